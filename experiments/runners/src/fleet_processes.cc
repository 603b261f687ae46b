#include "fleetmap/runners/fleet_processes.h"

#include <signal.h>

#include <fstream>
#include <memory>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/robot_registry.h"

namespace fleetmap {

namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;

constexpr auto kServerStartTimeout = milliseconds(30'000);
constexpr auto kDrainTimeout = milliseconds(20'000);
// For an agent to exit once its output has ended.
constexpr auto kExitTimeout = milliseconds(10'000);

FleetRobot Register(RobotRegistry& registry, const std::string& name, const fs::path& map_dir) {
  NewRobot added = registry.Add(name, WallClockNs());
  fs::create_directories(map_dir);
  return {name, added.robot.id, added.token, map_dir};
}

}  // namespace

FleetRobot RegisterFleetRobot(const std::string& store_uri, const std::string& name,
                              const fs::path& map_dir) {
  const std::unique_ptr<Repository> central = Repository::Open(store_uri);
  RobotRegistry registry(*central);
  return Register(registry, name, map_dir);
}

std::vector<FleetRobot> RegisterFleetRobots(const std::string& store_uri,
                                            const std::vector<std::string>& names,
                                            const fs::path& robots_dir) {
  const std::unique_ptr<Repository> central = Repository::Open(store_uri);
  RobotRegistry registry(*central);
  std::vector<FleetRobot> robots;
  for (const std::string& name : names)
    robots.push_back(Register(registry, name, robots_dir / name));
  return robots;
}

void RequireExecutables(const std::string& what, const std::vector<fs::path>& programs) {
  for (const fs::path& program : programs) {
    if (!fs::is_regular_file(program)) {
      throw Error(ErrorCode::kInvalidArgument,
                  what + ": no executable at " + program.string() + " (build it: scripts/build)");
    }
  }
}

std::string LogTail(const fs::path& log, std::size_t lines) {
  std::ifstream in(log);
  std::vector<std::string> all;
  for (std::string line; std::getline(in, line);) all.push_back(line);
  std::string out;
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i) {
    out += "\n    " + all[i];
  }
  return out;
}

FleetServerProcess::FleetServerProcess(const fs::path& fleetmapd, const std::string& store_uri,
                                       const fs::path& log)
    : process_({fleetmapd.string(), "--store", store_uri, "--listen", "127.0.0.1:0", "--http",
                "127.0.0.1:0"},
               {.stderr_file = log, .environment = {}}) {
  const std::optional<std::string> line =
      process_.ReadLineContaining("listening on", kServerStartTimeout);
  if (!line) {
    throw Error(ErrorCode::kBackend,
                "fleetmapd did not start (log " + log.string() + "):" + LogTail(log, 10));
  }
  address_ = line->substr(line->rfind(' ') + 1);
  if (std::optional<std::string> http =
          process_.ReadLineContaining("http on", milliseconds(5000))) {
    status_url_ = "http://" + http->substr(http->rfind(' ') + 1) + "/";
  }
}

std::optional<int> FleetServerProcess::Stop() {
  if (!stopped_) {
    stopped_ = true;
    process_.Signal(SIGTERM);
    status_ = process_.Wait(kDrainTimeout);
    if (!status_) {
      process_.Signal(SIGKILL);
      process_.Wait(milliseconds(5000));
    }
  }
  return status_;
}

ChildProcess StartAgentSync(const fs::path& agent, const FleetRobot& robot,
                            const std::string& server, const std::vector<std::string>& extra,
                            const fs::path& log) {
  std::vector<std::string> argv{agent.string(), "sync",
                                "--server",     server,
                                "--robot",      robot.id.ToString(),
                                "--map-dir",    robot.map_dir.string(),
                                "--json"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  return ChildProcess(argv, ChildProcessOptions{.stderr_file = log,
                                                .environment = {{"FLEETMAP_TOKEN", robot.token}}});
}

AgentSyncEnd WaitAgentSync(ChildProcess& sync, milliseconds timeout) {
  AgentSyncEnd end;
  end.out = sync.ReadRest(timeout);
  end.exit = sync.Wait(kExitTimeout);
  if (!end.out.empty()) {
    try {
      end.result = nlohmann::json::parse(end.out);
    } catch (const nlohmann::json::exception& e) {
      end.json_error = e.what();
    }
  }
  return end;
}

nlohmann::json FinishAgentSync(ChildProcess& sync, const FleetRobot& robot, const fs::path& log,
                               milliseconds timeout) {
  AgentSyncEnd end = WaitAgentSync(sync, timeout);
  if (end.exit != 0) {
    throw Error(ErrorCode::kBackend, "fleetmap-agent of " + robot.name + " failed (exit " +
                                         (end.exit ? std::to_string(*end.exit) : "timeout") +
                                         ", log " + log.string() + "):" + LogTail(log, 8));
  }
  if (end.result.is_null()) {
    throw Error(ErrorCode::kBackend,
                "fleetmap-agent of " + robot.name + " printed no JSON result (log " + log.string() +
                    "): " + (end.json_error.empty() ? "nothing" : end.json_error));
  }
  return std::move(end.result);
}

}  // namespace fleetmap
