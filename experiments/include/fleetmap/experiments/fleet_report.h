// What `fleetmap experiment fleet` leaves behind: CSVs of every figure, fleet.png in the layout
// of seed 004 Figs. 7–10, and summary.md with the paper's numbers beside ours and the issue's
// acceptance checks.
#pragma once

#include <filesystem>
#include <ostream>
#include <string>

#include "fleetmap/experiments/fleet_experiment.h"

namespace fleetmap {

// The headline figures over all folds.
struct FleetVerdict {
  // Fig. 7
  double merged_node_ratio = 0.0;     // merged nodes / single-agent nodes
  double single_not_localised = 0.0;  // fraction of held-out frames
  double merged_not_localised = 0.0;
  double merge_time_ratio = 0.0;       // critical path (CPU) / single-agent EBN (CPU)
  double merge_wall_time_ratio = 0.0;  // the same with wall clock seconds
  // Fig. 9
  double tod_node_ratio = 0.0;  // mean over held-out outings of nodes / copy's
  double tod_paths_node_ratio = 0.0;
  double copy_p10 = 0.0, tod_p10 = 0.0, tod_paths_p10 = 0.0;  // P(X > 10 m)

  bool merged_small_enough = false;     // <= 75 % of single-agent's nodes
  bool merged_localises_well = false;   // not localised <= single + 2 points
  bool merged_fast_enough = false;      // <= 35 % of single-agent's time
  bool tod_small_enough = false;        // <= 85 % of copy
  bool tod_paths_small_enough = false;  // <= 75 % of copy
  bool tod_localises_well = false;      // P(X > 10 m) within 5 points of copy
  bool tod_paths_localises_well = false;

  bool all() const {
    return merged_small_enough && merged_localises_well && merged_fast_enough && tod_small_enough &&
           tod_paths_small_enough && tod_localises_well && tod_paths_localises_well;
  }
};

FleetVerdict JudgeFleet(const FleetExperimentResult& result);

// Writes the CSVs, fleet.png (skipped with a note on `log` without gnuplot) and summary.md
// into `dir`; returns the summary's text. Throws Error(kBackend) for a file it cannot write.
std::string WriteFleetReport(const FleetExperimentResult& result,
                             const FleetExperimentOptions& options,
                             const std::filesystem::path& dir, std::ostream& log);

}  // namespace fleetmap
