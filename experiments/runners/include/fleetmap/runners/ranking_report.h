// What `fleetmap experiment ranking` leaves behind: CSVs of every curve, PNG plots in the
// layout of seed 002 Figs. 9, 11, 12 and 13, and summary.md with the acceptance checks.
#pragma once

#include <filesystem>
#include <ostream>

#include "fleetmap/runners/ranking_experiment.h"

namespace fleetmap {

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
