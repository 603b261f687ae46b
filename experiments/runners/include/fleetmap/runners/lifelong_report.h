// What `fleetmap experiment lifelong` leaves behind: lifelong.csv (a row per day), lifelong.png
// (nodes MERGE added per day and the map's size; the next day's P(X > 10 m) with copy and each
// download) and summary.md with the acceptance lines judged.
#pragma once

#include <filesystem>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "fleetmap/runners/lifelong_experiment.h"

namespace fleetmap {

// The acceptance lines on one world seed. The early and late windows are days 1-10 and 21-30 of a
// run of 30 days or more; a shorter run compares its first and last thirds (and says so).
struct LifelongVerdict {
  int early_first = 0, early_last = 0, late_first = 0, late_last = 0;  // 1-based days
  std::size_t early_added = 0, late_added = 0;
  double growth = 0.0;  // late_added / early_added; the line: <= 0.30
  // P(X > 10 m) of the forays held out on those days with copy, as Laplace-smoothed
  // probabilities (k + 1) / (n + 2) (fleet_report.cc explains why), and their ratio late /
  // early; the line: <= 1 (no worse).
  std::int64_t early_beyond = 0, early_frames = 0, late_beyond = 0, late_frames = 0;
  double copy_p10_ratio = 0.0;
  bool growth_pass = false;
  bool p10_pass = false;
  bool all() const { return growth_pass && p10_pass; }
};

// Throws Error(kInvalidArgument) for a run of fewer than 3 days (no windows to compare).
LifelongVerdict JudgeLifelong(const LifelongResult& result);

struct LifelongSeedRun {
  std::uint64_t seed = 0;
  LifelongResult result;
};

// Writes per seed lifelong.csv and lifelong.png (skipped with a note on `log` without gnuplot)
// into `dir`/seed-<seed>/, and summary.md over the seeds into `dir` (a line passes on the mean
// over seeds, with no seed beyond twice its bound); returns the summary. Throws Error(kBackend)
// for a file it cannot write, Error(kInvalidArgument) for no seeds.
std::string WriteLifelongReport(std::span<const LifelongSeedRun> seeds,
                                const LifelongOptions& options, const std::filesystem::path& dir,
                                std::ostream& log);

}  // namespace fleetmap
