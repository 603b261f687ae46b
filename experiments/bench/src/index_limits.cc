// See index_limits.h.
#include "index_limits.h"

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <random>
#include <tuple>
#include <utility>
#include <vector>

#include "bench_report.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/store/sensor_index.h"
#include "index_workload.h"
#include "raw_baseline.h"
#include "raw_sensor_index.h"

namespace fleetmap::bench {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsIn(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

// Removes a SQLite file and its WAL when it goes out of scope.
class ScratchSqliteFile {
 public:
  explicit ScratchSqliteFile(fs::path path) : path_(std::move(path)) {}
  ~ScratchSqliteFile() {
    std::error_code ignored;
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(path_.string() + suffix, ignored);
  }
  ScratchSqliteFile(const ScratchSqliteFile&) = delete;
  ScratchSqliteFile& operator=(const ScratchSqliteFile&) = delete;
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

// Loads the workload's rows through `insert(batch)`; returns rows per second of the calls.
template <typename Insert>
double Load(const BenchPlatform& p, std::int64_t rows, Insert&& insert) {
  RowSource source(p.platform, p.sensors, rows);
  Clock::duration spent{};
  std::int64_t loaded = 0;
  while (true) {
    const std::vector<Datum> batch = source.Next(kBatchRows);
    if (batch.empty()) break;
    const auto t0 = Clock::now();
    insert(batch);
    spent += Clock::now() - t0;
    loaded += static_cast<std::int64_t>(batch.size());
  }
  return static_cast<double>(loaded) / SecondsIn(spent);
}

// Loads the rows through ours and the raw side, in the order asked; rows/s of each.
template <typename Ours, typename Raw>
std::pair<double, double> LoadBoth(const BenchPlatform& p, std::int64_t rows, bool ours_first,
                                   Ours&& ours, Raw&& raw) {
  double ours_per_s = 0, raw_per_s = 0;
  if (ours_first) ours_per_s = Load(p, rows, ours);
  raw_per_s = Load(p, rows, raw);
  if (!ours_first) ours_per_s = Load(p, rows, ours);
  return {ours_per_s, raw_per_s};
}

}  // namespace

IndexAgainstRaw MeasureSqliteIndexAgainstRaw(const std::string& dir, std::int64_t rows,
                                             Durability durability, int samples, bool ours_first) {
  fs::create_directories(dir);
  const std::string run = Uuid::GenerateRandom().ToString().substr(0, 8);
  const ScratchSqliteFile ours_file(fs::path(dir) / ("index-ours-" + run + ".sqlite"));
  const ScratchSqliteFile raw_file(fs::path(dir) / ("index-raw-" + run + ".sqlite"));
  StoreOptions options;
  options.durability = durability;

  // Both files get the schema and the platform from our migrations, so ids agree.
  std::unique_ptr<GraphStore> ours =
      GraphStore::Open("sqlite:" + ours_file.path().string(), options);
  const BenchPlatform p = AddBenchPlatform(ours->sensors());
  {
    auto raw_schema = GraphStore::Open("sqlite:" + raw_file.path().string(), options);
    const BenchPlatform same = AddBenchPlatform(raw_schema->sensors());
    if (same.sensors != p.sensors) {
      throw Error(ErrorCode::kBackend, "raw index baseline: sensor ids differ from ours");
    }
  }
  std::unique_ptr<RawSqliteSensorIndex> raw =
      OpenRawSqliteSensorIndex(raw_file.path().string(), durability);

  IndexAgainstRaw f;
  std::tie(f.ours_insert_per_s, f.raw_insert_per_s) = LoadBoth(
      p, rows, ours_first, [&](const std::vector<Datum>& b) { ours->sensors().InsertData(b); },
      [&](const std::vector<Datum>& b) { raw->Insert(b); });

  RowSource extent(p.platform, p.sensors, rows);
  while (!extent.Next(kBatchRows).empty()) {
  }
  std::mt19937_64 rng(7);
  std::uniform_int_distribution<std::int64_t> random_t(kStart, extent.last_ns());
  std::vector<double> ours_us, raw_us;
  ours_us.reserve(static_cast<std::size_t>(samples));
  raw_us.reserve(static_cast<std::size_t>(samples));
  for (int i = 0; i < samples + 1000; ++i) {  // the first 1000 warm the caches, untimed
    const SensorId sensor = p.sensors[static_cast<std::size_t>(i) % p.sensors.size()];
    const std::int64_t t = random_t(rng);
    const auto t0 = Clock::now();
    const std::optional<Datum> a = ours->sensors().Nearest(p.platform, sensor, t);
    const auto t1 = Clock::now();
    const std::optional<Datum> b = raw->Nearest(p.platform, sensor, t);
    const auto t2 = Clock::now();
    if (a != b) {
      throw Error(ErrorCode::kBackend, "nearest at " + std::to_string(t) + ": ours and raw differ");
    }
    if (i < 1000) continue;
    ours_us.push_back(SecondsIn(t1 - t0) * 1e6);
    raw_us.push_back(SecondsIn(t2 - t1) * 1e6);
  }
  f.ours_nearest_us = Median(ours_us);
  f.raw_nearest_us = Median(raw_us);
  return f;
}

IngestAgainstRaw MeasurePostgresIngestAgainstRaw(const std::string& admin_uri, std::int64_t rows,
                                                 Durability durability, bool ours_first) {
  const std::string run = Uuid::GenerateRandom().ToString().substr(0, 8);
  const std::string ours_db = "fleetmap_limits_ours_" + run;
  const std::string raw_db = "fleetmap_limits_raw_" + run;
  CreatePostgresDatabase(admin_uri, ours_db);
  IngestAgainstRaw f;
  try {
    CreatePostgresDatabase(admin_uri, raw_db);
    try {
      StoreOptions options;
      options.durability = durability;
      std::unique_ptr<GraphStore> ours =
          GraphStore::Open(UriWithDatabase(admin_uri, ours_db), options);
      const BenchPlatform p = AddBenchPlatform(ours->sensors());
      {
        auto raw_schema = GraphStore::Open(UriWithDatabase(admin_uri, raw_db), options);
        AddBenchPlatform(raw_schema->sensors());
      }
      std::unique_ptr<RawPostgresIngest> raw =
          OpenRawPostgresIngest(UriWithDatabase(admin_uri, raw_db), durability);
      std::tie(f.ours_insert_per_s, f.raw_insert_per_s) = LoadBoth(
          p, rows, ours_first, [&](const std::vector<Datum>& b) { ours->sensors().InsertData(b); },
          [&](const std::vector<Datum>& b) { raw->Insert(b); });
    } catch (...) {
      DropPostgresDatabase(admin_uri, raw_db);
      throw;
    }
    DropPostgresDatabase(admin_uri, raw_db);
  } catch (...) {
    DropPostgresDatabase(admin_uri, ours_db);
    throw;
  }
  DropPostgresDatabase(admin_uri, ours_db);
  return f;
}

}  // namespace fleetmap::bench
