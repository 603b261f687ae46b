// `fleetmap bench index` (seed 000 §6, Table 1): the sensor index's insert rate, select by id,
// nearest by (platform, sensor, t), and temporal joins, on SQLite and PostgreSQL, beside the
// paper's figures and our targets.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct IndexBenchOptions {
  std::int64_t records = 10'000'000;
  std::vector<std::string> stores;  // explicit stores; empty: SQLite file + scratch PostgreSQL
  std::string pg_uri;               // empty: $FLEETMAP_TEST_PG_URI
  std::string out_dir = "bench-out";
  int samples = 20'000;
  int join_samples = 2'000;
  bool sqlite_buffered = false;
};

// Loads the rows, times each call, prints the table. Throws Error naming the targets missed.
void RunIndexBench(const IndexBenchOptions& options);

}  // namespace fleetmap::bench
