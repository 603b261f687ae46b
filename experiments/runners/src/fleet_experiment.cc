// The fleet experiment (fleet_experiment.h): its options checked, then run (fleet_run.h).
#include "fleetmap/runners/fleet_experiment.h"

#include <filesystem>
#include <string>

#include "fleet_run.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/dreaming.h"

namespace fleetmap {
namespace {

void Validate(const FleetExperimentOptions& o) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "fleet experiment: " + what);
  };
  if (o.folds < 3) fail("folds must be >= 3 (one held out, at least two groups)");
  if (o.build_cores < 1) fail("build_cores must be >= 1");
  if (o.test_policy != "path" && o.test_policy != "distance") {
    fail("test_policy must be path or distance, not " + o.test_policy);
  }
  if (o.test_cores < 1) fail("test_cores must be >= 1");
  if (o.test_window < 0) fail("test_window must be >= 0");
  if (!(o.tod_window_min >= 0.0)) fail("tod_window_min must be >= 0 (0: each policy's own)");
  if (!(o.paths_percent > 0.0 && o.paths_percent <= 100.0)) fail("paths_percent in (0, 100]");
  if (!(o.epoch_min > 0.0 && o.epoch_min <= 1440.0)) fail("epoch_min in (0, 1440]");
  if (o.dream_folds < 0 || o.dream_folds > o.folds) fail("dream_folds in [0, folds]");
  if (o.folds - 1 > kMaxDreamGroups) {
    fail("at most " + std::to_string(kMaxDreamGroups) +
         " groups can be dreamt (folds <= " + std::to_string(kMaxDreamGroups + 1) + ")");
  }
  if (o.threads < 1) fail("threads must be >= 1");
  if (o.work_dir.empty()) fail("work_dir must be set");
}

}  // namespace

FleetReach& FleetReach::operator+=(const FleetReach& other) {
  lost += other.lost;
  no_node_near += other.no_node_near;
  none_localises += other.none_localises;
  not_candidate += other.not_candidate;
  not_candidate_lost += other.not_candidate_lost;
  not_candidate_unreached += other.not_candidate_unreached;
  not_candidate_placed_far += other.not_candidate_placed_far;
  not_candidate_reference_far += other.not_candidate_reference_far;
  not_tried += other.not_tried;
  tried += other.tried;
  return *this;
}

FleetExperimentResult RunFleetExperiment(const FleetExperimentOptions& options,
                                         const ProgressCallback& progress) {
  Validate(options);
  std::filesystem::create_directories(options.work_dir);
  return fleet_internal::FleetRun(options, progress).Run();
}

}  // namespace fleetmap
