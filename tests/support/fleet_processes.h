// Real fleetmap-agent processes beside a real fleetmapd (fleetmapd_process.h) on 127.0.0.1
// for the cross-process tests: register robots in the server's store, write a robot's local
// map, run an agent sync and read its --json result. Every wait is
// bounded; ChildProcess kills what is still running when a test ends.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/repository/robot_registry.h"
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

struct TestRobot {
  Uuid id;
  std::string name;
  std::string token;
  std::filesystem::path map_dir;
};

inline TestRobot RegisterRobot(const std::string& store_uri, const std::string& name,
                               const std::filesystem::path& map_dir) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(store_uri);
  RobotRegistry registry(store->versions());
  NewRobot added = registry.Add(name, WallNs());
  std::filesystem::create_directories(map_dir);
  return {added.robot.id, name, added.token, map_dir};
}

// Writes `map` into the robot's local map (what its EBN builder would have done).
inline void WriteLocalMap(const TestRobot& robot, const GraphBatch& map) {
  GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->Put(map);
}

// `fleetmap-agent sync ... --json` for `robot`, started (not waited for).
inline std::unique_ptr<ChildProcess> StartSync(const TestRobot& robot, const std::string& server,
                                               const std::filesystem::path& log,
                                               std::vector<std::string> extra = {}) {
  std::vector<std::string> argv = {FLEETMAP_AGENT_PATH,
                                   "sync",
                                   "--server",
                                   server,
                                   "--robot",
                                   robot.id.ToString(),
                                   "--map-dir",
                                   robot.map_dir.string(),
                                   "--json"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return std::make_unique<ChildProcess>(
      argv,
      ChildProcessOptions{.stderr_file = log, .environment = {{"FLEETMAP_TOKEN", robot.token}}});
}

struct SyncOutcome {
  int exit = -1;
  nlohmann::json result;  // the --json object (null when it printed none)
};

// Waits for an agent started by StartSync (bounded) and parses its result.
inline SyncOutcome FinishSync(ChildProcess& agent, const std::filesystem::path& log,
                              milliseconds timeout = milliseconds(120'000)) {
  SyncOutcome outcome;
  const std::string out = agent.ReadRest(timeout);
  const std::optional<int> status = agent.Wait(milliseconds(10'000));
  outcome.exit = status.value_or(-1);
  try {
    if (!out.empty()) outcome.result = nlohmann::json::parse(out);
  } catch (const nlohmann::json::exception&) {
    ADD_FAILURE() << "agent printed no JSON: " << out << "\n" << ReadLog(log);
  }
  if (outcome.exit != 0) ADD_FAILURE() << "agent exit " << outcome.exit << ":\n" << ReadLog(log);
  return outcome;
}

}  // namespace fleetmap::testing
