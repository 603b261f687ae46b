#include "fleetmap/map_management/download_policy.h"

namespace fleetmap {

DownloadPolicy PolicyOfRequest(const DownloadParams& params) {
  DownloadPolicy policy = ParseDownloadPolicy(params.policy);
  policy.mission_start_min = params.mission_start_min;
  // 0 (and anything not above it) leaves the policy's default: proto3 cannot say "unset".
  if (params.window_min > 0) policy.window_min = params.window_min;
  if (params.best_percent > 0) policy.best_percent = params.best_percent;
  if (params.epoch_min > 0) policy.epoch_min = params.epoch_min;
  if (params.budget_bytes > 0 && policy.budget_bytes) policy.budget_bytes = params.budget_bytes;
  policy.include = params.include_nodes;
  if (params.has_route()) {
    DownloadRoute& route = policy.route ? *policy.route : policy.route.emplace();
    route.outing = params.route_outing;
    route.anchor = params.route_anchor;
    for (std::size_t i = 0; i + 2 < params.route_xyz.size(); i += 3) {
      route.anchor_p_m.emplace_back(params.route_xyz[i], params.route_xyz[i + 1],
                                    params.route_xyz[i + 2]);
    }
    if (params.route_radius_m > 0) route.radius_m = params.route_radius_m;
  }
  ValidateDownloadPolicy(policy);
  ValidateChannelName(params.channel);
  return policy;
}

void SetRequestRoute(DownloadParams& params, const DownloadRoute& route, double radius_m) {
  params.route_outing = route.outing;
  params.route_anchor = route.anchor;
  params.route_xyz.clear();
  for (const Eigen::Vector3d& p : route.anchor_p_m) {
    params.route_xyz.insert(params.route_xyz.end(), {p.x(), p.y(), p.z()});
  }
  params.route_radius_m = radius_m;
}

}  // namespace fleetmap
