#include "progress_bar.h"

#include <unistd.h>

#include <cstdio>

#include "fleetmap/core/clock.h"

namespace fleetmap::cli {

ProgressBar::ProgressBar(std::string label, std::ostream& out)
    : label_(std::move(label)), out_(out), terminal_(isatty(STDERR_FILENO) != 0) {}

void ProgressBar::Update(std::int64_t done, std::int64_t total) {
  done_ = done;
  total_ = total;
  if (total <= 0) return;
  const double fraction = static_cast<double>(done) / static_cast<double>(total);
  const Clock::time_point now = Clock::now();
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double left = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
  char line[160];
  if (terminal_) {
    if (now - last_draw_ < std::chrono::milliseconds(200) && done < total) return;
    last_draw_ = now;
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    std::string bar(static_cast<std::size_t>(filled), '#');
    bar.resize(kWidth, '.');
    std::snprintf(line, sizeof line, "\r%s [%s] %5.1f%%  %.0f s elapsed, ~%.0f s left ",
                  label_.c_str(), bar.c_str(), 100.0 * fraction, elapsed, left);
    out_ << line << std::flush;
  } else {
    const int decile = static_cast<int>(fraction * 10.0);
    if (decile == last_decile_) return;
    last_decile_ = decile;
    std::snprintf(line, sizeof line, "%s: %3d%%  %.0f s elapsed, ~%.0f s left\n", label_.c_str(),
                  decile * 10, elapsed, left);
    out_ << line << std::flush;
  }
}

void ProgressBar::Finish() {
  const double elapsed = SecondsSince(start_);
  char line[160];
  std::snprintf(line, sizeof line, "%s%s: done in %.1f s\n", terminal_ ? "\r" : "", label_.c_str(),
                elapsed);
  out_ << line << std::flush;
}

}  // namespace fleetmap::cli
