// `fleetmap bench index`: seed 000 §6 Table 1 on our sensor index (sensor_index.h), on SQLite
// and PostgreSQL. A 10-sensor platform records N index rows (rates 1-100 Hz, so 10^7 rows are
// about 11 hours of driving); we time
//   insert      InsertData in batches of 50,000 rows (records/s over the whole load)
//   select      GetDatum of a random data_id (median over --samples)
//   nearest     Nearest(platform, random sensor, random t), closest mode (median)
//   join        TemporalJoin(platform, random t) over the 10 sensors (median)
//   batch join  BatchTemporalJoin of the 20 Hz camera over one hour against the 9 others
// and print them beside the paper's figures (250M rows on PostgreSQL, 2015 hardware) and our
// targets. Only the calls are timed (steady_clock); generating rows and ANALYZE are not.
// Index rows point at synthetic files (no record bytes are written): Table 1 times the index.
#include "fleetmap/bench/index_bench.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <optional>
#include <pqxx/pqxx>
#include <random>
#include <string>
#include <vector>

#include "bench_report.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"
#include "index_workload.h"
#include "raw_baseline.h"

namespace fleetmap::bench {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Figures {
  std::string backend;
  std::int64_t rows = 0;
  double insert_per_s = 0;
  double select_us = 0;
  double nearest_us = 0;
  double join_us = 0;
  double batch_s = 0;
  std::int64_t batch_rows = 0;
};

double Seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

double MedianUs(std::vector<double>& us) {
  std::nth_element(us.begin(), us.begin() + static_cast<std::ptrdiff_t>(us.size() / 2), us.end());
  return us[us.size() / 2];
}

// What the load left: the ids it was given, and its last capture time.
struct Loaded {
  DataId first_id = 0, last_id = 0;
  std::int64_t end_ns = 0;
};

// Inserts o.records rows in batches of kBatchRows, timing only InsertData.
Loaded InsertRows(SensorIndex& index, const BenchPlatform& bench_platform,
                  const IndexBenchOptions& o, const std::string& backend, Figures& f) {
  const PlatformId platform = bench_platform.platform;
  const std::vector<SensorId>& sensors = bench_platform.sensors;
  RowSource source(platform, sensors, o.records);
  Clock::duration insert_time{};
  std::int64_t loaded = 0;
  Loaded load;
  DataId& first_id = load.first_id;
  DataId& last_id = load.last_id;
  int last_percent = -1;
  while (true) {
    std::vector<Datum> rows = source.Next(kBatchRows);
    if (rows.empty()) break;
    const auto t0 = Clock::now();
    const std::vector<DataId> ids = index.InsertData(rows);
    insert_time += Clock::now() - t0;
    if (first_id == 0) first_id = ids.front();
    last_id = ids.back();
    loaded += static_cast<std::int64_t>(rows.size());
    const int percent = static_cast<int>(100 * loaded / o.records);
    if (percent / 10 != last_percent / 10) {
      std::cerr << "[" << backend << "] inserted " << loaded << " rows ("
                << static_cast<long long>(static_cast<double>(loaded) / Seconds(insert_time))
                << " rows/s)\n";
      last_percent = percent;
    }
  }
  f.rows = loaded;
  f.insert_per_s = static_cast<double>(loaded) / Seconds(insert_time);
  load.end_ns = source.last_ns();
  return load;
}

// Select by id, nearest and temporal join, each the median of its samples, after warming the
// caches; `rng` draws the ids and times.
void TimeLookups(SensorIndex& index, const BenchPlatform& bench_platform,
                 const IndexBenchOptions& o, const std::string& backend, const Loaded& load,
                 std::mt19937_64& rng, Figures& f) {
  const PlatformId platform = bench_platform.platform;
  const std::vector<SensorId>& sensors = bench_platform.sensors;
  const std::int64_t end_ns = load.end_ns;
  auto random_t = [&] { return std::uniform_int_distribution<std::int64_t>(kStart, end_ns)(rng); };
  std::vector<double> us;
  auto time_us = [&](auto&& call) {
    const auto t0 = Clock::now();
    call();
    us.push_back(Seconds(Clock::now() - t0) * 1e6);
  };
  // Warm the caches a little, as a long-running service would be.
  for (int i = 0; i < 1000; ++i) index.Nearest(platform, sensors[i % kSensors], random_t());

  us.clear();
  std::uniform_int_distribution<DataId> random_id(load.first_id, load.last_id);
  std::int64_t found = 0;
  for (int i = 0; i < o.samples; ++i) {
    const DataId id = random_id(rng);
    time_us([&] { found += index.FindDatum(id).has_value(); });
  }
  f.select_us = MedianUs(us);
  if (found != o.samples) {
    throw Error(ErrorCode::kBackend, "select by id found " + std::to_string(found) + " of " +
                                         std::to_string(o.samples) + " ids on " + backend);
  }

  us.clear();
  for (int i = 0; i < o.samples; ++i) {
    const SensorId s = sensors[static_cast<std::size_t>(i) % kSensors];
    const std::int64_t t = random_t();
    time_us([&] { index.Nearest(platform, s, t); });
  }
  f.nearest_us = MedianUs(us);

  us.clear();
  std::size_t joined = 0;
  for (int i = 0; i < o.join_samples; ++i) {
    const std::int64_t t = random_t();
    time_us([&] { joined += index.TemporalJoin(platform, t).size(); });
  }
  f.join_us = MedianUs(us);
  if (joined != static_cast<std::size_t>(o.join_samples) * kSensors) {
    throw Error(ErrorCode::kBackend, "temporal join returned " + std::to_string(joined) +
                                         " data, expected " + std::to_string(kSensors) +
                                         " per call on " + backend);
  }
}

// Batch join over one hour (or all there is, if less), from a random start.
void TimeBatchJoin(SensorIndex& index, const BenchPlatform& bench_platform,
                   const std::string& backend, const Loaded& load, std::mt19937_64& rng,
                   Figures& f) {
  const PlatformId platform = bench_platform.platform;
  const std::vector<SensorId>& sensors = bench_platform.sensors;
  const std::int64_t end_ns = load.end_ns;
  const std::int64_t span = std::min<std::int64_t>(kHour, end_ns - kStart);
  const std::int64_t t0 = std::uniform_int_distribution<std::int64_t>(kStart, end_ns - span)(rng);
  const auto b0 = Clock::now();
  std::int64_t matched = 0;
  f.batch_rows =
      index.BatchTemporalJoin(platform, sensors[kCamera], t0, t0 + span, [&](const JoinedRow& row) {
        for (const auto& other : row.others) {
          matched += other.has_value();
        }
      });
  f.batch_s = Seconds(Clock::now() - b0);
  if (matched != f.batch_rows * (kSensors - 1)) {
    throw Error(ErrorCode::kBackend, "batch join matched " + std::to_string(matched) + " of " +
                                         std::to_string(f.batch_rows * (kSensors - 1)) + " on " +
                                         backend);
  }
  std::cerr << "[" << backend << "] batch join: " << f.batch_rows << " camera rows over "
            << static_cast<double>(span) / kHour << " h\n";
}

Figures RunOne(const std::string& backend, const std::string& uri, const IndexBenchOptions& o) {
  Figures f;
  f.backend = backend;
  StoreOptions store_options;
  if (backend == "sqlite" && o.sqlite_buffered) store_options.durability = Durability::kBuffered;
  auto store = GraphStore::Open(uri, store_options);
  SensorIndex& index = store->sensors();
  if (index.CountData() != 0) {
    throw Error(ErrorCode::kConflict,
                "bench index needs an empty index; " + store->uri() + " already holds data");
  }
  const BenchPlatform bench_platform = AddBenchPlatform(index);
  const Loaded load = InsertRows(index, bench_platform, o, backend, f);
  if (backend == "postgresql") {
    // What autovacuum would do after a bulk load; not timed.
    pqxx::connection c(uri);
    pqxx::nontransaction t(c);
    t.exec("ANALYZE data");
  }
  std::mt19937_64 rng(42);
  TimeLookups(index, bench_platform, o, backend, load, rng, f);
  TimeBatchJoin(index, bench_platform, backend, load, rng, f);
  return f;
}

void PrintTable(const std::vector<Figures>& all) {
  std::printf("\nTable 1 (seed 000 §6): sensor index, 10-sensor platform\n");
  std::printf("%-34s %-22s", "query", "paper (PG, 250M rows)");
  for (const Figures& f : all) {
    std::printf(" %-22s", (f.backend + " (" + std::to_string(f.rows) + " rows)").c_str());
  }
  std::printf("\n");
  auto line = [&](const char* name, const char* paper, auto cell) {
    std::printf("%-34s %-22s", name, paper);
    for (const Figures& f : all) std::printf(" %-22s", cell(f).c_str());
    std::printf("\n");
  };
  line("insert rate (records/s)", "~5,800 (12 h)",
       [](const Figures& f) { return Format("%.0f", f.insert_per_s); });
  line("select by id (median)", "0.06 ms",
       [](const Figures& f) { return Format("%.1f us", f.select_us); });
  line("nearest (platform,sensor,t) (med)", "0.06 ms",
       [](const Figures& f) { return Format("%.1f us", f.nearest_us); });
  line("temporal join at instant (median)", "7.5 ms",
       [](const Figures& f) { return Format("%.1f us", f.join_us); });
  line("batch temporal join, 1 hour", "14.7 s", [](const Figures& f) {
    return Format("%.2f s", f.batch_s) + " (" + std::to_string(f.batch_rows) + " rows)";
  });
}

// The index's targets; returns the failed ones.
std::vector<std::string> CheckTargets(const std::vector<Figures>& all) {
  std::vector<std::string> failed;
  auto check = [&](bool ok, const std::string& what) {
    std::printf("  %s %s\n", ok ? "PASS" : "FAIL", what.c_str());
    if (!ok) failed.push_back(what);
  };
  std::printf("\ntargets:\n");
  for (const Figures& f : all) {
    const bool sqlite = f.backend == "sqlite";
    if (sqlite) {
      check(f.insert_per_s >= 300'000,
            "sqlite insert >= 300,000 records/s: " + Format("%.0f", f.insert_per_s));
    }
    const double nearest_limit = sqlite ? 20 : 200;
    check(f.nearest_us <= nearest_limit, f.backend +
                                             " nearest median <= " + Format("%.0f", nearest_limit) +
                                             " us: " + Format("%.1f", f.nearest_us));
    check(f.join_us <= 1000,
          f.backend + " temporal join median <= 1 ms: " + Format("%.1f", f.join_us) + " us");
  }
  return failed;
}

}  // namespace

void RunIndexBench(const IndexBenchOptions& o) {
  std::vector<std::pair<std::string, std::string>> stores;  // backend, uri
  std::optional<std::string> scratch_db;
  std::string admin_uri = o.pg_uri;
  fs::path sqlite_file;
  const std::string run_id = Uuid::GenerateRandom().ToString().substr(0, 8);
  if (!o.stores.empty()) {
    for (const std::string& uri : o.stores) {
      stores.emplace_back(uri.rfind("sqlite:", 0) == 0 ? "sqlite" : "postgresql", uri);
    }
  } else {
    fs::create_directories(o.out_dir);
    sqlite_file = fs::path(o.out_dir) / ("index-bench-" + run_id + ".sqlite");
    stores.emplace_back("sqlite", "sqlite:" + sqlite_file.string());
    if (admin_uri.empty()) {
      if (const char* env = std::getenv("FLEETMAP_TEST_PG_URI")) admin_uri = env;
    }
    if (!admin_uri.empty()) {
      scratch_db = "fleetmap_bench_index_" + run_id;
      CreatePostgresDatabase(admin_uri, *scratch_db);
      stores.emplace_back("postgresql", UriWithDatabase(admin_uri, *scratch_db));
    } else {
      std::cerr << "no PostgreSQL (--pg or FLEETMAP_TEST_PG_URI): SQLite only\n";
    }
  }
  auto cleanup = [&] {
    std::error_code ignored;
    if (!sqlite_file.empty()) {
      for (const char* suffix : {"", "-wal", "-shm"})
        fs::remove(sqlite_file.string() + suffix, ignored);
    }
    if (scratch_db) {
      try {
        DropPostgresDatabase(admin_uri, *scratch_db);
      } catch (const Error& e) {
        std::cerr << "could not drop " << *scratch_db << ": " << e.what() << "\n";
      }
    }
  };
  std::vector<Figures> all;
  try {
    for (const auto& [backend, uri] : stores) {
      std::cerr << "[" << backend << "] " << o.records << " rows into " << uri << "\n";
      all.push_back(RunOne(backend, uri, o));
    }
  } catch (...) {
    cleanup();
    throw;
  }
  cleanup();
  PrintTable(all);
  const std::vector<std::string> failed = CheckTargets(all);
  if (!failed.empty()) {
    throw Error(ErrorCode::kBackend, std::to_string(failed.size()) + " target(s) missed");
  }
}

}  // namespace fleetmap::bench
