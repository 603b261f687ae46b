// One seed's part of the fleet report (fleet_report.cc writes the whole): its CSVs and plots
// (fleet_seed_files.cc) and its sections of summary.md (fleet_seed_sections.cc).
#pragma once

#include <filesystem>
#include <ostream>
#include <sstream>
#include <string>

#include "fleetmap/runners/fleet_experiment.h"
#include "fleetmap/runners/fleet_report.h"

namespace fleetmap::fleet_report_internal {

// One seed's CSVs and fleet.png in `dir` (created). Returns whether the plot was drawn;
// gnuplot's complaints go to `log`.
bool WriteSeedFiles(const FleetExperimentResult& result, const std::filesystem::path& dir,
                    std::ostream& log);

// The figures' sections of one seed, at heading level `h` ("###"), judged as `v` says.
void SeedSections(std::ostringstream& md, const FleetExperimentResult& result,
                  const FleetExperimentOptions& options, const FleetVerdict& v,
                  const std::string& h);

}  // namespace fleetmap::fleet_report_internal
