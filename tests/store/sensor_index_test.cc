// SensorIndex (seed 000 §4.1, Eqs. 1-2) on both backends: platforms, sensors and mounts, the
// nearest datum (before / after / closest, tolerance), the temporal join Ω(r, t), the streamed
// batch join, and ingest / reindex of record files (idempotent, equal, relocatable root).
#include "fleetmap/store/sensor_index.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/records/record_file.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/records/sensor_ingest.h"
#include "fleetmap/store/graph_store.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::BackendNames;
using testing::StoreBackends;

constexpr std::int64_t kMs = 1'000'000;

template <typename Backend>
class SensorIndexTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    store_ = GraphStore::Open(backend_->Uri());
  }

  SensorIndex& index() { return store_->sensors(); }

  // Rows of one sensor on one platform at the given stamps (ms), in a made-up file.
  std::vector<DataId> Insert(PlatformId p, SensorId s, const std::vector<std::int64_t>& stamps_ms,
                             const std::string& file) {
    std::vector<Datum> rows;
    std::uint64_t offset = 0;
    for (std::int64_t ms : stamps_ms) {
      rows.push_back(Datum{0, p, s, ms * kMs, file, offset, 100, "fleetmap.v1.Test"});
      offset += 100;
    }
    return index().InsertData(rows);
  }

  std::optional<Backend> backend_;
  std::unique_ptr<GraphStore> store_;
};

TYPED_TEST_SUITE(SensorIndexTest, StoreBackends, BackendNames);

TYPED_TEST(SensorIndexTest, PlatformsAndSensorsAreAddedOnceByName) {
  SensorIndex& x = this->index();
  const PlatformId p = x.AddPlatform("husky1");
  EXPECT_EQ(x.AddPlatform("husky1"), p);
  EXPECT_NE(x.AddPlatform("husky2"), p);
  const SensorId s = x.AddSensor("bumblebee", "camera");
  EXPECT_EQ(x.AddSensor("bumblebee", "camera"), s);
  ExpectError(
      ErrorCode::kConflict, [&] { x.AddSensor("bumblebee", "gps"); }, "bumblebee");
  EXPECT_EQ(x.GetPlatform(p).name, "husky1");
  EXPECT_EQ(x.GetSensor(s), (Sensor{s, "bumblebee", "camera"}));
  EXPECT_EQ(x.FindSensor("nope"), std::nullopt);
  ExpectError(ErrorCode::kNotFound, [&] { x.GetPlatform(p + 100); });
}

TYPED_TEST(SensorIndexTest, InsertReturnsIdsAndIsIdempotentByFileAndOffset) {
  SensorIndex& x = this->index();
  const PlatformId p = x.AddPlatform("r");
  const SensorId s = x.AddSensor("gps", "gps");
  // 300 rows: two full 128-row chunks on SQLite plus single rows.
  std::vector<std::int64_t> stamps;
  for (int i = 0; i < 300; ++i) stamps.push_back(i * 10);
  const std::vector<DataId> ids = this->Insert(p, s, stamps, "r/gps/a.rec");
  ASSERT_EQ(ids.size(), 300u);
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const Datum d = x.GetDatum(ids[i]);
    EXPECT_EQ(d.stamp_ns, stamps[i] * kMs);
    EXPECT_EQ(d.offset, i * 100);
    EXPECT_EQ(d.file, "r/gps/a.rec");
  }
  std::int64_t inserted = -1;
  std::vector<Datum> again;
  for (DataId id : ids) again.push_back(x.GetDatum(id));
  EXPECT_EQ(x.InsertData(again, &inserted), ids);
  EXPECT_EQ(inserted, 0);
  EXPECT_EQ(x.CountData(), 300);
  ExpectError(ErrorCode::kNotFound, [&] { x.GetDatum(ids.back() + 1000); });
}

TYPED_TEST(SensorIndexTest, NearestBeforeAfterClosestAndTolerance) {
  SensorIndex& x = this->index();
  const PlatformId p = x.AddPlatform("r");
  const SensorId s = x.AddSensor("laser", "laser");
  x.Mount(s, p, 0, std::nullopt);
  this->Insert(p, s, {100, 200, 300}, "f.rec");
  auto at = [&](std::int64_t ms, NearestMode mode,
                std::optional<std::int64_t> tol_ms = {}) -> std::optional<std::int64_t> {
    NearestQuery q{mode, tol_ms ? std::optional<std::int64_t>(*tol_ms * kMs) : std::nullopt};
    auto d = x.Nearest(p, s, ms * kMs, q);
    if (!d) return std::nullopt;
    return d->stamp_ns / kMs;
  };
  EXPECT_EQ(at(240, NearestMode::kBefore), 200);
  EXPECT_EQ(at(240, NearestMode::kAfter), 300);
  EXPECT_EQ(at(240, NearestMode::kClosest), 200);
  EXPECT_EQ(at(260, NearestMode::kClosest), 300);
  EXPECT_EQ(at(250, NearestMode::kClosest), 200);  // a tie goes to before
  EXPECT_EQ(at(200, NearestMode::kBefore), 200);   // exact hits count both ways
  EXPECT_EQ(at(200, NearestMode::kAfter), 200);
  EXPECT_EQ(at(50, NearestMode::kBefore), std::nullopt);
  EXPECT_EQ(at(50, NearestMode::kClosest), 100);
  EXPECT_EQ(at(350, NearestMode::kAfter), std::nullopt);
  // Tolerance: 260 is 40 ms from 300 and 60 ms from 200.
  EXPECT_EQ(at(260, NearestMode::kClosest, 50), 300);
  EXPECT_EQ(at(260, NearestMode::kClosest, 30), std::nullopt);
  EXPECT_EQ(at(260, NearestMode::kBefore, 50), std::nullopt);
  EXPECT_EQ(at(1000, NearestMode::kClosest, 100), std::nullopt);
  // Another platform's data never match.
  const PlatformId other = x.AddPlatform("other");
  EXPECT_EQ(x.Nearest(other, s, 200 * kMs), std::nullopt);
}

TYPED_TEST(SensorIndexTest, TemporalJoinAtAnInstantOverThreeSensors) {
  SensorIndex& x = this->index();
  const PlatformId p = x.AddPlatform("r");
  const SensorId cam = x.AddSensor("cam", "camera");
  const SensorId gps = x.AddSensor("gps", "gps");
  const SensorId imu = x.AddSensor("imu", "imu");
  for (SensorId s : {cam, gps, imu}) x.Mount(s, p, 0, std::nullopt);
  const auto cams = this->Insert(p, cam, {100, 200, 300}, "cam.rec");
  const auto gpss = this->Insert(p, gps, {90, 193, 310}, "gps.rec");
  const auto imus = this->Insert(p, imu, {101, 151, 201, 251}, "imu.rec");
  const std::vector<Datum> joined = x.TemporalJoin(p, 195 * kMs);
  ASSERT_EQ(joined.size(), 3u);
  EXPECT_EQ(joined[0].id, cams[1]);
  EXPECT_EQ(joined[1].id, gpss[1]);
  EXPECT_EQ(joined[2].id, imus[2]);
  // Camera 5 ms, GPS 2 ms, IMU 6 ms away: a tolerance of 6 ms keeps all, 4 ms only the GPS.
  const std::vector<Datum> tight = x.TemporalJoin(p, 195 * kMs, {NearestMode::kClosest, 6 * kMs});
  ASSERT_EQ(tight.size(), 3u);
  const std::vector<Datum> tighter = x.TemporalJoin(p, 195 * kMs, {NearestMode::kClosest, 4 * kMs});
  ASSERT_EQ(tighter.size(), 1u);
  EXPECT_EQ(tighter[0].id, gpss[1]);
  EXPECT_EQ(x.SensorsOn(p, 195 * kMs), (std::vector<SensorId>{cam, gps, imu}));
}

TYPED_TEST(SensorIndexTest, BatchJoinStreamsEveryBaseRecordWithItsNearestOthers) {
  SensorIndex& x = this->index();
  const PlatformId p = x.AddPlatform("r");
  const SensorId cam = x.AddSensor("cam", "camera");
  const SensorId gps = x.AddSensor("gps", "gps");
  const SensorId imu = x.AddSensor("imu", "imu");
  for (SensorId s : {cam, gps, imu}) x.Mount(s, p, 0, std::nullopt);
  // 5000 camera frames every 10 ms (more than two pages), GPS every 1 s, IMU every 3 ms.
  std::vector<std::int64_t> cam_ms, gps_ms, imu_ms;
  for (int i = 0; i < 5000; ++i) cam_ms.push_back(1000 + 10 * i);
  for (int i = 0; i <= 60; ++i) gps_ms.push_back(500 + 1000 * i);
  for (int i = 0; i < 20000; ++i) imu_ms.push_back(999 + 3 * i);
  this->Insert(p, cam, cam_ms, "cam.rec");
  this->Insert(p, gps, gps_ms, "gps.rec");
  this->Insert(p, imu, imu_ms, "imu.rec");

  std::vector<SensorId> order;
  std::int64_t rows = 0, checked_mismatch = 0;
  const std::int64_t t0 = 2000 * kMs, t1 = 40000 * kMs;
  const std::int64_t n = x.BatchTemporalJoin(
      p, cam, t0, t1,
      [&](const JoinedRow& row) {
        ++rows;
        ASSERT_EQ(row.others.size(), 2u);
        // Every 97th row is checked against the one-off query.
        if (rows % 97 != 1) return;
        for (std::size_t i = 0; i < 2; ++i) {
          const auto expected = x.Nearest(p, order[i], row.base.stamp_ns);
          if (row.others[i] != expected) ++checked_mismatch;
        }
      },
      {}, &order);
  EXPECT_EQ(order, (std::vector<SensorId>{gps, imu}));
  EXPECT_EQ(n, (40000 - 2000) / 10 + 1);
  EXPECT_EQ(rows, n);
  EXPECT_EQ(checked_mismatch, 0);

  // The matches may lie outside [t0, t1]: GPS before t0 at the start, after t1 at the end.
  std::vector<std::optional<Datum>> first_gps;
  x.BatchTemporalJoin(p, cam, 1990 * kMs, 1990 * kMs,
                      [&](const JoinedRow& row) { first_gps.push_back(row.others[0]); },
                      {NearestMode::kBefore, std::nullopt});
  ASSERT_EQ(first_gps.size(), 1u);
  ASSERT_TRUE(first_gps[0].has_value());
  EXPECT_EQ(first_gps[0]->stamp_ns, 1500 * kMs);
  std::optional<Datum> late;
  x.BatchTemporalJoin(p, cam, 50900 * kMs, 50990 * kMs,
                      [&](const JoinedRow& row) { late = row.others[0]; },
                      {NearestMode::kAfter, std::nullopt});
  ASSERT_TRUE(late.has_value());
  EXPECT_EQ(late->stamp_ns, 51500 * kMs);
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { x.BatchTemporalJoin(p, cam, t1, t0, [](const JoinedRow&) {}); });
}

TYPED_TEST(SensorIndexTest, SensorMovedBetweenPlatforms) {
  SensorIndex& x = this->index();
  const PlatformId a = x.AddPlatform("husky");
  const PlatformId b = x.AddPlatform("wildcat");
  const SensorId gps = x.AddSensor("gps7", "gps");
  const SensorId cam_a = x.AddSensor("cam-a", "camera");
  const SensorId cam_b = x.AddSensor("cam-b", "camera");
  x.Mount(cam_a, a, 0, std::nullopt);
  x.Mount(cam_b, b, 0, std::nullopt);
  x.Mount(gps, a, 0, 1000 * kMs);
  x.Mount(gps, b, 1000 * kMs, std::nullopt);
  x.Mount(gps, b, 1000 * kMs, std::nullopt);  // the same mount again: a no-op
  EXPECT_EQ(x.MountsOf(gps).size(), 2u);
  // Never on two platforms at once.
  ExpectError(
      ErrorCode::kConflict, [&] { x.Mount(gps, a, 1500 * kMs, 1600 * kMs); }, "gps");
  ExpectError(ErrorCode::kConflict, [&] { x.Mount(gps, b, 500 * kMs, 700 * kMs); });
  ExpectError(ErrorCode::kConflict, [&] { x.Mount(gps, a, -10 * kMs, std::nullopt); });
  ExpectError(ErrorCode::kInvalidArgument, [&] { x.Mount(gps, a, 5, 5); });
  EXPECT_EQ(x.PlatformOf(gps, 999 * kMs), a);
  EXPECT_EQ(x.PlatformOf(gps, 1000 * kMs), b);
  EXPECT_EQ(x.PlatformOf(gps, -1), std::nullopt);

  const auto gps_on_a = this->Insert(a, gps, {100, 500, 900}, "husky/gps7/x.rec");
  const auto gps_on_b = this->Insert(b, gps, {1100, 1500}, "wildcat/gps7/y.rec");
  this->Insert(a, cam_a, {400, 1400}, "husky/cam-a/x.rec");
  this->Insert(b, cam_b, {400, 1400}, "wildcat/cam-b/y.rec");

  // Before the move the GPS is part of husky's world state; after it, of wildcat's.
  const auto husky_before = x.TemporalJoin(a, 450 * kMs);
  ASSERT_EQ(husky_before.size(), 2u);
  EXPECT_EQ(husky_before[0].id, gps_on_a[1]);
  const auto husky_after = x.TemporalJoin(a, 1450 * kMs);
  ASSERT_EQ(husky_after.size(), 1u);
  EXPECT_EQ(husky_after[0].sensor, cam_a);
  EXPECT_EQ(x.TemporalJoin(b, 450 * kMs).size(), 1u);
  const auto wildcat_after = x.TemporalJoin(b, 1450 * kMs);
  ASSERT_EQ(wildcat_after.size(), 2u);
  EXPECT_EQ(wildcat_after[0].id, gps_on_b[1]);
}

// ---- Ingest and reindex ----------------------------------------------------------------

// A repository root with two sensors of one platform in the layout PLATFORM/SENSOR/DATE/.
std::vector<fs::path> WriteRepository(const fs::path& root) {
  std::vector<fs::path> files;
  const std::int64_t t0 = 1'700'000'000'000'000'000;
  for (const auto& [sensor, type, period_ms, count] :
       {std::tuple{"cam", "fleetmap.v1.StereoImagePair", 50, 300},
        std::tuple{"gps", "fleetmap.v1.GpsFix", 200, 80}}) {
    const fs::path file = root / RecordFilePath("husky", sensor, t0);
    fs::create_directories(file.parent_path());
    RecordWriter writer(file);
    for (int i = 0; i < count; ++i) {
      writer.Append(
          t0 + static_cast<std::int64_t>(i) * period_ms * kMs, type,
          std::string(static_cast<std::size_t>(10 + i % 7), static_cast<char>('a' + i % 26)));
    }
    writer.Flush();
    files.push_back(file);
  }
  return files;
}

// Everything but the ids, for comparing two indexes.
std::vector<std::tuple<std::string, std::string, std::int64_t, std::string, std::uint64_t,
                       std::uint64_t, std::string>>
Rows(SensorIndex& x) {
  std::vector<std::tuple<std::string, std::string, std::int64_t, std::string, std::uint64_t,
                         std::uint64_t, std::string>>
      rows;
  for (const IndexedFile& f : x.ListFiles()) {
    for (const Datum& d : x.DataOfFile(f.file)) {
      rows.emplace_back(x.GetPlatform(d.platform).name, x.GetSensor(d.sensor).name, d.stamp_ns,
                        d.file, d.offset, d.length, d.type);
    }
  }
  return rows;
}

TYPED_TEST(SensorIndexTest, IngestIsIdempotentAndReindexEqualsIt) {
  ScratchDir dir("sensor-index");
  const fs::path root = dir / "repo";
  const std::vector<fs::path> files = WriteRepository(root);
  SensorIndex& x = this->index();
  IngestResult first = IngestRecordFile(x, root, files[0], "husky", "cam");
  EXPECT_EQ(first.records, 300);
  EXPECT_EQ(first.inserted, 300);
  IngestResult gps = IngestRecordFile(x, root, files[1], "husky", "gps");
  EXPECT_EQ(gps.inserted, 80);
  EXPECT_EQ(x.CountData(), 380);
  // Paths are stored relative to the root.
  const auto listed = x.ListFiles();
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].file, RelativeToRoot(root, files[0]).generic_string());
  EXPECT_EQ(listed[0].records, 300);

  // Again: unchanged files are skipped; a forced rescan adds nothing either.
  IngestResult again = IngestRecordFile(x, root, files[0], "husky", "cam");
  EXPECT_EQ(again.files_unchanged, 1);
  EXPECT_EQ(again.inserted, 0);
  IngestResult rescan = IngestRecordFile(x, root, files[0], "husky", "cam", true);
  EXPECT_EQ(rescan.records, 300);
  EXPECT_EQ(rescan.inserted, 0);
  EXPECT_EQ(x.CountData(), 380);

  // Reindex into a second store of the same backend gives the same rows.
  TypeParam other_backend;
  auto other = GraphStore::Open(other_backend.Uri());
  IngestResult re = ReindexRoot(other->sensors(), root);
  EXPECT_EQ(re.files, 2);
  EXPECT_EQ(re.inserted, 380);
  EXPECT_TRUE(re.problems.empty());
  EXPECT_EQ(Rows(other->sensors()), Rows(x));
  // Reindex over an ingested index adds nothing.
  EXPECT_EQ(ReindexRoot(x, root).inserted, 0);

  // The ingested sensors were mounted: Ω(r, t) finds both.
  const PlatformId husky = x.FindPlatform("husky")->id;
  const std::int64_t t = 1'700'000'000'000'000'000 + 1234 * kMs;
  const auto joined = x.TemporalJoin(husky, t);
  ASSERT_EQ(joined.size(), 2u);
  EXPECT_EQ(joined[0].stamp_ns, 1'700'000'000'000'000'000 + 1250 * kMs);
  EXPECT_EQ(joined[1].stamp_ns, 1'700'000'000'000'000'000 + 1200 * kMs);
}

TYPED_TEST(SensorIndexTest, MovedRootStillResolvesAndReindexes) {
  ScratchDir dir("sensor-index");
  const fs::path root = dir / "repo";
  const std::vector<fs::path> files = WriteRepository(root);
  SensorIndex& x = this->index();
  ReindexRoot(x, root);
  const PlatformId husky = x.FindPlatform("husky")->id;
  const SensorId gps = x.FindSensor("gps")->id;
  const Datum d = *x.Nearest(husky, gps, 1'700'000'000'000'000'000 + 2000 * kMs);

  const fs::path moved = dir / "elsewhere" / "repo2";
  fs::create_directories(moved.parent_path());
  fs::rename(root, moved);
  // Read the record via the new root and the stored relative path.
  RecordReader reader(ResolveUnderRoot(moved, d.file));
  const Record r = reader.ReadAt(d.offset);
  EXPECT_EQ(r.header.stamp_ns, d.stamp_ns);
  EXPECT_EQ(r.location.length, d.length);
  EXPECT_EQ(r.header.type, "fleetmap.v1.GpsFix");
  // Reindexing at the new place finds every row already there.
  const auto before = Rows(x);
  EXPECT_EQ(ReindexRoot(x, moved).inserted, 0);
  EXPECT_EQ(Rows(x), before);
}

// Symbolic links under a root that lead out of it: one to a directory of record files, one to
// a single record file elsewhere. Reindex followed the file link (and would index whatever a
// link points at as if it lay under the root); now it indexes neither, and reports each link
// by its path as a skipped problem. Ingesting a file through a link is refused, naming it.
TYPED_TEST(SensorIndexTest, SymlinksUnderTheRootAreReportedAndNotFollowed) {
  ScratchDir dir("sensor-index");
  const fs::path root = dir / "repo";
  const std::vector<fs::path> files = WriteRepository(root);
  const std::vector<fs::path> outside = WriteRepository(dir / "outside");
  const fs::path dir_link = root / "husky" / "lidar";
  fs::create_directory_symlink(outside[0].parent_path().parent_path(), dir_link);
  const fs::path file_link = files[1].parent_path() / "elsewhere.rec";
  fs::create_symlink(outside[1], file_link);

  SensorIndex& x = this->index();
  const IngestResult r = ReindexRoot(x, root);
  EXPECT_EQ(r.files, 2);
  EXPECT_EQ(r.inserted, 380);
  std::vector<fs::path> reported;
  for (const RecordProblem& p : r.problems) {
    reported.push_back(p.file);
    EXPECT_NE(p.what.find("symbolic link"), std::string::npos) << p.what;
  }
  std::sort(reported.begin(), reported.end());
  EXPECT_EQ(reported, (std::vector<fs::path>{file_link, dir_link}));
  const auto listed = x.ListFiles();
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].file, RelativeToRoot(root, files[0]).generic_string());
  EXPECT_EQ(listed[1].file, RelativeToRoot(root, files[1]).generic_string());

  ExpectError(
      ErrorCode::kInvalidArgument, [&] { IngestRecordFile(x, root, file_link, "husky", "gps"); },
      file_link.string());
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] {
        IngestRecordFile(x, root,
                         dir_link / files[0].parent_path().filename() / files[0].filename(),
                         "husky", "lidar");
      },
      dir_link.string());
  EXPECT_EQ(x.CountData(), 380);
  EXPECT_EQ(x.ListFiles().size(), 2u);
}

}  // namespace
}  // namespace fleetmap
