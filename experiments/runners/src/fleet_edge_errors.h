// The pose error of a map's metric edges between outings (FleetEdgeErrors), summarised for the
// fleet report: how consistent the links are that the localiser's search composes across.
#pragma once

#include <cstddef>
#include <sstream>
#include <string>

#include "fleetmap/runners/fleet_experiment.h"

namespace fleetmap {

struct EdgeErrorSummary {
  std::size_t edges = 0;
  double p50_m = 0.0, p90_m = 0.0, max_m = 0.0;  // NaN with no edges
  // The edges that carry a covariance, and the share of them whose error is within three of
  // the standard deviations it claims (NaN with none): how honest the covariances are.
  std::size_t with_covariance = 0;
  double within_3_sigma = 0.0;
};

// Over every fold of `result` whose FleetEdgeErrors::map is `map`.
EdgeErrorSummary SummariseEdgeErrors(const FleetExperimentResult& result, const std::string& map);

// The per-seed table (single-agent's, the merged map's, MERGE's own links) and a sentence.
void WriteEdgeErrorTable(std::ostringstream& md, const FleetExperimentResult& result);

// fold,map,edges,p50_m,p90_m,max_m per fold and map.
std::string EdgeErrorCsv(const FleetExperimentResult& result);

}  // namespace fleetmap
