#include "fleetmap/protocol/download_request.h"

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// A route's node or outing id as the wire carries it (empty: none).
std::optional<Uuid> RouteIdOf(const std::string& bytes) {
  if (bytes.empty()) return std::nullopt;
  if (bytes.size() != Uuid::kSize) {
    throw Error(ErrorCode::kInvalidArgument, "route: a node or outing id of " +
                                                 std::to_string(bytes.size()) +
                                                 " bytes (ids are 16 bytes)");
  }
  return Uuid::FromBytes(bytes);
}

}  // namespace

v1::DownloadRequest DownloadRequestOf(const DownloadParams& params, std::int64_t base_revision) {
  // Every field is set as it is, zeros included: proto3 writes no zero, so a request's bytes
  // are those of its parameters whatever the writer.
  v1::DownloadRequest request;
  request.set_policy(params.policy);
  request.set_mission_start_min(params.mission_start_min);
  request.set_window_min(params.window_min);
  request.set_best_percent(params.best_percent);
  request.set_budget_bytes(params.budget_bytes);
  request.set_epoch_min(params.epoch_min);
  request.set_base_revision(base_revision);
  for (const Uuid& node : params.include_nodes) request.add_include_nodes(node.ToBytesString());
  request.set_channel(params.channel);
  if (params.route_outing) request.set_route_outing(params.route_outing->ToBytesString());
  if (params.route_anchor) request.set_route_anchor(params.route_anchor->ToBytesString());
  for (const double value : params.route_xyz) request.add_route_xyz(value);
  request.set_route_radius_m(params.route_radius_m);
  return request;
}

DownloadParams DownloadParamsOf(const v1::DownloadRequest& request) {
  DownloadParams params;
  params.policy = request.policy();
  params.mission_start_min = request.mission_start_min();
  params.window_min = request.window_min();
  params.best_percent = request.best_percent();
  params.budget_bytes = request.budget_bytes();
  params.epoch_min = request.epoch_min();
  for (const std::string& node : request.include_nodes()) {
    params.include_nodes.push_back(Uuid::FromBytes(node));
  }
  params.channel = request.channel().empty() ? std::string("head") : request.channel();
  params.route_outing = RouteIdOf(request.route_outing());
  params.route_anchor = RouteIdOf(request.route_anchor());
  if (request.route_xyz_size() > 3 * kMaxRoutePositions) {
    throw Error(ErrorCode::kInvalidArgument,
                "route: " + std::to_string(request.route_xyz_size() / 3) +
                    " positions, over this server's " + std::to_string(kMaxRoutePositions));
  }
  if (request.route_xyz_size() % 3 != 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "route: " + std::to_string(request.route_xyz_size()) +
                    " coordinates, not a whole number of x y z positions");
  }
  params.route_xyz.assign(request.route_xyz().begin(), request.route_xyz().end());
  params.route_radius_m = request.route_radius_m();
  return params;
}

nlohmann::json DownloadParamsToJson(const DownloadParams& params) {
  nlohmann::json include = nlohmann::json::array();
  for (const Uuid& id : params.include_nodes) include.push_back(id.ToString());
  nlohmann::json object = {{"policy", params.policy},
                           {"mission_start_min", params.mission_start_min},
                           {"window_min", params.window_min},
                           {"best_percent", params.best_percent},
                           {"budget_bytes", params.budget_bytes},
                           {"epoch_min", params.epoch_min},
                           {"include_nodes", include},
                           {"channel", params.channel},
                           {"route_xyz", params.route_xyz},
                           {"route_radius_m", params.route_radius_m}};
  if (params.route_outing) object["route_outing"] = params.route_outing->ToString();
  if (params.route_anchor) object["route_anchor"] = params.route_anchor->ToString();
  return object;
}

DownloadParams DownloadParamsFromJson(const nlohmann::json& object) {
  DownloadParams params;
  params.policy = object.at("policy").get<std::string>();
  params.mission_start_min = object.at("mission_start_min").get<double>();
  params.window_min = object.at("window_min").get<double>();
  params.best_percent = object.at("best_percent").get<double>();
  params.budget_bytes = object.at("budget_bytes").get<std::int64_t>();
  params.epoch_min = object.at("epoch_min").get<double>();
  for (const nlohmann::json& item : object.at("include_nodes")) {
    params.include_nodes.push_back(Uuid::Parse(item.get<std::string>()));
  }
  // A state written before channels and routes has none of these: the head, no route.
  params.channel = object.value("channel", std::string("head"));
  if (object.contains("route_xyz")) {
    params.route_xyz = object["route_xyz"].get<std::vector<double>>();
  }
  params.route_radius_m = object.value("route_radius_m", 0.0);
  if (object.contains("route_outing")) {
    params.route_outing = Uuid::Parse(object["route_outing"].get<std::string>());
  }
  if (object.contains("route_anchor")) {
    params.route_anchor = Uuid::Parse(object["route_anchor"].get<std::string>());
  }
  return params;
}

}  // namespace fleetmap
