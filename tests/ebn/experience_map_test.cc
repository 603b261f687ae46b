// The experience map's neighbourhood search: how far it reaches grows with the uncertainty of
// the estimate and of the edges it composes along, and never beyond its bound.
#include "fleetmap/ebn/experience_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <optional>
#include <vector>

#include "corridor_scene.h"
#include "fleetmap/core/se3.h"

namespace fleetmap {
namespace {

// A covariance whose position part has `sigma_m` on every axis.
PoseCovariance PositionOnly(double sigma_m) {
  PoseCovariance c = PoseCovariance::Zero();
  c.bottomRightCorner<3, 3>() = Eigen::Matrix3d::Identity() * sigma_m * sigma_m;
  return c;
}

Se3 Ahead(double metres) {
  Se3 pose = Se3::Identity();
  pose.translation() = Eigen::Vector3d(0.0, 0.0, metres);
  return pose;
}

class NeighbourhoodReach : public ::testing::Test {
 protected:
  // a -> b five metres ahead, the edge's covariance `edge` when given.
  void Build(const std::optional<PoseCovariance>& edge) {
    for (Uuid* id : {&a_, &b_}) {
      Node node;
      node.id = *id = Uuid::Generate();
      node.robot = node.outing = Uuid::Generate();
      map_.AddNode(node, Landmarks{});
    }
    map_.AddMetricEdge(a_, b_, Ahead(5.0), edge);
  }

  // The nodes near the origin a's own position, reached within `reach`.
  std::vector<Uuid> Near(const ExperienceMap::Reach& reach) const {
    std::vector<Uuid> ids;
    for (const ExperienceMap::Nearby& near :
         map_.Neighbourhood(*map_.Find(a_), Eigen::Vector3d::Zero(), reach, 25.0)) {
      ids.push_back(map_.at(near.node).node.id);
    }
    return ids;
  }

  bool Reaches(const ExperienceMap::Reach& reach) const {
    const std::vector<Uuid> ids = Near(reach);
    return std::find(ids.begin(), ids.end(), b_) != ids.end();
  }

  ExperienceMap map_{SharedCorridorVocabulary()};
  Uuid a_, b_;
};

TEST_F(NeighbourhoodReach, WithNoUncertaintyTheRadiusIsFixed) {
  Build(std::nullopt);
  EXPECT_FALSE(Reaches({.radius_m = 2.0, .max_radius_m = 8.0}));
  EXPECT_TRUE(Reaches({.radius_m = 5.5, .max_radius_m = 5.5}));
}

TEST_F(NeighbourhoodReach, TheEstimatesUncertaintyWidensTheRadius) {
  Build(std::nullopt);
  // 2 m + 3 x 1.2 m = 5.6 m reaches b at 5 m; 3 x 0.8 m does not.
  EXPECT_TRUE(Reaches({.radius_m = 2.0, .max_radius_m = 8.0, .position_sigma_m = 1.2}));
  EXPECT_FALSE(Reaches({.radius_m = 2.0, .max_radius_m = 8.0, .position_sigma_m = 0.8}));
  // Never beyond the bound, however uncertain.
  EXPECT_FALSE(Reaches({.radius_m = 2.0, .max_radius_m = 4.0, .position_sigma_m = 10.0}));
}

TEST_F(NeighbourhoodReach, AnEdgesCovarianceWidensTheRadiusBeyondIt) {
  Build(PositionOnly(1.2));
  EXPECT_TRUE(Reaches({.radius_m = 2.0, .max_radius_m = 8.0}));
  EXPECT_FALSE(Reaches({.radius_m = 2.0, .max_radius_m = 4.0}));
  for (const ExperienceMap::Nearby& near :
       map_.Neighbourhood(*map_.Find(a_), Eigen::Vector3d::Zero(),
                          ExperienceMap::Reach{.radius_m = 2.0, .max_radius_m = 8.0}, 25.0)) {
    if (map_.at(near.node).node.id != b_) continue;
    EXPECT_NEAR(near.sigma_m, 1.2, 1e-9);
    ASSERT_TRUE(near.covariance.has_value());
  }
  // The edge read backwards carries the inverse's covariance: the same position spread here.
  std::vector<ExperienceMap::Nearby> from_b =
      map_.Neighbourhood(*map_.Find(b_), Eigen::Vector3d::Zero(),
                         ExperienceMap::Reach{.radius_m = 2.0, .max_radius_m = 8.0}, 25.0);
  EXPECT_EQ(from_b.size(), 2u);
}

TEST_F(NeighbourhoodReach, AnEdgeWithAPreciseCovarianceDoesNotWiden) {
  Build(PositionOnly(0.05));
  EXPECT_FALSE(Reaches({.radius_m = 2.0, .max_radius_m = 8.0}));
}

}  // namespace
}  // namespace fleetmap
