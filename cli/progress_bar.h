// A progress line for long commands on stderr: redrawn in place on a terminal (at most ~5 times
// a second), one line per 10 % otherwise, so CI logs stay short. Shows percent, elapsed time
// and an estimate of the time left.
#pragma once

#include <chrono>
#include <cstdint>
#include <ostream>
#include <string>

namespace fleetmap::cli {

class ProgressBar {
 public:
  ProgressBar(std::string label, std::ostream& out);
  // Thread-compatible: callers serialise (the experiment runner reports under a lock).
  void Update(std::int64_t done, std::int64_t total);
  void Finish();

 private:
  using Clock = std::chrono::steady_clock;

  std::string label_;
  std::ostream& out_;
  bool terminal_;
  Clock::time_point start_ = Clock::now();
  Clock::time_point last_draw_{};
  int last_decile_ = -1;
  std::int64_t done_ = 0, total_ = 0;
};

}  // namespace fleetmap::cli
