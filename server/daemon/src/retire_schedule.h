// fleetmapd's retirement on schedule (`--retire-after DAYS`, at `--retire-at HH:MM` UTC or right
// after each nightly dream): a daily job (daily_job.h) that runs Repository::Retire
// (retirement.h) on a Repository of its own (its own store connection), so neither a session
// nor the merge queue waits for it. Its revision is one more writer's: a merge that meets it
// retries on the new head, as after any other (merge_queue.h), and a merge that appends first
// makes the retirement plan once more on the new head.
//
// A retirement at its own time of day that did not happen since that time last came (fleetmapd
// down then, or nothing was retired) runs at once when it starts: another plan costs one read of
// the head's nodes and edges, and retires nothing the time has not made due.
#pragma once

#include <functional>
#include <optional>
#include <string>

#include "daily_job.h"
#include "fleetmap/repository/retirement.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap::daemon {

class RetireSchedule {
 public:
  // `second_of_day`: daily at that UTC second of the day; nullopt: only when asked (RunSoon), as
  // after each dream. `after_retired`, when given, is called on the job's thread after each
  // revision it appends (fleetmapd reads the new head for its status).
  RetireSchedule(std::string store_uri, StoreOptions store_options,
                 std::optional<int> second_of_day, RetireOptions options,
                 std::function<void()> after_retired = {});
  ~RetireSchedule();  // Stop()
  RetireSchedule(const RetireSchedule&) = delete;
  RetireSchedule& operator=(const RetireSchedule&) = delete;

  void Start();
  // Joins once a retirement in progress is done (it cannot be abandoned half-way, and it is a
  // single transaction: it either appends its revision or nothing).
  void Stop();
  // A retirement as soon as the one in progress (if any) ends: right after the dream.
  void RunSoon();

 private:
  void RunOnce();
  // Whether no retirement revision was appended since the time of day last came, logging so; a
  // store that cannot be read is logged and taken as not due.
  bool DueAtStart() const;

  const std::string store_uri_;
  const StoreOptions store_options_;
  const std::optional<int> second_of_day_;
  const RetireOptions options_;
  const std::function<void()> after_retired_;
  DailyJob job_;  // last: its thread uses the members above
};

}  // namespace fleetmap::daemon
