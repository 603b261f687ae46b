// What `fleetmap experiment fleet` leaves behind: per world seed the CSVs of every figure and
// fleet.png in the layout of seed 004 Figs. 7–10, and one summary.md with the paper's numbers
// beside ours and the acceptance judged over the seeds.
//
// Every line is a ratio "ours / reference ≤ bound". Probabilities are compared by ratio, not by
// points: 5 points around a probability of 0.003 is no test at all.
#pragma once

#include <cstdint>
#include <filesystem>
#include <ostream>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/runners/fleet_experiment.h"

namespace fleetmap {

// One line on one seed. NaN `value`: a side of the ratio was not run, which never passes.
struct FleetRatio {
  std::string name;     // the same on every seed: JudgeFleetSeeds joins the seeds by it
  double value = 0.0;   // ours / reference
  double bound = 0.0;   // a judged line passes at value <= bound
  bool judged = false;  // false: reported beside the judged lines (the paper's own policies, CPU)
  bool pass = false;    // judged and value <= bound
  std::string detail;   // what the ratio is made of, for the report
};

// One seed's acceptance: the judged lines in a fixed order, then the reported ones.
struct FleetVerdict {
  std::vector<FleetRatio> lines;

  // nullptr when no line has that name.
  const FleetRatio* Find(std::string_view name) const;
  bool all() const;  // every judged line passes
};

// The acceptance on one seed. The probabilities (P(X > 10 m) over held-out frames, the fraction
// not localised) enter as Laplace-smoothed ratios (k + 1) / (n + 2); see fleet_report.cc for why.
// A policy or map with no runs (or no downloads, or no builds) fails its lines as "not run".
FleetVerdict JudgeFleet(const FleetExperimentResult& result);

// CPU seconds over every fold: single-agent EBN; the merging strategy with its groups driven in
// parallel (the slowest group, then every merge in turn; Fig. 7's "merged" time); and all the
// groups and merges together. What JudgeFleet's CPU lines are the ratios of.
struct FleetCpuSeconds {
  double single = 0, merging = 0, total = 0;
};
FleetCpuSeconds SumFleetCpu(const FleetExperimentResult& result);

// One point of the frontier an operator picks a download policy from, over
// every fold: its share of copy's nodes (mean over downloads) and of copy's landmark bytes, and
// its P(X > 10 m) and not-localised fraction against copy's on the same held-out frames
// (Laplace-smoothed ratios). On the frontier when no other point needs no more nodes and fails
// no more, one of them strictly less.
struct FrontierSummary {
  std::string label;
  std::string policy;
  std::size_t downloads = 0;
  double node_share = 0.0;
  double byte_share = 0.0;
  std::int64_t bytes = 0, copy_bytes = 0;
  std::int64_t frames = 0, beyond_10m = 0, not_localised = 0;
  double p10_ratio = 0.0;
  double not_localised_ratio = 0.0;
  bool on_frontier = false;
};
// The points of result.frontier by label, by node share (then label).
std::vector<FrontierSummary> SummariseFrontier(const FleetExperimentResult& result);

// A line over several world seeds.
struct FleetLine {
  std::string name;
  double bound = 0.0;
  bool judged = false;
  std::vector<double> per_seed;  // in the order of the verdicts; NaN where not run
  double mean = 0.0, min = 0.0, max = 0.0;
  bool pass = false;
  std::string why;  // when a judged line fails: "not run", the mean, or the seed too far out
};

struct FleetAcceptance {
  std::vector<FleetLine> lines;
  bool all() const;  // every judged line passes
};

// The rule over seeds: a judged line passes only when the mean over seeds meets its bound
// and no seed is worse than twice the bound (each value <= 2 bound). A seed somewhat over the
// bound is the world's noise and the mean absorbs it; a seed beyond twice the bound is a failure
// the other seeds must not average away. A line missing or NaN on any seed fails. Throws
// Error(kInvalidArgument) for no verdicts.
FleetAcceptance JudgeFleetSeeds(std::span<const FleetVerdict> per_seed);

// One world seed's experiment.
struct FleetSeedRun {
  std::uint64_t seed = 0;
  FleetExperimentResult result;
};

// Writes per seed the CSVs and fleet.png (skipped with a note on `log` without gnuplot) into
// `dir`/seed-<seed>/, and summary.md over all seeds into `dir`; returns the summary's text.
// `options` are the runs' options but for the world's seed. Throws Error(kBackend) for a file it
// cannot write, Error(kInvalidArgument) for no seeds or a seed twice.
std::string WriteFleetReport(std::span<const FleetSeedRun> seeds,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log);

// The one-seed report (seed options.world.seed), laid out as above.
std::string WriteFleetReport(const FleetExperimentResult& result,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log);

}  // namespace fleetmap
