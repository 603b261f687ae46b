// `fleetmap bench limits`: every performance measure beside its raw limit in the
// same run, with the bound on their ratio, printed as one table (docs/experiments.md, "Benchmarks")
// and written as CSV and Markdown:
//   MERGE CPU        the fleet experiment's merging strategy (groups in parallel) and all its
//                    groups and merges, against single-agent EBN's CPU (mean over world seeds);
//   sensor index     insert and nearest on SQLite, synchronous and buffered, against plain
//                    sqlite3 on the same schema (raw_sensor_index.h); PostgreSQL's bulk
//                    ingest against plain COPY into the data table (reported, not bounded);
//   agent pull       fleetmap-agent's pull from a real fleetmapd against RawSqliteInstall, the
//                    cold download's rate and fleetmapd's memory growth (sync_download_benchmark);
//   front end        the stereo front end against ORB alone on both images, KITTI and EuRoC
//                    (stereo_front_end_benchmark);
//   matching         our descriptor matcher against a plain popcount loop
//   (fleetmap_microbenchmarks).
// The last three run as child processes: the benchmark executables of the build tree.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct LimitsBenchOptions {
  std::vector<std::string> measures{"merge", "index", "pull", "front-end", "matching"};
  int repetitions = 3;  // >= 1; the medians are over these
  std::string out_dir = "bench-limits";
  std::string benchmarks_dir;  // empty: tests/benchmarks of the build tree holding this fleetmap
  // Sensor index.
  std::int64_t index_rows = 1'000'000;
  int index_samples = 20'000;
  // PostgreSQL server for the bulk-ingest line (scratch databases made and dropped); empty:
  // $FLEETMAP_TEST_PG_URI, and without either the line says it was not run.
  std::string pg_uri;
  // MERGE.
  std::string world_file;               // empty: the built-in default world
  int merge_seeds = 3;                  // the world's seed and the ones after it
  std::string merge_scale = "default";  // small | default
  int threads = 2;
};

// Runs the measures, prints the table to stdout (progress to stderr), writes
// OUT/limits.csv and OUT/limits.md. Returns the number of lines whose bound is not met.
int RunLimitsBench(const LimitsBenchOptions& options);

}  // namespace fleetmap::bench
