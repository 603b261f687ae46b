// Real fleetmap-agent processes beside a real fleetmapd (fleetmapd_process.h) on 127.0.0.1
// for the cross-process tests: register robots in the server's store, write a robot's local
// map, run an agent sync and read its --json result. The processes are the experiments' own
// (fleetmap/runners/fleet_processes.h); what is here reports to GoogleTest instead of throwing.
// Every wait is bounded; ChildProcess kills what is still running when a test ends.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/runners/fleet_processes.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmapd_process.h"
#include "random_robot_map.h"

namespace fleetmap::testing {

using std::chrono::milliseconds;

// The whole file, for a failure message.
inline std::string ReadLog(const std::filesystem::path& log) {
  std::ifstream in(log);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

using TestRobot = FleetRobot;

inline TestRobot RegisterRobot(const std::string& store_uri, const std::string& name,
                               const std::filesystem::path& map_dir) {
  return RegisterFleetRobot(store_uri, name, map_dir);
}

// Writes `map` into the robot's local map (what its EBN builder would have done).
inline void WriteLocalMap(const TestRobot& robot, const GraphBatch& map) {
  GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->Put(map);
}

// `fleetmap-agent sync ... --json` for `robot`, started (not waited for).
inline std::unique_ptr<ChildProcess> StartSync(const TestRobot& robot, const std::string& server,
                                               const std::filesystem::path& log,
                                               std::vector<std::string> extra = {}) {
  return std::make_unique<ChildProcess>(
      StartAgentSync(FLEETMAP_AGENT_PATH, robot, server, extra, log));
}

struct SyncOutcome {
  int exit = -1;
  nlohmann::json result;  // the --json object (null when it printed none)
};

// Waits for an agent started by StartSync (bounded) and parses its result.
inline SyncOutcome FinishSync(ChildProcess& agent, const std::filesystem::path& log,
                              milliseconds timeout = milliseconds(120'000)) {
  const AgentSyncEnd end = WaitAgentSync(agent, timeout);
  SyncOutcome outcome;
  outcome.exit = end.exit.value_or(-1);
  outcome.result = end.result;
  if (!end.json_error.empty()) {
    ADD_FAILURE() << "agent printed no JSON: " << end.out << "\n" << ReadLog(log);
  }
  if (outcome.exit != 0) ADD_FAILURE() << "agent exit " << outcome.exit << ":\n" << ReadLog(log);
  return outcome;
}

}  // namespace fleetmap::testing
