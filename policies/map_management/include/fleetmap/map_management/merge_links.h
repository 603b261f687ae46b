// How MERGE links a frame it adds to the server map (merge.h).
//
// Where: by the frame's own registration against the server's experiences near where its
// replay placed it, the placement serving only as the prior of a guided match (localiser.h
// Register), as COVINS and ORB-SLAM3 register a place before they weld maps. A placement composed
// through odometry keeps an uncertainty that grows with the distance it was composed over, so a
// link made from it says how far it can be trusted.
//
// Whether the links along one stretch agree with each other: RTAB-Map rejects a loop closure
// whose residual exceeds three standard deviations after optimisation; along a stretch
// the robot's own odometry already relates its frames, so each link is checked against its
// nearest neighbours on either side without a solve: link j, moved by the odometry from its
// frame to link k's and by the server's own poses from its node to link k's, must place link
// k's frame within 3 sigma of where link k puts it (both links', the odometry's and the server
// chain's uncertainty together).
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"

namespace fleetmap {

// A frame placed on the server: the pose of the frame in a server node, and its uncertainty.
struct Placement {
  enum class Source {
    kLocalised,   // the replay localised the frame there
    kComposed,    // odometry from a frame that localised (or from the segment's known start)
    kRegistered,  // registered against the node, guided by a placement of one of the above
  };
  Uuid node;
  Se3 node_T_frame = Se3::Identity();
  PoseCovariance covariance = PoseCovariance::Zero();
  Source source = Source::kLocalised;
};

class LinkRegistration {
 public:
  // `server` must outlive this; `options` are the replay's (their localiser, candidate radius
  // and search radius).
  LinkRegistration(const ExperienceMap& server, const BuilderOptions& options);

  // The best registration (most inliers) of `frame` against the server nodes nearest to where
  // `prior` puts it, searched within the candidate radius plus three of the prior's standard
  // deviations (at most the search radius); nodes of the frame's own outing are skipped (its
  // own odometry relates it to them already). When none registers, `prior` itself.
  struct Result {
    Placement placement;
    bool registered = false;
  };
  Result Register(const Landmarks& frame, const Node& node, const Placement& prior) const;

 private:
  static constexpr int kTargets = 3;  // nearest server nodes tried per frame

  const ExperienceMap& server_;
  BuilderOptions options_;
  Localiser localiser_;
};

// A link to check: its placement, and its frame's pose along the stretch (odometry from the
// stretch's first frame) with the odometry metres driven to it.
struct StretchLink {
  Placement at;
  Se3 stretch_T_frame = Se3::Identity();
  double travelled_m = 0.0;
};

// The server's pose of node `to` in node `from`, and its standard deviation in metres (the
// covariances its chain carries), when the server relates the two within its search.
struct ServerChain {
  Se3 from_T_to = Se3::Identity();
  double sigma_m = 0.0;
};
using ServerChainOf = std::function<std::optional<ServerChain>(const Uuid& from, const Uuid& to)>;

struct LinkConsistencyOptions {
  std::size_t neighbours = 2;  // links compared on each side
  double floor_m = 0.05;       // added to every comparison's sigma: poses are never exact
  OdometryNoise odometry_noise{};
};

// Per link, false where it disagrees with most of at least two of its neighbours.
std::vector<bool> ConsistentLinks(std::span<const StretchLink> links, const ServerChainOf& chain,
                                  const LinkConsistencyOptions& options);

}  // namespace fleetmap
