// What `fleetmap experiment lifelong` leaves behind: per seed lifelong.csv (a row per day, the
// arms without and with retirement side by side) and lifelong.png (the map's size and the next
// day's P(X > 10 m), with and without), and summary.md with the acceptance lines judged
// (the lines and their judgement, below).
#pragma once

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <ostream>
#include <span>
#include <string>
#include <vector>

#include "fleetmap/runners/lifelong_experiment.h"

namespace fleetmap {

inline constexpr double kLifelongGrowthBound = 0.30;  // nodes added late / early
inline constexpr double kLifelongP10Bound = 1.0;      // copy's P(X > 10 m) late / early
inline constexpr double kRetiredSizeBound = 1.25;     // with retirement: last day's map / middle's
inline constexpr double kRetiredHeldOutBound = 1.10;  // with retirement / without, late window

// The maps whose late window is compared with and without retirement.
inline const std::vector<std::string> kRetirementJudgedMaps = {"copy", "tod+cover"};

// The early and late windows of a run of `days` days (1-based, inclusive): days 1-10 and 21-30
// of a run of 30 days or more; a shorter run compares its first and last thirds. Throws
// Error(kInvalidArgument) for fewer than 3 days (no windows to compare).
struct LifelongWindows {
  int early_first = 0, early_last = 0, late_first = 0, late_last = 0;
};
LifelongWindows LifelongWindowsOf(int days);

// One arm's lines.
struct LifelongVerdict {
  int early_first = 0, early_last = 0, late_first = 0, late_last = 0;  // 1-based days
  std::size_t early_added = 0, late_added = 0;
  double growth = 0.0;  // late_added / early_added; the line: <= kLifelongGrowthBound
  // Copy's P(X > 10 m) of the forays held out on those days, smoothed, late / early; the line:
  // <= kLifelongP10Bound (no worse).
  std::int64_t early_beyond = 0, early_frames = 0, late_beyond = 0, late_frames = 0;
  double copy_p10_ratio = 0.0;
  bool growth_pass = false;
  bool p10_pass = false;
  bool all() const { return growth_pass && p10_pass; }
};

// Throws Error(kInvalidArgument) for fewer than 3 days.
LifelongVerdict JudgeLifelong(std::span<const LifelongDay> days);

// One map's forays held out over the late window, with retirement against without.
struct RetiredHeldOut {
  std::string map;
  bool measured = false;  // both arms held out in it, on some frames
  std::int64_t frames_without = 0, beyond_without = 0, not_localised_without = 0;
  std::int64_t frames_with = 0, beyond_with = 0, not_localised_with = 0;
  // Smoothed with / without; NaN when not measured. The lines: <= kRetiredHeldOutBound.
  double p10_ratio = std::numeric_limits<double>::quiet_NaN();
  double not_localised_ratio = std::numeric_limits<double>::quiet_NaN();
  bool p10_pass = false;
  bool not_localised_pass = false;
};

struct RetirementVerdict {
  // The map's size with retirement: nodes at the head after the middle day (day 15 of 30;
  // days / 2) and after the last; the line: last / middle <= kRetiredSizeBound.
  int middle_day = 0, last_day = 0;
  std::size_t middle_nodes = 0, last_nodes = 0;
  double size_ratio = 0.0;
  bool size_pass = false;
  int late_first = 0, late_last = 0;     // as JudgeLifelong's late window
  std::vector<RetiredHeldOut> held_out;  // kRetirementJudgedMaps, in order
  bool all() const;
};

// Judges the arm with retirement against the arm without. Throws Error(kInvalidArgument) for
// fewer than 3 days or arms whose days differ.
RetirementVerdict JudgeRetirement(std::span<const LifelongDay> without,
                                  std::span<const LifelongDay> with);

struct LifelongSeedRun {
  std::uint64_t seed = 0;
  LifelongResult result;
};

// A line over seeds: it passes on the mean of the seeds' values, with no seed beyond twice its
// bound (one bad seed is not hidden by good ones). A value is NaN where a seed could not be
// judged (a map not measured), which fails the line.
struct LifelongLine {
  std::string name;  // heads the report's row
  double bound = 0.0;
  std::vector<double> per_seed;
  std::vector<std::string> per_seed_counts;  // what each seed's value was computed from
  double mean = 0.0, worst = 0.0;
  bool pass = false;
};

struct LifelongAcceptance {
  // Without retirement: growth, copy's P(X > 10 m); with retirement (when it was run): the same
  // two, the map's size, then P(X > 10 m) and not-localised of each judged map.
  std::vector<LifelongLine> lines;
  bool all() const;
};

// Throws Error(kInvalidArgument) for no seeds, a seed with fewer than 3 days, or seeds of which
// some ran retirement and some did not.
LifelongAcceptance JudgeLifelongSeeds(std::span<const LifelongSeedRun> seeds);

// Writes per seed lifelong.csv and lifelong.png (skipped with a note on `log` without gnuplot)
// into `dir`/seed-<seed>/, and summary.md over the seeds into `dir` (JudgeLifelongSeeds);
// returns the summary. Throws Error(kBackend) for a file it cannot write, and as
// JudgeLifelongSeeds does (Error(kInvalidArgument) for no seeds).
std::string WriteLifelongReport(std::span<const LifelongSeedRun> seeds,
                                const LifelongOptions& options, const std::filesystem::path& dir,
                                std::ostream& log);

}  // namespace fleetmap
