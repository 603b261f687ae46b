// What fleetmapd counts while it runs, and the facts about the store it last learned, from
// which SyncServer::Status() takes a FleetStatus snapshot. Sessions, the merge thread and the
// store workers record into it; nothing here touches the store.
//
// Threading: every member is safe from any thread (one mutex; the counters are cheap).
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap::daemon {

class ServerActivity {
 public:
  void SessionOpened();
  void SessionClosed();
  std::uint64_t sessions_open() const;

  void BytesReceived(std::uint64_t n);
  void BytesSent(std::uint64_t n);
  void ErrorSent(const std::string& code_name);
  void PushAccepted(const Uuid& robot);
  void DownloadSent(const Uuid& robot);
  void MergeFinished(bool merged);
  // A merge this server committed (kept among the recent ones).
  void MergeRan(const Uuid& submission, RevisionNumber revision, double seconds,
                std::int64_t finished_ns);
  void SetInstance(const std::string& instance);
  // A hello whose last-sync time could not be written to the store (it is kept here).
  void LastSyncNotRecorded();
  void MergeRetried();  // a merge failed transiently; its submission stays queued

  // The registered robots and the channels as last read from the store (replacing both).
  void SetRobots(const std::vector<RegisteredRobot>& robots, std::vector<Channel> channels);
  // A robot that just said Hello: (re)listed with its sync time.
  void RobotSynced(const RegisteredRobot& robot, std::int64_t now_ns);
  // The robot's name when known, else its UUID text.
  std::string RobotName(const Uuid& robot) const;

  void SetHead(RevisionNumber head, const StoreStats& stats);

  // Everything but what the caller adds (listen address, queue, times).
  FleetStatus Snapshot() const;

 private:
  struct RobotActivity {
    RegisteredRobot robot;
    std::uint64_t pushes = 0, downloads = 0;
  };

  mutable Mutex mutex_;
  FleetStatus totals_ GUARDED_BY(mutex_);
  std::map<Uuid, RobotActivity> robots_ GUARDED_BY(mutex_);
  std::vector<Channel> channels_ GUARDED_BY(mutex_);
};

}  // namespace fleetmap::daemon
