// The fleet demo (`fleetmap demo`, the README's main command): a repository server and a few
// robots, as real processes on loopback, over several forays of the synthetic world.
//
// It starts `fleetmapd` on a SQLite store in `work_dir`, registers the robots, and then per
// foray: each robot drives one scheduled outing of the world through single-agent EBN on its
// own local map (DIR/robots/NAME/map.db, the map `fleetmap-agent` owns), adding experiences
// where it fails to localise; then all robots dock at once and run `fleetmap-agent sync`
// (push what is new, wait for the merge, pull the next mission's subset by `policy`). The
// robots' next foray starts from what they pulled, so what one robot learnt helps the others
// (seed 004 §VI-C, Fig. 8).
//
// Every process it starts ends with it (SIGTERM and a drain for fleetmapd, SIGKILL for
// anything left), also when it throws.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "fleetmap/world/world_config.h"

namespace fleetmap {

// One robot in one foray: its drive, then its sync at the dock.
struct RobotForay {
  std::string robot;
  int frames = 0;                      // frames of its outing
  int localised = 0;                   // frames that localised in its map
  std::int64_t nodes_after_drive = 0;  // its local map when it docked
  std::int64_t pushed_nodes = 0;       // new experiences it pushed
  std::int64_t nodes_held = 0;         // its local map after the sync (the pulled subset)
  std::int64_t bytes_sent = 0;         // on the wire, both ways
  std::int64_t bytes_received = 0;
  bool incremental = false;  // the pull sent only what changed
  double sync_seconds = 0.0;
};

struct ForayReport {
  int foray = 0;              // 1, 2, ...
  std::string mission_start;  // HH:MM of the outings driven
  std::vector<RobotForay> robots;
  std::int64_t server_revision = 0;  // after every robot synced
  std::int64_t server_nodes = 0;
};

struct FleetDemoOptions {
  int robots = 3;                    // [1, 8]
  int forays = 6;                    // [1, 20]
  std::string policy = "tod+paths";  // what robots pull (download_policy.h)
  std::filesystem::path work_dir;    // required, empty or new: stores, robots' maps, logs
  std::filesystem::path out_dir;     // required: plots and the per-foray CSV
  std::filesystem::path fleetmapd;   // the executables
  std::filesystem::path agent;
  WorldConfig world{};
  // One line per step, for a person watching (may be empty).
  std::function<void(const std::string&)> progress;
  // Each foray's report as soon as every robot synced (may be empty).
  std::function<void(const ForayReport&)> foray_done;
};

struct FleetDemoResult {
  std::vector<ForayReport> forays;
  std::filesystem::path csv;
  std::vector<std::filesystem::path> plots;  // empty when gnuplot is missing
  double seconds = 0.0;
};

// Throws Error(kInvalidArgument) for options out of range or missing executables, and Error
// with the process's own message when fleetmapd or an agent fails (its log's path included).
FleetDemoResult RunFleetDemo(const FleetDemoOptions& options);

}  // namespace fleetmap
