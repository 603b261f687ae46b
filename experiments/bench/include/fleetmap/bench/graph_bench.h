// `fleetmap bench graph` (seed 000 §6.1, Figs 6-7): linear chains of n experiences created and
// read back through GraphStore and through a raw SQL baseline on identical tables, on SQLite and
// PostgreSQL, synchronous and buffered, one call per element and one for the whole chain.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct GraphBenchOptions {
  std::vector<std::string> backends{"sqlite"};
  std::vector<std::string> durabilities{"synchronous", "buffered"};
  std::vector<std::string> ops{"create", "read"};
  std::vector<std::string> modes{"individual", "batch"};
  std::string pg_uri;  // empty: $FLEETMAP_TEST_PG_URI
  std::size_t max_n = 100'000;
  std::size_t max_n_sqlite_batch = 1'000'000;
  double budget_s = 20.0;
  std::string out_dir = "bench-out";
  // PostgreSQL plans the recursive chain query from table statistics; on freshly loaded tables
  // without them it scans all edges once per step (O(n^2)). Reads run after an ANALYZE, as on a
  // server whose autovacuum has caught up, unless this is set.
  bool pg_no_analyze = false;
  // "time-ordered": Uuid::Generate, the ids fleetmap makes (v7, so B-trees append);
  // "random": v4 ids, which insert at random places in every UUID index.
  std::string ids = "time-ordered";
};

// Runs every selected case, prints the table and the acceptance checks to standard output,
// writes OUT/graph_bench.csv (and .png with gnuplot). Throws Error(kBackend) naming what did
// not run; Error(kInvalidArgument) when PostgreSQL is asked for without a server.
void RunGraphBench(const GraphBenchOptions& options);

}  // namespace fleetmap::bench
