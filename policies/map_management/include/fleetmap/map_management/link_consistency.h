// Whether the links MERGE makes along one stretch agree with each other: RTAB-Map rejects a loop
// closure whose residual exceeds three standard deviations after optimisation; along a stretch
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

#include "fleetmap/core/pose_covariance.h"
#include "fleetmap/map_management/link_registration.h"

namespace fleetmap {

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
