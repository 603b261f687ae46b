// A job fleetmapd runs once a day at a UTC time of day, on a thread of its own (the nightly
// dream, retirement): it sleeps until the time comes, runs the job, and sleeps until the next
// day's. A run missed before it started (fleetmapd down at the time, or killed mid-run; the job
// says whether) runs at once when it starts, and another thread may ask for a run now
// (RunSoon: retirement right after the dream).
//
// Threading: construct, Start() and Stop() from one thread; RunSoon(), Stopping() and NextNs()
// from any. The job itself runs on the job's thread only, one run at a time.
#pragma once

#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <thread>

#include "fleetmap/core/mutex.h"

namespace fleetmap::daemon {

// The first time after `now` whose UTC time of day is `second_of_day` (today's, when it is
// still to come, else tomorrow's).
std::chrono::system_clock::time_point NextDailyTime(std::chrono::system_clock::time_point now,
                                                    int second_of_day);

// `t` as UTC nanoseconds since the epoch.
std::int64_t UtcNs(std::chrono::system_clock::time_point t);

// "HH:MM", for the log and the status page.
std::string TimeOfDayText(int second_of_day);

class DailyJob {
 public:
  // `run` is the job. `missed`, when given, is asked once on the job's thread as it starts
  // whether a run is due at once (it logs why). Without a `second_of_day` the job runs only
  // when asked (RunSoon), and after a missed run.
  DailyJob(std::optional<int> second_of_day, std::function<void()> run,
           std::function<bool()> missed = {});
  ~DailyJob();  // Stop()
  DailyJob(const DailyJob&) = delete;
  DailyJob& operator=(const DailyJob&) = delete;

  void Start();
  // Wakes the thread and joins it once the run in progress (if any) returns: a long job watches
  // Stopping() to return early.
  void Stop();
  // A run as soon as the one in progress (if any) ends; one however often it is asked meanwhile.
  void RunSoon();

  bool Stopping() const;
  // The next run by the clock, UTC ns; 0 without a time of day (or before Start).
  std::int64_t NextNs() const;

 private:
  void Run();
  // Waits until the next run is due (true) or Stop() (false).
  bool WaitForRun();

  const std::optional<int> second_of_day_;
  const std::function<void()> run_;
  const std::function<bool()> missed_;

  mutable Mutex mutex_;
  CondVar wake_;
  bool stopping_ GUARDED_BY(mutex_) = false;
  bool run_soon_ GUARDED_BY(mutex_) = false;
  std::int64_t next_ns_ GUARDED_BY(mutex_) = 0;
  std::thread thread_;
};

}  // namespace fleetmap::daemon
