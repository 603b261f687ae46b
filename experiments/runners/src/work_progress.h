// Progress of a long experiment: units of work (frames processed) done of a planned total,
// reported to the caller's callback. Workers on several threads advance it; the callback is
// called under a lock so its lines never interleave and `done` never goes backwards.
#pragma once

#include <atomic>
#include <cstdint>
#include <mutex>

#include "fleetmap/runners/ranking_experiment.h"

namespace fleetmap {

class WorkProgress {
 public:
  explicit WorkProgress(const ProgressCallback& callback) : callback_(callback) {}

  // The plan, set before any work is done.
  void Plan(std::int64_t total) { total_ = total; }
  std::int64_t total() const { return total_; }

  void Advance(std::int64_t units) {
    const std::lock_guard lock(mutex_);
    done_ += units;
    if (callback_) callback_(done_, total_);
  }

 private:
  const ProgressCallback& callback_;
  std::int64_t total_ = 0;
  std::int64_t done_ = 0;
  std::mutex mutex_;
};

}  // namespace fleetmap
