#include "dream_schedule.h"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <ctime>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {
namespace {

// Thrown from the dream's progress callback to abandon it when the server stops.
struct DreamAbandoned {};

}  // namespace

DreamSchedule::DreamSchedule(std::string store_uri, StoreOptions store_options, int second_of_day,
                             NightlyDreamOptions options, std::function<void()> after_each)
    : store_uri_(std::move(store_uri)),
      store_options_(store_options),
      second_of_day_(second_of_day),
      options_(options),
      after_each_(std::move(after_each)),
      job_(
          second_of_day, [this] { RunOnce(); }, [this] { return DueAtStart(); }) {
  status_.scheduled = true;
  status_.at = TimeOfDayText(second_of_day_);
}

DreamSchedule::~DreamSchedule() {
  Stop();
}

void DreamSchedule::Start() {
  spdlog::info("dream: scheduled daily at {} UTC", TimeOfDayText(second_of_day_));
  job_.Start();
}

void DreamSchedule::Stop() {
  job_.Stop();
}

DreamStatus DreamSchedule::Status() const {
  DreamStatus status;
  {
    MutexLock lock(mutex_);
    status = status_;
  }
  status.next_ns = job_.NextNs();
  return status;
}

bool DreamSchedule::DueAtStart() const {
  std::optional<MissedDream> missed;
  try {
    RepositoryOptions repository_options;
    repository_options.store = store_options_;
    const std::unique_ptr<Repository> repository = Repository::Open(store_uri_, repository_options);
    missed = FindMissedDream(*repository, UtcNs(std::chrono::system_clock::now()), second_of_day_);
  } catch (const std::exception& error) {
    // The schedule goes on: the next night's dream covers what this one would have.
    spdlog::warn("dream: cannot tell whether a dream was missed: {}", error.what());
    return false;
  }
  if (!missed) return false;
  const std::time_t seconds = static_cast<std::time_t>(missed->scheduled_ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char day[16];
  std::strftime(day, sizeof day, "%Y-%m-%d", &utc);
  spdlog::info("dream: missed the {} UTC dream of {}: {}; running it now",
               TimeOfDayText(second_of_day_), day, missed->why);
  return true;
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
          if (job_.Stopping()) throw DreamAbandoned{};
          MutexLock lock(mutex_);
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
  status_.last_finished_ns = UtcNs(std::chrono::system_clock::now());
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
  lock.Unlock();
  // Not on the way out: what follows the dream waits for the next one.
  if (after_each_ && !job_.Stopping()) after_each_();
}

}  // namespace fleetmap::daemon
