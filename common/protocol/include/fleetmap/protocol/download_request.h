// A download request's parameters as a robot states them (seed 004 §V-B: which subset of the map
// a mission takes), and their one conversion to and from each form they travel in: the agent's
// flags fill them, the agent's sync state keeps them as JSON (to ask for changes only when the
// next request is the same), the wire carries them as sync.proto DownloadRequest, and the server
// turns them into a DownloadPolicy (map_management/download_policy.h PolicyOfRequest).
//
// The server's default: a numeric parameter of 0 (window, percent, budget, epoch, route radius)
// leaves the policy's own default, and PolicyOfRequest is the one place that applies it (proto3
// cannot tell 0 from unset, so 0 is the only way to say "default"). The mission start has no
// default: 0 is midnight.
#pragma once

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"

namespace fleetmap {

// Positions a route may have: a 10 km drive at a metre apart. An authenticated robot still gets
// a bounded amount of the server's work per request.
inline constexpr int kMaxRoutePositions = 10'000;

struct DownloadParams {
  std::string policy = "copy";  // download_policy.h names
  double mission_start_min = 0.0;
  double window_min = 0.0;          // 0: the server's default
  double best_percent = 0.0;        // 0: the server's default
  std::int64_t budget_bytes = 0;    // 0: the server's default
  double epoch_min = 0.0;           // 0: the server's default
  std::vector<Uuid> include_nodes;  // nodes every download keeps (where the robot is docked)
  // The release channel followed: "head" (the head), or a channel the depot sets with
  // `fleetmap channel set`.
  std::string channel = "head";
  // A route: the map within route_radius_m (0: the server's default) of an earlier outing, or of
  // positions (x y z metres, flattened) in an anchor node's frame.
  std::optional<Uuid> route_outing;
  std::optional<Uuid> route_anchor;
  std::vector<double> route_xyz;
  double route_radius_m = 0.0;

  bool has_route() const { return route_outing || route_anchor || !route_xyz.empty(); }
  friend bool operator==(const DownloadParams&, const DownloadParams&) = default;
};

// The request on the wire, for the changes since `base_revision` (0: the whole selection).
v1::DownloadRequest DownloadRequestOf(const DownloadParams& params, std::int64_t base_revision);

// The parameters a request states ("head" for a request naming no channel). Throws
// Error(kInvalidArgument) naming what is malformed: an id that is not 16 bytes, route
// coordinates that are not whole x y z positions or more than kMaxRoutePositions of them.
DownloadParams DownloadParamsOf(const v1::DownloadRequest& request);

// As the agent's state keeps them; a state written before channels and routes reads as the
// head without a route. FromJson throws nlohmann::json's errors for a malformed object and
// Error(kInvalidArgument) for a malformed id.
nlohmann::json DownloadParamsToJson(const DownloadParams& params);
DownloadParams DownloadParamsFromJson(const nlohmann::json& object);

}  // namespace fleetmap
