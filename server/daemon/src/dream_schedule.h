// fleetmapd's nightly dream (`--dream-at HH:MM`, UTC): a daily job (daily_job.h) that runs
// RunNightlyDream (nightly_dream.h) on a Repository of its own (its own store connection), so a
// dream never holds a session's or the merge queue's store: pushes, merges and downloads go on
// while it runs. What it does shows in Status() (for /metrics and the status page). A dream
// missed before it started (fleetmapd down at the time, or killed mid-dream) runs at once when
// it starts, with a log line saying so.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "daily_job.h"
#include "fleetmap/core/mutex.h"
#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/nightly_dream.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap::daemon {

class DreamSchedule {
 public:
  // `after_each`, when given, is called on the dream's thread after each dream, however it
  // ended, unless the schedule is stopping (fleetmapd retires right after the dream).
  DreamSchedule(std::string store_uri, StoreOptions store_options, int second_of_day,
                NightlyDreamOptions options, std::function<void()> after_each = {});
  ~DreamSchedule();  // Stop()
  DreamSchedule(const DreamSchedule&) = delete;
  DreamSchedule& operator=(const DreamSchedule&) = delete;

  void Start();
  // Abandons a dream in progress at its next step (it leaves no candidate) and joins.
  void Stop();

  DreamStatus Status() const;

 private:
  void RunOnce();
  // Whether a dream was missed before this start (FindMissedDream), logging which; a store
  // that cannot be read is logged and taken as none missed.
  bool DueAtStart() const;

  const std::string store_uri_;
  const StoreOptions store_options_;
  const int second_of_day_;
  const NightlyDreamOptions options_;
  const std::function<void()> after_each_;

  mutable Mutex mutex_;
  DreamStatus status_ GUARDED_BY(mutex_);
  DailyJob job_;  // last: its thread uses the members above
};

}  // namespace fleetmap::daemon
