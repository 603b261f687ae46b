// fleetmapd and fleetmap-agent as real processes on loopback, for the experiments that go
// through the fleet's real sync path (the fleet demo, real-merge): robots registered in the
// central store before the server opens it, fleetmapd started and stopped with a drain, and
// `fleetmap-agent sync` run for a robot whose map directory its EBN builder wrote.
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
// (DIR/map.db is the robot's map, local_map.h).
struct FleetRobot {
  std::string name;
  Uuid id;
  std::string token;
  std::filesystem::path dir;
};

// Registers each of `names` in the store at `store_uri` (before fleetmapd opens it) with the
// map directory robots_dir/NAME, created empty. Throws what GraphStore::Open and the registry
// throw.
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

// `fleetmap-agent sync --server SERVER --robot ID --map-dir DIR --wait-merge --json EXTRA...`
// for `robot` (its token in the environment), started, not waited for; stderr to `log`.
ChildProcess StartAgentSync(const std::filesystem::path& agent, const FleetRobot& robot,
                            const std::string& server, const std::vector<std::string>& extra,
                            const std::filesystem::path& log);

// How long an experiment waits for one agent's sync: a cold download of a whole map and a merge
// behind the other robots' on a 2-core machine, with room to spare.
constexpr std::chrono::milliseconds kSyncTimeout{150'000};

// Waits up to `timeout` for a sync StartAgentSync started and returns its --json result.
// Throws Error(kBackend) naming the robot, the exit status and the log's tail when it failed
// or did not finish.
nlohmann::json FinishAgentSync(ChildProcess& sync, const FleetRobot& robot,
                               const std::filesystem::path& log, std::chrono::milliseconds timeout);

}  // namespace fleetmap
