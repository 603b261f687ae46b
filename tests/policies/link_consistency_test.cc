// MERGE's check of the links along one stretch (merge_links.h): a link that its neighbours,
// moved by the robot's odometry and the server's own poses, place more than 3 sigma away from
// where it says is dropped; an uncertain link is not.
#include <gtest/gtest.h>

#include <vector>

#include "fleetmap/map_management/merge_links.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

Se3 At(double x, double z) {
  Se3 pose = Se3::Identity();
  pose.translation() = Eigen::Vector3d(x, 0.0, z);
  return pose;
}

PoseCovariance PositionSigma(double sigma_m) {
  PoseCovariance c = PoseCovariance::Zero();
  c.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma_m * sigma_m;
  return c;
}

// Five frames a metre apart along z, each linked to server node 1 or 2 (node 2 lies 2.5 m ahead
// of node 1 in the server's map) where they truly are.
std::vector<StretchLink> Straight() {
  std::vector<StretchLink> links;
  for (int k = 0; k < 5; ++k) {
    StretchLink link;
    const bool second = k >= 3;
    link.at.node = NumberedUuid(second ? 2 : 1);
    link.at.node_T_frame = At(0.0, second ? k - 2.5 : k);
    link.at.covariance = PositionSigma(0.05);
    link.stretch_T_frame = At(0.0, k);
    link.travelled_m = k;
    links.push_back(link);
  }
  return links;
}

std::optional<ServerChain> TwoNodes(const Uuid& from, const Uuid& to) {
  const double from_z = from == NumberedUuid(2) ? 2.5 : 0.0,
               to_z = to == NumberedUuid(2) ? 2.5 : 0.0;
  return ServerChain{At(0.0, to_z - from_z), 0.02};
}

TEST(LinkConsistency, LinksThatAgreeAreAllKept) {
  EXPECT_EQ(ConsistentLinks(Straight(), TwoNodes, {}), std::vector<bool>(5, true));
}

TEST(LinkConsistency, ALinkOneMetreOffItsNeighboursIsDropped) {
  std::vector<StretchLink> links = Straight();
  links[2].at.node_T_frame = links[2].at.node_T_frame * At(1.0, 0.0);
  EXPECT_EQ(ConsistentLinks(links, TwoNodes, {}),
            (std::vector<bool>{true, true, false, true, true}));
  // The same error on a link that says it may be a metre off is within its 3 sigma.
  links[2].at.covariance = PositionSigma(1.0);
  EXPECT_EQ(ConsistentLinks(links, TwoNodes, {}), std::vector<bool>(5, true));
}

TEST(LinkConsistency, TheServersOwnPosesBetweenNodesCount) {
  // The server puts node 2 a metre to the side of where the robot's odometry finds it.
  const auto skewed = [](const Uuid& from, const Uuid& to) -> std::optional<ServerChain> {
    std::optional<ServerChain> chain = TwoNodes(from, to);
    if (from != to)
      chain->from_T_to = chain->from_T_to * At(from == NumberedUuid(1) ? 1.0 : -1.0, 0.0);
    return chain;
  };
  // Link 3 (node 2) disagrees with links 1 and 2 (node 1) and agrees with link 4 alone; links 2
  // and 4 are split evenly and stay.
  EXPECT_EQ(ConsistentLinks(Straight(), skewed, {}),
            (std::vector<bool>{true, true, true, false, true}));
  // ... unless the server chain's own uncertainty covers it.
  const auto uncertain = [&](const Uuid& from, const Uuid& to) {
    std::optional<ServerChain> chain = skewed(from, to);
    chain->sigma_m = 1.0;
    return chain;
  };
  EXPECT_EQ(ConsistentLinks(Straight(), uncertain, {}), std::vector<bool>(5, true));
}

TEST(LinkConsistency, TooFewComparisonsKeepEverything) {
  std::vector<StretchLink> links = Straight();
  links[1].at.node_T_frame = links[1].at.node_T_frame * At(5.0, 0.0);
  links.resize(2);  // two links cannot say which of them is wrong
  EXPECT_EQ(ConsistentLinks(links, TwoNodes, {}), std::vector<bool>(2, true));
  // Nodes the server does not relate are not compared.
  links = Straight();
  links[2].at.node_T_frame = links[2].at.node_T_frame * At(5.0, 0.0);
  const auto unrelated = [](const Uuid&, const Uuid&) -> std::optional<ServerChain> {
    return std::nullopt;
  };
  EXPECT_EQ(ConsistentLinks(links, unrelated, {}), std::vector<bool>(5, true));
}

}  // namespace
}  // namespace fleetmap
