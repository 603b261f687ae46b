#include <algorithm>
#include <cmath>

#include "fleetmap/map_management/merge_links.h"

namespace fleetmap {

std::vector<bool> ConsistentLinks(std::span<const StretchLink> links, const ServerChainOf& chain,
                                  const LinkConsistencyOptions& options) {
  std::vector<bool> consistent(links.size(), true);
  if (links.size() < 3) return consistent;  // two that disagree cannot say which is wrong
  const double floor_variance = options.floor_m * options.floor_m;
  for (std::size_t k = 0; k < links.size(); ++k) {
    const StretchLink& link = links[k];
    const double link_variance =
        std::pow(PositionSigma(link.at.node_T_frame, link.at.covariance), 2);
    int agree = 0, disagree = 0;
    const std::size_t lo = k >= options.neighbours ? k - options.neighbours : 0;
    const std::size_t hi = std::min(links.size(), k + options.neighbours + 1);
    for (std::size_t j = lo; j < hi; ++j) {
      if (j == k) continue;
      const StretchLink& other = links[j];
      const std::optional<ServerChain> server = chain(link.at.node, other.at.node);
      if (!server) continue;
      // Link k's frame as link j and the odometry place it, in link k's node.
      const Se3 j_T_k = other.stretch_T_frame.inverse() * link.stretch_T_frame;
      const Se3 predicted = server->from_T_to * other.at.node_T_frame * j_T_k;
      const double odometry = std::abs(link.travelled_m - other.travelled_m);
      const PoseCovariance other_in_k = ComposeCovariance(
          server->from_T_to, PoseCovariance::Zero(),
          ComposeCovariance(other.at.node_T_frame, other.at.covariance,
                            OdometryCovariance(odometry, options.odometry_noise)));
      const double sigma =
          std::sqrt(link_variance + std::pow(PositionSigma(predicted, other_in_k), 2) +
                    server->sigma_m * server->sigma_m + floor_variance);
      const double residual = (predicted.translation() - link.at.node_T_frame.translation()).norm();
      ++(residual <= 3.0 * sigma ? agree : disagree);
    }
    consistent[k] = !(agree + disagree >= 2 && disagree > agree);
  }
  return consistent;
}

}  // namespace fleetmap
