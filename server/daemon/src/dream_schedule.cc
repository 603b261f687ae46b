#include "dream_schedule.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <ctime>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {
namespace {

// Thrown from the dream's progress callback to abandon it when the server stops.
struct DreamAbandoned {};

std::int64_t NsOf(std::chrono::system_clock::time_point t) {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(t.time_since_epoch()).count();
}

std::string ClockText(int minute_of_day) {
  char text[8];
  std::snprintf(text, sizeof text, "%02d:%02d", minute_of_day / 60, minute_of_day % 60);
  return text;
}

}  // namespace

std::chrono::system_clock::time_point NextDreamTime(std::chrono::system_clock::time_point now,
                                                    int minute_of_day) {
  using std::chrono::days;
  using std::chrono::minutes;
  // system_clock counts UTC without leap seconds, so days divide it exactly.
  const auto midnight = std::chrono::floor<days>(now);
  auto next = midnight + minutes(minute_of_day);
  if (next <= now) next += days(1);
  return next;
}

DreamSchedule::DreamSchedule(std::string store_uri, StoreOptions store_options, int minute_of_day,
                             NightlyDreamOptions options)
    : store_uri_(std::move(store_uri)),
      store_options_(store_options),
      minute_of_day_(minute_of_day),
      options_(options) {
  status_.scheduled = true;
  status_.at = ClockText(minute_of_day_);
}

DreamSchedule::~DreamSchedule() {
  Stop();
}

void DreamSchedule::Start() {
  std::string at;
  {
    MutexLock lock(mutex_);
    status_.next_ns = NsOf(NextDreamTime(std::chrono::system_clock::now(), minute_of_day_));
    at = status_.at;
  }
  spdlog::info("dream: scheduled daily at {} UTC", at);
  thread_ = std::thread([this] { Run(); });
}

void DreamSchedule::Stop() {
  {
    MutexLock lock(mutex_);
    stopping_ = true;
  }
  wake_.NotifyAll();
  if (thread_.joinable()) thread_.join();
}

DreamStatus DreamSchedule::Status() const {
  MutexLock lock(mutex_);
  return status_;
}

std::optional<MissedDream> DreamSchedule::FindMissed() const {
  try {
    RepositoryOptions repository_options;
    repository_options.store = store_options_;
    const std::unique_ptr<Repository> repository = Repository::Open(store_uri_, repository_options);
    return FindMissedDream(*repository, NsOf(std::chrono::system_clock::now()), minute_of_day_);
  } catch (const std::exception& error) {
    // The schedule goes on: the next night's dream covers what this one would have.
    spdlog::warn("dream: cannot tell whether a dream was missed: {}", error.what());
    return std::nullopt;
  }
}

void DreamSchedule::Run() {
  // A dream that did not run at its time, or did not finish, runs now rather than a day late;
  // once, as it records its finish.
  if (const std::optional<MissedDream> missed = FindMissed()) {
    const std::time_t seconds = static_cast<std::time_t>(missed->scheduled_ns / 1'000'000'000);
    std::tm utc{};
    gmtime_r(&seconds, &utc);
    char day[16];
    std::strftime(day, sizeof day, "%Y-%m-%d", &utc);
    spdlog::info("dream: missed the {} UTC dream of {}: {}; running it now",
                 ClockText(minute_of_day_), day, missed->why);
    RunOnce();
  }
  MutexLock lock(mutex_);
  while (!stopping_) {
    const auto next = NextDreamTime(std::chrono::system_clock::now(), minute_of_day_);
    status_.next_ns = NsOf(next);
    // Woken early only to stop; a spurious or clock-change wake-up re-checks the time.
    if (wake_.WaitUntil(mutex_, next, [&]() REQUIRES(mutex_) { return stopping_; })) break;
    if (std::chrono::system_clock::now() < next) continue;
    lock.Unlock();
    RunOnce();
    lock.Lock();
  }
}

void DreamSchedule::RunOnce() {
  {
    MutexLock lock(mutex_);
    status_.running = true;
    status_.steps_done = status_.steps_all = 0;
  }
  spdlog::info("dream: starting");
  std::string result;
  std::optional<DreamCandidateRecord> candidate;
  bool skipped = false, failed = false;
  double seconds = 0.0;
  try {
    RepositoryOptions repository_options;
    repository_options.store = store_options_;
    const std::unique_ptr<Repository> repository = Repository::Open(store_uri_, repository_options);
    const NightlyDreamOutcome outcome =
        RunNightlyDream(*repository, options_, [this](std::size_t done, std::size_t all) {
          MutexLock lock(mutex_);
          if (stopping_) throw DreamAbandoned{};
          status_.steps_done = done;
          status_.steps_all = all;
        });
    seconds = outcome.seconds;
    if (outcome.candidate) {
      candidate = outcome.candidate;
      result =
          fmt::format("candidate {}: {} orders, held-out P(gap > {:.0f} m) {:.4f}, score {:.4f}",
                      candidate->id.ToString(), candidate->orders, candidate->gap_m,
                      candidate->p_gap_exceeds, candidate->score);
      if (candidate->merged_order_score) {
        result += fmt::format(" (the order merged: {:.4f})", *candidate->merged_order_score);
      }
    } else {
      skipped = true;
      result = "skipped: " + outcome.skipped;
    }
  } catch (const DreamAbandoned&) {
    result = "abandoned: the server stopped";
    failed = true;
  } catch (const std::exception& error) {
    result = std::string("failed: ") + error.what();
    failed = true;
  }
  if (failed) {
    spdlog::warn("dream: {}", result);
  } else {
    spdlog::info("dream: {}", result);
  }
  MutexLock lock(mutex_);
  status_.running = false;
  status_.last_finished_ns = NsOf(std::chrono::system_clock::now());
  status_.last_seconds = seconds;
  status_.last_result = result;
  if (candidate) {
    ++status_.runs;
    status_.last_candidate = candidate->id.ToString();
    status_.last_score = candidate->score;
    status_.last_p_gap_exceeds = candidate->p_gap_exceeds;
  } else if (skipped) {
    ++status_.skipped;
  } else {
    ++status_.failed;
  }
}

}  // namespace fleetmap::daemon
