// fleetmapd and fleetmap-agent as real processes on loopback, for the experiments that go
// through the fleet's real sync path (the fleet demo, real-merge, the real fleet loop) and for
// the tests that run them (tests/support/fleet_processes.h wraps these for GoogleTest): robots
// registered in the central store before the server opens it, fleetmapd started and stopped
// with a drain, and `fleetmap-agent sync --json` run for a robot whose map directory holds its
// map.
//
// Every process ends with its owner (ChildProcess SIGKILLs what is left), also on a throw.
// One thread at a time per object.
#pragma once

#include <chrono>
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

// A robot as the server knows it, with the map directory `fleetmap-agent` syncs
// (MAP_DIR/map.db is the robot's map, local_map.h).
struct FleetRobot {
  std::string name;
  Uuid id;
  std::string token;
  std::filesystem::path map_dir;
};

// Registers `name` in the store at `store_uri` (before fleetmapd opens it, or beside it) with
// the map directory `map_dir`, created if missing. Throws what GraphStore::Open and the
// registry throw.
FleetRobot RegisterFleetRobot(const std::string& store_uri, const std::string& name,
                              const std::filesystem::path& map_dir);
// Each of `names` so, with the map directory robots_dir/NAME.
std::vector<FleetRobot> RegisterFleetRobots(const std::string& store_uri,
                                            const std::vector<std::string>& names,
                                            const std::filesystem::path& robots_dir);

// Throws Error(kInvalidArgument), prefixed by `what`, naming the first program that is not a
// file and how to build it.
void RequireExecutables(const std::string& what,
                        const std::vector<std::filesystem::path>& programs);

// The last `lines` lines of a log, each on an indented line of its own: for an error message
// that says what the process said.
std::string LogTail(const std::filesystem::path& log, std::size_t lines);

// fleetmapd on 127.0.0.1 (any free ports) for the object's lifetime; stderr to `log`.
class FleetServerProcess {
 public:
  // Throws Error(kBackend) with the log's tail when it does not say it listens within 30 s.
  FleetServerProcess(const std::filesystem::path& fleetmapd, const std::string& store_uri,
                     const std::filesystem::path& log);
  ~FleetServerProcess() { Stop(); }
  FleetServerProcess(const FleetServerProcess&) = delete;
  FleetServerProcess& operator=(const FleetServerProcess&) = delete;

  // SIGTERM, a drain of up to 20 s, then SIGKILL: its exit status (nullopt when it had to be
  // killed). Later calls return the first one's answer.
  std::optional<int> Stop();

  const std::string& address() const { return address_; }        // HOST:PORT of the sync port
  const std::string& status_url() const { return status_url_; }  // empty without one

 private:
  ChildProcess process_;
  std::string address_;
  std::string status_url_;
  bool stopped_ = false;
  std::optional<int> status_;
};

// `AGENT sync --server SERVER --robot ID --map-dir MAP_DIR --json EXTRA...` for `robot` (its
// token in the environment), started, not waited for; stderr to `log`.
ChildProcess StartAgentSync(const std::filesystem::path& agent, const FleetRobot& robot,
                            const std::string& server, const std::vector<std::string>& extra,
                            const std::filesystem::path& log);

// How long an experiment waits for one agent's sync: a cold download of a whole map and a merge
// behind the other robots' on a 2-core machine, with room to spare.
constexpr std::chrono::milliseconds kSyncTimeout{150'000};

// How a sync StartAgentSync started ended.
struct AgentSyncEnd {
  std::optional<int> exit;  // nullopt: still running after the wait (then killed with it)
  std::string out;          // what it printed on stdout
  nlohmann::json result;    // `out` parsed: the --json result; null when `out` is empty or not JSON
  std::string json_error;   // why a non-empty `out` is not JSON; else empty
};
// Reads the agent's output for up to `timeout`, then waits (10 s at most) for it to exit.
AgentSyncEnd WaitAgentSync(ChildProcess& sync, std::chrono::milliseconds timeout);

// WaitAgentSync, then its --json result. Throws Error(kBackend) naming the robot, the exit
// status and the log's tail when it failed or did not finish, and naming the log when it
// printed no JSON.
nlohmann::json FinishAgentSync(ChildProcess& sync, const FleetRobot& robot,
                               const std::filesystem::path& log, std::chrono::milliseconds timeout);

}  // namespace fleetmap
