// real-fleet's files (real_fleet_experiment.h): summary.md, real_fleet.csv and the plot.
#pragma once

#include "fleetmap/runners/real_fleet_experiment.h"

namespace fleetmap {

// Writes summary.md, real_fleet.csv and real_fleet.png/.gp to options.out_dir and sets
// result.summary and the paths (the plot's empty when gnuplot failed; the summary says why).
// Throws Error(kBackend) when a file cannot be written.
void WriteRealFleetReport(const RealFleetOptions& options, RealFleetResult& result);

}  // namespace fleetmap
