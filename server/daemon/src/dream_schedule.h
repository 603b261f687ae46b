// fleetmapd's nightly dream (`--dream-at HH:MM`, UTC): a thread of its own that sleeps until
// the time comes, then runs RunNightlyDream (nightly_dream.h) on a Repository of its own (its
// own store connection), so a dream never holds a session's or the merge queue's store: pushes,
// merges and downloads go on while it runs. What it does shows in Status() (for /metrics and
// the status page). A dream missed before it started (fleetmapd down at the time, or killed
// mid-dream) runs at once when it starts, with a log line saying so.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <thread>

#include "fleetmap/core/mutex.h"
#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/nightly_dream.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap::daemon {

// The first time after `now` whose UTC time of day is `minute_of_day` (today's, when it is
// still to come, else tomorrow's).
std::chrono::system_clock::time_point NextDreamTime(std::chrono::system_clock::time_point now,
                                                    int minute_of_day);

class DreamSchedule {
 public:
  DreamSchedule(std::string store_uri, StoreOptions store_options, int minute_of_day,
                NightlyDreamOptions options);
  ~DreamSchedule();  // Stop()
  DreamSchedule(const DreamSchedule&) = delete;
  DreamSchedule& operator=(const DreamSchedule&) = delete;

  void Start();
  // Abandons a dream in progress at its next step (it leaves no candidate) and joins.
  void Stop();

  DreamStatus Status() const;

 private:
  void Run();
  void RunOnce();
  // The dream missed before this start (FindMissedDream), if any; a store that cannot be read
  // is logged and taken as none missed.
  std::optional<MissedDream> FindMissed() const;

  const std::string store_uri_;
  const StoreOptions store_options_;
  const int minute_of_day_;
  const NightlyDreamOptions options_;

  mutable Mutex mutex_;
  CondVar wake_;
  bool stopping_ GUARDED_BY(mutex_) = false;
  DreamStatus status_ GUARDED_BY(mutex_);
  std::thread thread_;
};

}  // namespace fleetmap::daemon
