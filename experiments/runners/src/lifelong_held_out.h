// Reading the held-out forays of a lifelong day (LifelongDay::next_day), shared by the verdict
// (lifelong_verdict.cc) and the report (lifelong_report.cc, lifelong_seed_files.cc).
#pragma once

#include <cstdint>
#include <string>

#include "fleetmap/runners/lifelong_experiment.h"

namespace fleetmap::lifelong_internal {

// The day's row of `map`, or nullptr when the day held nothing out in it.
inline const LifelongHeldOut* HeldOutIn(const LifelongDay& day, const std::string& map) {
  for (const LifelongHeldOut& h : day.next_day) {
    if (h.map == map) return &h;
  }
  return nullptr;
}

// k / n, 0 for no frames: what a row measured.
inline double Share(std::int64_t k, std::int64_t n) {
  return n == 0 ? 0.0 : static_cast<double>(k) / static_cast<double>(n);
}

// (k + 1) / (n + 2): what lines compare (lifelong_report.h).
inline double Smoothed(std::int64_t k, std::int64_t n) {
  return (static_cast<double>(k) + 1.0) / (static_cast<double>(n) + 2.0);
}

}  // namespace fleetmap::lifelong_internal
