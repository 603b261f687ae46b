// `fleetmap bench scale`: how the repository's merge, download and store grow
// with the map, each step measured in a child process of its own (its peak RSS is its own).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct ScaleBenchOptions {
  std::vector<std::size_t> sizes{10'000, 100'000, 1'000'000};
  std::vector<std::string> backends{"sqlite", "postgresql"};
  std::string pg_uri;
  std::string out_dir = "bench-scale";
  int landmarks = 200;
  std::size_t submission_nodes = 500;
  int merges = 3;  // merge runs per size; the median is reported
  double subset_percent = 10.0;
  std::uint32_t seed = 1;
  bool keep = false;
};

// One measured step, run in the child process (`fleetmap bench scale-step`, hidden).
struct ScaleStepOptions {
  std::string op;  // "merge" or "download"
  std::string store;
  std::size_t nodes = 0;
  int landmarks = 200;
  std::uint32_t seed = 1;
  std::size_t submission_nodes = 500;
  double subset_percent = 10.0;
  std::string appearance_dir;
};

// Writes each size's map, runs the steps as children of this same program (which must offer
// `bench scale-step`), prints the table and writes OUT/scale_bench.csv and .png. Throws when a
// size failed.
void RunScaleBench(const ScaleBenchOptions& options);

// The child's side: runs one step and prints one JSON line (seconds, peak RSS, RSS before).
void RunScaleStep(const ScaleStepOptions& options);

}  // namespace fleetmap::bench
