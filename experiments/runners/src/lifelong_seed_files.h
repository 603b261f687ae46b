// One seed's files of the lifelong report (lifelong_report.h): lifelong.csv and lifelong.png.
#pragma once

#include <filesystem>
#include <ostream>

#include "fleetmap/runners/lifelong_experiment.h"

namespace fleetmap::lifelong_internal {

// lifelong.csv: a row per day, day, forays and world_replaced, then per arm ("without", and
// "with" when retirement ran) <arm>_nodes_built, _nodes_added, _nodes_retired, _map_nodes,
// _map_mb (landmark bytes / 1e6), and per map held out (copy, then the policies)
// <arm>_<map>_nodes, _frames, _not_localised, _beyond_10m, _not_localised_p, _p10 (of the next
// day's forays). lifelong.png (through lifelong.gp): map nodes, the day's change (nodes added
// and retired, landmarks the world replaced) and the next day's P(X > 10 m), each arm a curve.
// Writes into `dir` (created); gnuplot's complaints go to `log`. Throws Error(kBackend) when
// the CSV cannot be written.
void WriteLifelongSeedFiles(const LifelongResult& result, const LifelongOptions& options,
                            const std::filesystem::path& dir, std::ostream& log);

}  // namespace fleetmap::lifelong_internal
