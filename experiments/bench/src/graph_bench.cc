// `fleetmap bench graph`: seed 000 §6.1, Figs 6-7. Linear chains of n experiences are created
// and read back on SQLite and PostgreSQL, synchronous and buffered, one call per element and
// one call for the whole chain, each through our GraphStore and through a raw SQL baseline
// (raw_baseline.h) on identical tables. Prints a table, writes graph_bench.csv and
// graph_bench.png, and checks the acceptance targets: SQLite batch create >= 200,000 nodes/s
// and ours/raw <= 1.3 for individual calls.
//
// Every (n, case) starts from an empty store (a new SQLite file; truncated PostgreSQL tables)
// so sizes never accumulate; the read cases read the chain the batch create just wrote, over
// a new connection (on PostgreSQL after an ANALYZE; see --pg-no-analyze). Only the calls
// themselves are timed (steady_clock): opening, schema creation, ANALYZE and generating the
// chain are not. Ours and raw alternate run by run; small n are repeated and the median kept.
#include "fleetmap/bench/graph_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "bench_report.h"
#include "chain_workload.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "raw_baseline.h"

namespace fleetmap::bench {

namespace {

namespace fs = std::filesystem;

// A case whose linear projection to the next n exceeds this many budgets is not started:
// synchronous individual writes cost one fsync each and would otherwise run for many minutes.
constexpr double kProjectionBudgets = 5.0;

bool Contains(const std::vector<std::string>& list, const std::string& item) {
  return std::find(list.begin(), list.end(), item) != list.end();
}

// Metadata-only experiences (empty landmark blob), 1 m apart along x, fresh UUIDs.
GraphBatch MakeChain(std::size_t n, bool random_ids) {
  const auto new_id = random_ids ? &Uuid::GenerateRandom : &Uuid::Generate;
  GraphBatch chain;
  const Uuid robot = new_id();
  const Uuid outing = new_id();
  const std::int64_t t0_ns = 1'700'000'000'000'000'000;
  Se3 step = Se3::Identity();
  step.translation() = Eigen::Vector3d(1.0, 0.0, 0.0);
  chain.nodes.reserve(n);
  chain.edges.reserve(n > 0 ? n - 1 : 0);
  for (std::size_t i = 0; i < n; ++i) {
    const std::int64_t stamp_ns = t0_ns + static_cast<std::int64_t>(i) * 100'000'000;
    chain.nodes.push_back(Node{new_id(), stamp_ns, robot, outing, std::string()});
    if (i > 0) {
      chain.edges.push_back(Edge{new_id(), chain.nodes[i - 1].id, chain.nodes[i].id,
                                 EdgeKind::kMetric, step, Uuid()});
    }
  }
  return chain;
}

// The workload through our public API.
class GraphStoreChain final : public ChainWorkload {
 public:
  explicit GraphStoreChain(std::unique_ptr<GraphStore> store) : store_(std::move(store)) {}

  void CreateIndividual(const GraphBatch& chain) override {
    if (chain.nodes.empty()) return;
    store_->PutNode(chain.nodes[0]);
    for (std::size_t i = 1; i < chain.nodes.size(); ++i) {
      store_->PutNode(chain.nodes[i]);
      store_->PutEdge(chain.edges[i - 1]);
    }
  }

  void CreateBatch(const GraphBatch& chain) override { store_->Put(chain); }

  std::size_t ReadIndividual(const Uuid& start) override {
    std::size_t count = 0;
    Uuid current = start;
    while (true) {
      const Node node = store_->GetNode(current);
      ++count;
      const std::vector<Edge> edges = store_->EdgesFrom(node.id);
      if (edges.empty()) return count;
      current = edges.front().to;
    }
  }

  std::size_t ReadBatch(const Uuid& start) override {
    return store_->ReadChain(start).nodes.size();
  }

 private:
  std::unique_ptr<GraphStore> store_;
};

// One side (ours or raw) of one backend and durability: a store that can be emptied and
// connected to, and that remembers which chain it holds.
class BenchStore {
 public:
  // uri: the GraphStore URI (sqlite:PATH or postgresql://.../DB).
  BenchStore(std::string backend, std::string uri, bool raw, Durability durability,
             bool analyze_before_reads)
      : backend_(std::move(backend)),
        uri_(std::move(uri)),
        raw_(raw),
        analyze_before_reads_(analyze_before_reads && backend_ == "postgresql") {
    options_.durability = durability;
  }

  // An empty store whose tables were made by GraphStore's migrations (for the raw side too).
  void Reset() {
    if (backend_ == "sqlite") {
      const std::string path = SqlitePath();
      for (const char* suffix : {"", "-wal", "-shm", "-journal"}) fs::remove(path + suffix);
    }
    GraphStore::Open(uri_, options_).reset();
    if (backend_ == "postgresql") TruncatePostgresGraphTables(uri_);
    holds_ = Uuid();
    analyzed_ = false;
  }

  // Called before timing a read of the chain the store holds.
  void PrepareForReads() {
    if (analyze_before_reads_ && !analyzed_) AnalyzePostgresGraphTables(uri_);
    analyzed_ = true;
  }

  std::unique_ptr<ChainWorkload> Connect() {
    if (!raw_) return std::make_unique<GraphStoreChain>(GraphStore::Open(uri_, options_));
    if (backend_ == "sqlite") return OpenRawSqliteChain(SqlitePath(), options_.durability);
    return OpenRawPostgresChain(uri_, options_.durability);
  }

  // The first node of the chain the store holds; nil when empty.
  const Uuid& holds() const { return holds_; }
  void set_holds(const Uuid& start) {
    holds_ = start;
    analyzed_ = false;
  }

 private:
  std::string SqlitePath() const { return uri_.substr(std::string("sqlite:").size()); }

  std::string backend_;
  std::string uri_;
  bool raw_;
  bool analyze_before_reads_;
  StoreOptions options_;
  Uuid holds_;
  bool analyzed_ = false;
};

// Small n are repeated (fresh store each time) and the median kept: one run of ten calls is
// mostly noise.
int Repetitions(std::size_t n) {
  return n <= 100 ? 5 : n <= 10'000 ? 3 : 1;
}

// Wall time of one run of op/mode on one store. A read first makes sure the store holds this
// chain (an untimed batch create when the create cases did not leave it there).
double RunOnce(BenchStore& store, const std::string& op, const std::string& mode,
               const GraphBatch& chain) {
  const Uuid& start = chain.nodes.front().id;
  if (op == "create") {
    store.Reset();
    std::unique_ptr<ChainWorkload> w = store.Connect();
    const auto t0 = std::chrono::steady_clock::now();
    if (mode == "individual") {
      w->CreateIndividual(chain);
    } else {
      w->CreateBatch(chain);
    }
    const double seconds = SecondsSince(t0);
    store.set_holds(start);
    return seconds;
  }
  if (store.holds() != start) {
    store.Reset();
    store.Connect()->CreateBatch(chain);
    store.set_holds(start);
  }
  store.PrepareForReads();
  std::unique_ptr<ChainWorkload> w = store.Connect();
  const auto t0 = std::chrono::steady_clock::now();
  const std::size_t read = mode == "individual" ? w->ReadIndividual(start) : w->ReadBatch(start);
  const double seconds = SecondsSince(t0);
  if (read != chain.nodes.size()) {
    throw Error(ErrorCode::kCorrupt, "read back " + std::to_string(read) + " nodes of a chain of " +
                                         std::to_string(chain.nodes.size()));
  }
  return seconds;
}

// Prefixes an Error with the side that threw it.
double RunSide(const char* side, BenchStore& store, const std::string& op, const std::string& mode,
               const GraphBatch& chain) {
  try {
    return RunOnce(store, op, mode, chain);
  } catch (const Error& e) {
    throw Error(e.code(), std::string(side) + ": " + e.what());
  }
}

// Median times of ours and raw. The two alternate run by run, so drift of the machine (other
// load, page cache, writeback) falls on both alike.
std::pair<double, double> MeasurePair(BenchStore& ours, BenchStore& raw, const std::string& op,
                                      const std::string& mode, const GraphBatch& chain) {
  std::vector<double> ours_s, raw_s;
  for (int rep = 0; rep < Repetitions(chain.nodes.size()); ++rep) {
    ours_s.push_back(RunSide("ours", ours, op, mode, chain));
    raw_s.push_back(RunSide("raw", raw, op, mode, chain));
  }
  return {Median(ours_s), Median(raw_s)};
}

std::string Seconds(double s) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.3g s", s);
  return buffer;
}

std::string Ratio(double ours_s, double raw_s) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.2f", ours_s / raw_s);
  return buffer;
}

// Powers of ten from 10 to max_n, and max_n itself when it is not one.
std::vector<std::size_t> Sizes(std::size_t max_n) {
  std::vector<std::size_t> sizes;
  for (std::size_t n = 10; n <= max_n; n *= 10) sizes.push_back(n);
  if (max_n >= 10 && sizes.back() != max_n) sizes.push_back(max_n);
  return sizes;
}

// Databases made for this run, dropped when it ends (also on error).
class ScratchDatabases {
 public:
  explicit ScratchDatabases(std::string admin_uri) : admin_uri_(std::move(admin_uri)) {}
  ScratchDatabases(const ScratchDatabases&) = delete;
  ScratchDatabases& operator=(const ScratchDatabases&) = delete;
  ~ScratchDatabases() {
    for (const std::string& name : names_) {
      try {
        DropPostgresDatabase(admin_uri_, name);
      } catch (const Error& e) {
        std::cerr << "warning: could not drop database " << name << ": " << e.what() << "\n";
      }
    }
  }

  // Creates a database and returns its URI.
  std::string Create(const std::string& name) {
    CreatePostgresDatabase(admin_uri_, name);
    names_.push_back(name);
    return UriWithDatabase(admin_uri_, name);
  }

 private:
  std::string admin_uri_;
  std::vector<std::string> names_;
};

// Runs every selected case of one backend and durability, appending to rows. A case (op,
// mode) that ran over the budget, would by projection, or failed is not run at larger n.
// Returns the number of failed cases.
int RunConfiguration(const GraphBenchOptions& options, const std::string& backend,
                     const std::string& durability_name, BenchStore& ours, BenchStore& raw,
                     std::vector<BenchRow>& rows) {
  const std::size_t max_batch_n = backend == "sqlite" ? options.max_n_sqlite_batch : options.max_n;
  std::vector<std::size_t> sizes = Sizes(options.max_n);
  for (std::size_t n : Sizes(max_batch_n)) sizes.push_back(n);
  std::sort(sizes.begin(), sizes.end());
  sizes.erase(std::unique(sizes.begin(), sizes.end()), sizes.end());

  struct CaseState {
    std::string skip;        // non-empty: why larger n are not run
    std::size_t last_n = 0;  // the last n measured and its slower side's time
    double last_s = 0.0;
  };
  std::map<std::string, CaseState> cases;
  int failures = 0;
  for (std::size_t n : sizes) {
    GraphBatch chain;
    for (const std::string& op : {std::string("create"), std::string("read")}) {
      for (const std::string& mode : {std::string("individual"), std::string("batch")}) {
        if (!Contains(options.ops, op) || !Contains(options.modes, mode)) continue;
        if (n > (mode == "batch" ? max_batch_n : options.max_n)) continue;
        BenchRow row{backend, durability_name, op, mode, n, std::nullopt, std::nullopt, ""};
        CaseState& state = cases[op + " " + mode];
        if (state.skip.empty() && state.last_n > 0) {
          const double projected_s =
              state.last_s * static_cast<double>(n) / static_cast<double>(state.last_n);
          if (projected_s > kProjectionBudgets * options.budget_s) {
            state.skip = "skipped: projected " + Seconds(projected_s) +
                         " from n=" + std::to_string(state.last_n) + ", over " +
                         Seconds(kProjectionBudgets * options.budget_s);
          }
        }
        if (!state.skip.empty()) {
          row.status = state.skip;
          rows.push_back(row);
          continue;
        }
        const std::string label = "[" + backend + " " + durability_name + " " + op + " " + mode +
                                  " n=" + std::to_string(n) + "]";
        if (chain.nodes.empty()) {
          std::cerr << label << " generating the chain\n";
          chain = MakeChain(n, options.ids == "random");
        }
        std::cerr << label << " ..." << std::flush;
        try {
          const auto [ours_s, raw_s] = MeasurePair(ours, raw, op, mode, chain);
          row.ours_s = ours_s;
          row.raw_s = raw_s;
          std::cerr << " ours " << Seconds(ours_s) << ", raw " << Seconds(raw_s) << ", ours/raw "
                    << Ratio(ours_s, raw_s) << "\n";
        } catch (const Error& e) {
          std::cerr << " failed: " << e.what() << "\n";
          row.status = std::string("error: ") + e.what();
          state.skip = "skipped: failed at n=" + std::to_string(n);
          ++failures;
          rows.push_back(row);
          continue;
        }
        const double slower_s = std::max(*row.ours_s, *row.raw_s);
        if (slower_s > options.budget_s) {
          state.skip = "skipped: n=" + std::to_string(n) + " took " + Seconds(slower_s) +
                       ", over the budget of " + Seconds(options.budget_s);
        }
        state.last_n = n;
        state.last_s = slower_s;
        rows.push_back(row);
      }
    }
  }
  return failures;
}

Durability ParseDurability(const std::string& name) {
  return name == "synchronous" ? Durability::kSynchronous : Durability::kBuffered;
}

}  // namespace

void RunGraphBench(const GraphBenchOptions& options) {
  std::string pg_uri = options.pg_uri;
  if (pg_uri.empty()) {
    if (const char* env = std::getenv("FLEETMAP_TEST_PG_URI")) pg_uri = env;
  }
  if (Contains(options.backends, "postgresql") && pg_uri.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "--backends postgresql needs a server: pass --pg postgresql://USER@HOST:PORT/DB "
                "or set FLEETMAP_TEST_PG_URI (the user must be allowed to CREATE DATABASE)");
  }
  const fs::path out_dir(options.out_dir);
  // Random, not time-ordered: two runs started close together must not share a name.
  const std::string run_id = Uuid::GenerateRandom().ToString().substr(0, 8);
  // SQLite files live under --out, so the filesystem synchronous mode fsyncs is the user's.
  const fs::path store_dir = out_dir / ("stores-" + run_id);
  fs::create_directories(store_dir);
  const std::unique_ptr<const fs::path, void (*)(const fs::path*)> remove_stores(
      &store_dir, [](const fs::path* dir) {
        std::error_code ignored;
        fs::remove_all(*dir, ignored);
      });

  std::vector<BenchRow> rows;
  std::vector<std::string> failures;
  for (const std::string& backend : {std::string("sqlite"), std::string("postgresql")}) {
    if (!Contains(options.backends, backend)) continue;
    try {
      std::unique_ptr<ScratchDatabases> databases;
      std::string ours_pg_uri, raw_pg_uri;
      if (backend == "postgresql") {
        databases = std::make_unique<ScratchDatabases>(pg_uri);
        const std::string name = "fleetmap_bench_" + run_id;
        std::cerr << "[postgresql] creating scratch databases " << name << " and " << name
                  << "_raw\n";
        ours_pg_uri = databases->Create(name);
        raw_pg_uri = databases->Create(name + "_raw");
      }
      for (const std::string& durability_name :
           {std::string("synchronous"), std::string("buffered")}) {
        if (!Contains(options.durabilities, durability_name)) continue;
        const Durability durability = ParseDurability(durability_name);
        const std::string stem = (store_dir / (run_id + "-" + durability_name)).string();
        BenchStore ours(backend,
                        backend == "sqlite" ? "sqlite:" + stem + "-ours.sqlite" : ours_pg_uri,
                        false, durability, !options.pg_no_analyze);
        BenchStore raw(backend, backend == "sqlite" ? "sqlite:" + stem + "-raw.sqlite" : raw_pg_uri,
                       true, durability, !options.pg_no_analyze);
        // Both schemas come from GraphStore; a backend that cannot open stops here, clearly.
        ours.Reset();
        raw.Reset();
        const int failed = RunConfiguration(options, backend, durability_name, ours, raw, rows);
        if (failed > 0) {
          failures.push_back(backend + " " + durability_name + ": " + std::to_string(failed) +
                             " case(s) failed (see the table)");
        }
      }
    } catch (const Error& e) {
      std::cerr << "[" << backend << "] not measured: " << e.what() << "\n";
      failures.push_back(backend + ": " + e.what());
    }
  }

  if (!rows.empty()) {
    std::cout << "\nfleetmap bench graph: linear chains, seed 000 Figs 6-7; " << options.ids
              << " UUIDs; median of 5/3/1 runs for n <= 100 / <= 10,000 / larger\n";
    PrintTable(std::cout, rows);
    const fs::path csv = out_dir / "graph_bench.csv";
    WriteCsv(csv, rows);
    std::cout << "\nwrote " << csv.string() << "\n";
    if (PlotWithGnuplot(out_dir, rows, std::cerr)) {
      std::cout << "wrote " << (out_dir / "graph_bench.png").string() << "\n";
    }
    std::cout << "\n";
    PrintHeadlineChecks(std::cout, rows);
  }
  if (!failures.empty()) {
    std::string message = "bench graph: not everything ran:";
    for (const std::string& f : failures) message += "\n  " + f;
    throw Error(ErrorCode::kBackend, message);
  }
}

}  // namespace fleetmap::bench
