#include "fleetmap/agent/agent_sync.h"

#include <algorithm>
#include <cstdio>
#include <optional>
#include <random>
#include <thread>

#include "fleetmap/core/clock.h"
#include "sync_run.h"

namespace fleetmap {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

milliseconds Remaining(Clock::time_point deadline) {
  return std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
}

// Sleeps `delay`, waking every 50 ms to look at the stop flag.
void SleepUnlessStopped(milliseconds delay, const std::atomic<bool>* stop) {
  const Clock::time_point until = Clock::now() + delay;
  while (Clock::now() < until) {
    if (stop != nullptr && stop->load()) throw SyncStopped("sync abandoned (stopping)");
    std::this_thread::sleep_for(std::min(Remaining(until), milliseconds(50)));
  }
}

SyncResult RunSyncOnce(LocalMap& map, const AgentSyncOptions& options) {
  const Clock::time_point start = Clock::now();
  SyncResult result;
  agent_internal::SyncRun run(map, options, result);
  std::minstd_rand jitter(std::random_device{}());
  std::uniform_real_distribution<double> factor(0.75, 1.25);
  std::optional<Clock::time_point> first_failure;
  int milestones_at_failure = 0;
  milliseconds backoff = options.first_backoff;
  for (;;) {
    std::string reason;
    try {
      run.Attempt();
      break;
    } catch (const SyncServerError& e) {
      if (!e.retryable()) throw;
      reason = e.what();
    } catch (const SyncLinkError& e) {
      if (!e.retryable()) throw;
      reason = e.what();
    }
    if (!first_failure || run.milestones() != milestones_at_failure) {
      first_failure = Clock::now();  // progress since the last failure: a new window
      milestones_at_failure = run.milestones();
      backoff = options.first_backoff;
    }
    const milliseconds left =
        options.retry_for - std::chrono::duration_cast<milliseconds>(Clock::now() - *first_failure);
    if (left.count() <= 0) {
      throw SyncLinkError("sync with " + options.server + " failed after " +
                              std::to_string(result.retries) + " retries over " +
                              std::to_string(options.retry_for.count() / 1000) +
                              " s; last: " + reason,
                          false);
    }
    const milliseconds delay =
        std::min(left, milliseconds(static_cast<std::int64_t>(static_cast<double>(backoff.count()) *
                                                              factor(jitter))));
    ++result.retries;
    result.last_retry_reason = reason;
    run.NextServer();
    if (options.progress) {
      char seconds[32];
      std::snprintf(seconds, sizeof seconds, "%.1f", static_cast<double>(delay.count()) / 1000.0);
      options.progress("retry " + std::to_string(result.retries) + " in " + seconds +
                       " s: " + reason);
    }
    SleepUnlessStopped(delay, options.stop);
    backoff = std::min(backoff * 2, options.max_backoff);
  }
  result.seconds = SecondsSince(start);
  return result;
}

}  // namespace

SyncResult RunSync(LocalMap& map, const AgentSyncOptions& options) {
  // The outcome is kept for the next hello (the depot's last error of this robot).
  try {
    SyncResult result = RunSyncOnce(map, options);
    map.RecordSyncError("");
    return result;
  } catch (const SyncStopped&) {
    throw;
  } catch (const std::exception& e) {
    try {
      map.RecordSyncError(e.what());
    } catch (const std::exception&) {
      // The map directory cannot be written: the error thrown says more.
    }
    throw;
  }
}

}  // namespace fleetmap
