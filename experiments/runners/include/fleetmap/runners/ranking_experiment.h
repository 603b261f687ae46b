// The ranking experiment of seed 002 §VII: Γ(path) against Γ(distance) by 5-fold
// cross-validation over outings of the synthetic world. Four folds build an experience map
// (single-agent EBN, new experiences on localisation failure); the fifth localises only. The
// measure is P(X ≥ x), the probability of having travelled at least x metres (ground truth)
// since the last successful localisation, estimated over every frame of the held-out outings.
//
// Runs, per fold:
// - the map is built outing by outing in time order; after each of `map_size_steps` equal
//   shares of the training outings, both policies localise the held-out fold at
//   `reference_cores` (Fig. 9: failure vs map size);
// - on the full map: both policies at every Np in `cores` (Fig. 11, and P(X ≥ x) curves for
//   Fig. 12), and Γ(path) at `reference_cores` for every T in `windows` (Fig. 13).
//
// What `fleetmap experiment ranking` leaves behind (WriteRankingReport, below): CSVs of every
// curve, PNG plots in the layout of seed 002 Figs. 9, 11, 12 and 13, and summary.md with the
// acceptance checks.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {

// The builder settings of the experiment, apart from BuilderOptions' general defaults:
// - candidates within 2 m of the position estimate. Measured on the default world (5 folds,
//   maps built at Np = 4, Nr = 1), Γ(distance) at Np = 2 fails to localise for more than 10 m
//   on 0.66 % of frames with 1.5 m, 0.52 % with 2 m, 1.00 % with 2.5 m and 0.70 % with 3 m:
//   an attempt succeeds less often the farther the node is from the estimate, so farther
//   candidates mostly dilute the ranking;
// - when lost, one appearance match tried per frame, like FAB-MAP's single best place
//   (seed 004 §III-B).
inline BuilderOptions RankingBuilderOptions() {
  BuilderOptions options;
  options.candidate_radius_m = 2.0;
  options.max_candidate_radius_m = 8.0;
  options.relocalisation_candidates = 1;
  return options;
}

struct RankingExperimentOptions {
  WorldConfig world{};
  int folds = 5;                                               // >= 2
  std::vector<int> cores = {1, 2, 3, 4, 5, 6, 7, 8};           // Np values compared, each >= 1
  std::vector<int> windows = {0, 1, 5, 10, 20, 50, 100, 200};  // T values, each >= 0
  int reference_cores = 2;  // Np of the map-size and T sweeps, >= 1
  // T of Γ(path) elsewhere, >= 0. Measured on the default world at Np = 2: T = 20 is as good
  // as any longer window and better than T = 100 (see the T sweep, Fig. 13).
  int default_window = 20;
  int map_size_steps = 4;  // >= 1
  // The map-building runs: Γ(distance) at Np = build_cores and Nr = build_rounds, the baseline
  // system the maps come from. One round per frame, as in seed 002's system: when the Np
  // nearest experiences fail the frame becomes a new one, so the map grows denser with
  // repeated traverses, the regime where a ranking policy matters (seed 002 §VII-A).
  int build_cores = 4;   // >= 1
  int build_rounds = 1;  // >= 1
  // Shared by building and localising (cores, rounds and localise_only are set per run).
  BuilderOptions builder = RankingBuilderOptions();
  int threads = 2;                 // worker threads, >= 1
  std::filesystem::path work_dir;  // fold stores go here (created; removed by the caller)
};

// One localise-only run of one fold's held-out outings.
struct LocalisationRun {
  std::string policy;  // "distance" | "path"
  int cores = 0;       // Np
  int window = 0;      // T (Γ(path) only)
  int fold = 0;
  int map_step = 0;  // 1..map_size_steps; map_size_steps is the full map
  std::size_t map_nodes = 0;
  std::int64_t frames = 0;
  std::int64_t localised_frames = 0;
  std::int64_t attempts = 0;
  // Per frame: ground-truth metres since the last successful localisation.
  std::vector<float> gaps_m;
};

struct FoldBuild {
  int fold = 0;
  int training_outings = 0;
  std::size_t nodes = 0;
  std::size_t metric_edges = 0;
  std::size_t paths = 0;
  std::int64_t frames = 0;
  std::vector<std::size_t> nodes_after_outing;  // experience count after each training outing
  double seconds = 0.0;
};

struct RankingExperimentResult {
  std::vector<FoldBuild> builds;
  std::vector<LocalisationRun> runs;
  int outings = 0;
  std::int64_t frames_rendered = 0;
  double seconds = 0.0;
};

// Progress in frames processed out of a total known from the start.
using ProgressCallback = std::function<void(std::int64_t done, std::int64_t total)>;

// Throws Error(kInvalidArgument) for options out of range.
RankingExperimentResult RunRankingExperiment(const RankingExperimentOptions& options,
                                             const ProgressCallback& progress = {});

// P(X > x): the fraction of the runs' frames with more than x metres travelled since the last
// successful localisation (distances are continuous, so this is also P(X ≥ x)).
double ProbabilityGapExceeds(const std::vector<const LocalisationRun*>& runs, double x_m);

// The acceptance comparison on P(X > 10 m) over all folds.
struct RankingVerdict {
  double path_at_reference = 0.0;      // Γ(path), Np = reference_cores
  double distance_at_reference = 0.0;  // Γ(distance), Np = reference_cores
  double distance_at_double = 0.0;     // Γ(distance), Np = 2 x reference_cores (NaN if not run)
  bool path_beats_distance = false;    // strictly better at the same Np
  bool path_beats_double = false;      // strictly better than Γ(distance) with twice the cores
};

RankingVerdict JudgeRanking(const RankingExperimentResult& result,
                            const RankingExperimentOptions& options);

// Writes the CSVs, plots (skipped with a note on `log` when gnuplot is missing) and
// summary.md into `dir`; returns the summary's text. Throws Error(kBackend) when a file
// cannot be written.
std::string WriteRankingReport(const RankingExperimentResult& result,
                               const RankingExperimentOptions& options,
                               const std::filesystem::path& dir, std::ostream& log);

}  // namespace fleetmap
