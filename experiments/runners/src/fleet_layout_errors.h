// How far the map's layouts put its nodes from where they were captured (FleetLayoutError):
// the composed layout against the relaxed one, for the fleet report.
#pragma once

#include <sstream>
#include <string>

#include "fleetmap/runners/fleet_experiment.h"

namespace fleetmap {

// The per-seed table: per map (single-agent's, merged) and layout, the median over the folds of
// the aligned RMS error and of the largest error, and the folds where relaxed was the nearer.
void WriteLayoutErrorTable(std::ostringstream& md, const FleetExperimentResult& result);

// fold,map,layout,nodes,ate_rmse_m,max_m,seconds, a line per fold, map and layout.
std::string LayoutErrorCsv(const FleetExperimentResult& result);

}  // namespace fleetmap
