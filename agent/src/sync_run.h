// One sync of a robot with fleetmapd as a sequence of named steps (agent_sync.h says what each
// does), each over the protocol's exchanges (fleetmap/protocol/*.h): Prepare (plan the push,
// before the connect), Hello, PushAll, FollowMerges, Download, Install, ReportInstalled and,
// after a map that started over, RestoreOwnWork. It keeps what survives from one attempt to the
// next (the plan, the installed digest, the merge deadline), so a retry skips what is done.
//
// Threading: one thread; one SyncRun per sync.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/agent/agent_sync.h"
#include "fleetmap/agent/local_map.h"
#include "fleetmap/agent/sync_client.h"
#include "push_plan.h"

namespace fleetmap::agent_internal {

class SyncRun {
 public:
  SyncRun(LocalMap& map, const AgentSyncOptions& options, SyncResult& result);

  // One pass from the connect to the install; steps finished by an earlier pass are skipped.
  void Attempt();
  // After a failed attempt: the next server of the list (they share one store, so the push
  // resumes and the merge is waited for wherever the robot lands).
  void NextServer() { server_ = (server_ + 1) % servers_.size(); }
  const std::string& server() const { return servers_[server_]; }
  // Steps completed so far that a retry will not redo: a failure after one starts a new retry
  // window.
  int milestones() const { return milestones_; }

 private:
  using Clock = std::chrono::steady_clock;

  // A download as received: a full one written into its installation, changes in memory.
  struct Received {
    MapDownload download;  // full: what it is, no content
    std::unique_ptr<MapInstallation> installation;
  };

  // The steps, in order.
  void Prepare();
  void StartOverIfLost();
  void Hello(SyncClient& client, bool report_error = true);
  void Exchange(SyncClient& client);
  void PushAll(SyncClient& client);
  void Push(SyncClient& client, Uuid submission, const PlannedSubmission& content);
  void FollowMerges(SyncClient& client);
  v1::MergeStatus FollowMerge(SyncClient& client, const Uuid& submission, bool wait);
  Received Download(SyncClient& client);
  void ReceiveChunks(SyncClient& client, const std::string& during, Received& received);
  InstallReport Install(Received& received);
  void ReportInstalled(const InstallReport& report);
  void RestoreOwnWork();

  // What the server takes, as its last welcome said (or fleetmapd's defaults), within what
  // this agent's link sends.
  ServerLimits CurrentLimits() const;
  void RecordPushOutcome(const Uuid& submission, const PlannedSubmission& content,
                         const v1::PushAccepted& accepted);
  void SayPlanned(const PushPlan& plan, const ServerLimits& limits, double seconds) const;
  void SayInstalled(const InstallReport& report) const;
  void Progress(const std::string& line) const;
  static void SayBye(SyncClient& client);

  LocalMap& map_;
  const AgentSyncOptions& options_;
  SyncResult& result_;
  std::vector<std::string> servers_;
  std::size_t server_ = 0;
  std::optional<Clock::time_point> merge_deadline_;
  int milestones_ = 0;
  // What is left to push, planned before the connect; kept across retries.
  std::optional<PushPlan> plan_;
  // The installed selection's digest: as read back before the first connect, then as installed.
  std::optional<std::uint64_t> installed_digest_;
  std::size_t removed_ = 0;  // elements the last download removed
};

}  // namespace fleetmap::agent_internal
