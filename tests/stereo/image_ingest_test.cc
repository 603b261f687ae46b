// `fleetmap images ingest` (stereo_image_log.h, seed 000 §5.1): a synthetic EuRoC folder into a
// record file and a SQLite sensor index, read back record by record (stamps, PNG bytes identical
// to the source files) and found by time; every bad image leaves nothing under the root and
// nothing indexed; ingesting twice is a conflict that harms the first log; a KITTI folder with
// its calibration written as EuRoC yaml files that read back. Then the built executable end to
// end: the summary line, --layout and --platform, and exit 1 with a message naming the culprit.
#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/records/record_file.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/sensors.pb.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_image_log.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "image_files.h"
#include "jpeg_test_file.h"
#include "kitti_test_data.h"
#include "scratch_dir.h"
#include "synthetic_euroc.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::kEurocHeightPx;
using testing::kEurocWidthPx;
using testing::ReadFileBytes;
using testing::SyntheticEuroc;
using testing::SyntheticKitti;

constexpr int kIngestPairs = 5;
constexpr std::int64_t kMs = 1'000'000;

// Every path under `dir` (empty when `dir` is missing), for "nothing was left" checks.
std::vector<std::string> Contents(const fs::path& dir) {
  std::vector<std::string> paths;
  if (!fs::exists(dir)) return paths;
  for (const auto& entry : fs::recursive_directory_iterator(dir)) {
    paths.push_back(entry.path().string());
  }
  return paths;
}

class ImageIngestTest : public ::testing::Test {
 protected:
  void SetUp() override { store_ = GraphStore::Open("sqlite:" + (scratch_ / "index.db").string()); }

  SensorIndex& index() { return store_->sensors(); }
  fs::path root() const { return scratch_ / "root"; }

  StereoImageIngestResult Ingest(
      std::vector<std::pair<std::int64_t, std::int64_t>>* progress = nullptr) {
    return IngestStereoImages(LoadStereoSequence(folder_.dir()), index(), root(), "euroc", "stereo",
                              [&](std::int64_t done, std::int64_t total) {
                                if (progress) progress->emplace_back(done, total);
                              });
  }

  // The ingest fails with `code` naming `mention`, and leaves no trace.
  void ExpectIngestFailsCleanly(ErrorCode code, const std::string& mention) {
    const StereoSequence sequence = LoadStereoSequence(folder_.dir());
    ExpectError(
        code, [&] { IngestStereoImages(sequence, index(), root(), "euroc", "stereo"); }, mention);
    EXPECT_EQ(Contents(root()), std::vector<std::string>{});
    EXPECT_EQ(index().CountData(), 0);
    EXPECT_TRUE(index().ListFiles().empty());
  }

  ScratchDir scratch_{"fleetmap-image-ingest"};
  SyntheticEuroc folder_{scratch_ / "seq", kIngestPairs};
  std::unique_ptr<GraphStore> store_;
};

TEST_F(ImageIngestTest, WritesOneRecordPerPairAndIndexesIt) {
  std::vector<std::pair<std::int64_t, std::int64_t>> progress;
  const StereoImageIngestResult r = Ingest(&progress);

  const fs::path relative = RecordFilePath("euroc", "stereo", folder_.stamps().front());
  EXPECT_EQ(relative, fs::path("euroc/stereo/2014-06-25/euroc-stereo-20140625-165433.rec"));
  EXPECT_EQ(r.record_file, fs::absolute(root() / relative).lexically_normal());
  EXPECT_EQ(r.pairs, kIngestPairs);
  EXPECT_EQ(r.bytes, fs::file_size(r.record_file));
  EXPECT_EQ(r.index.records, kIngestPairs);
  EXPECT_EQ(r.index.inserted, kIngestPairs);
  EXPECT_TRUE(r.index.problems.empty());
  ASSERT_FALSE(progress.empty());
  EXPECT_EQ(progress.back(),
            std::make_pair(std::int64_t{kIngestPairs}, std::int64_t{kIngestPairs}));
  for (std::size_t i = 1; i < progress.size(); ++i) {
    EXPECT_GT(progress[i].first, progress[i - 1].first);
  }

  // The log reads back: one checking StereoImagePair per pair, the PNGs byte for byte.
  RecordReader reader(r.record_file);
  std::vector<Record> records;
  while (std::optional<Record> record = reader.Next()) records.push_back(std::move(*record));
  EXPECT_TRUE(reader.problems().empty());
  ASSERT_EQ(records.size(), static_cast<std::size_t>(kIngestPairs));
  for (int i = 0; i < kIngestPairs; ++i) {
    SCOPED_TRACE("pair " + std::to_string(i));
    EXPECT_EQ(records[i].header.type, "fleetmap.v1.StereoImagePair");
    EXPECT_EQ(records[i].header.stamp_ns, folder_.stamps()[i]);
    v1::StereoImagePair pair;
    ASSERT_TRUE(pair.ParseFromString(records[i].payload));
    EXPECT_EQ(pair.stamp_ns(), folder_.stamps()[i]);
    EXPECT_EQ(pair.left_camera(), "stereo/cam0");
    EXPECT_EQ(pair.right_camera(), "stereo/cam1");
    EXPECT_EQ(pair.encoding(), "png");
    EXPECT_EQ(pair.width_px(), static_cast<std::uint32_t>(kEurocWidthPx));
    EXPECT_EQ(pair.height_px(), static_cast<std::uint32_t>(kEurocHeightPx));
    EXPECT_EQ(pair.left_image(), ReadFileBytes(folder_.Image(0, i)));
    EXPECT_EQ(pair.right_image(), ReadFileBytes(folder_.Image(1, i)));
    const cv::Mat left = DecodeMonoImage(pair.left_image(), "left", kEurocWidthPx, kEurocHeightPx);
    const cv::Mat source = testing::ReadImageFile(folder_.Image(0, i), ImagePixels::kAsStored);
    EXPECT_EQ(cv::norm(left, source, cv::NORM_INF), 0.0);
  }

  // Indexed: one datum per pair, found by time, pointing at its record.
  const std::optional<Platform> platform = index().FindPlatform("euroc");
  const std::optional<Sensor> sensor = index().FindSensor("stereo");
  ASSERT_TRUE(platform && sensor);
  EXPECT_EQ(sensor->type, "fleetmap.v1.StereoImagePair");
  const std::vector<Datum> data = index().DataOfFile(relative.generic_string());
  ASSERT_EQ(data.size(), static_cast<std::size_t>(kIngestPairs));
  for (int i = 0; i < kIngestPairs; ++i) {
    EXPECT_EQ(data[i].stamp_ns, folder_.stamps()[i]);
    EXPECT_EQ(data[i].offset, records[i].location.offset);
    EXPECT_EQ(data[i].length, records[i].location.length);
  }
  const std::optional<Datum> near =
      index().Nearest(platform->id, sensor->id, folder_.stamps()[2] + 20 * kMs);
  ASSERT_TRUE(near);
  EXPECT_EQ(near->stamp_ns, folder_.stamps()[2]);
  EXPECT_EQ(reader.ReadAt(index().GetDatum(near->id).offset).header.stamp_ns, folder_.stamps()[2]);
  EXPECT_EQ(index().Nearest(platform->id, sensor->id, folder_.stamps()[4] + 30 * kMs)->stamp_ns,
            folder_.stamps()[4]);

  // The calibrations beside the log, and no temporary file left.
  EXPECT_EQ(r.left_calibration, StereoCalibrationPath(r.record_file, 0));
  EXPECT_EQ(r.left_calibration.filename(), "euroc-stereo-20140625-165433.cam0.yaml");
  EXPECT_EQ(ReadFileBytes(r.left_calibration), ReadFileBytes(SyntheticEuroc::Calibration(0)));
  EXPECT_EQ(ReadFileBytes(r.right_calibration), ReadFileBytes(SyntheticEuroc::Calibration(1)));
  EXPECT_EQ(Contents(r.record_file.parent_path()).size(), 3u);
}

TEST_F(ImageIngestTest, IngestingTwiceIsAConflictAndKeepsTheFirstLog) {
  const StereoImageIngestResult first = Ingest();
  const std::string bytes = ReadFileBytes(first.record_file);
  ExpectError(
      ErrorCode::kConflict, [&] { Ingest(); }, first.record_file.string());
  EXPECT_EQ(ReadFileBytes(first.record_file), bytes);
  EXPECT_EQ(index().CountData(), kIngestPairs);
  RecordReader reader(first.record_file);
  int records = 0;
  while (reader.Next()) ++records;
  EXPECT_EQ(records, kIngestPairs);
  EXPECT_TRUE(reader.problems().empty());
  EXPECT_TRUE(fs::exists(first.left_calibration));
  EXPECT_EQ(Contents(first.record_file.parent_path()).size(), 3u);
}

TEST_F(ImageIngestTest, UnreadableImageLeavesNothing) {
  // The last pair's right image: four pairs were already written when it is read.
  testing::WriteFileBytes(folder_.Image(1, kIngestPairs - 1), "garbage, not a PNG");
  ExpectIngestFailsCleanly(ErrorCode::kCorrupt, folder_.Image(1, kIngestPairs - 1).string());
}

TEST_F(ImageIngestTest, WrongSizeImageLeavesNothing) {
  SyntheticEuroc::WriteNoisePng(folder_.Image(0, 2), kEurocWidthPx, kEurocHeightPx / 2, 3);
  ExpectIngestFailsCleanly(ErrorCode::kInvalidArgument, folder_.Image(0, 2).string());
}

TEST_F(ImageIngestTest, NonPngImageLeavesNothing) {
  testing::WriteFileBytes(
      folder_.Image(0, 1),
      testing::EncodeJpegForTest(cv::Mat(kEurocHeightPx, kEurocWidthPx, CV_8UC1, cv::Scalar(7))));
  ExpectIngestFailsCleanly(ErrorCode::kInvalidArgument, "is not a PNG");
}

TEST_F(ImageIngestTest, ImageRemovedAfterLoadingLeavesNothing) {
  const StereoSequence sequence = LoadStereoSequence(folder_.dir());
  fs::remove(folder_.Image(0, 3));
  ExpectError(
      ErrorCode::kNotFound,
      [&] { IngestStereoImages(sequence, index(), root(), "euroc", "stereo"); },
      folder_.Image(0, 3).string());
  EXPECT_EQ(Contents(root()), std::vector<std::string>{});
  EXPECT_EQ(index().CountData(), 0);
}

TEST_F(ImageIngestTest, ExistingRootKeepsItsOtherFiles) {
  fs::create_directories(root() / "euroc" / "stereo");
  testing::WriteFileBytes(root() / "euroc" / "stereo" / "notes.txt", "mine");
  testing::WriteFileBytes(folder_.Image(0, 0), "garbage");
  const StereoSequence sequence = LoadStereoSequence(folder_.dir());
  ExpectError(ErrorCode::kCorrupt,
              [&] { IngestStereoImages(sequence, index(), root(), "euroc", "stereo"); });
  // Only what the ingest created is gone (the date directory); what was there stays.
  std::vector<std::string> left = Contents(root());
  std::sort(left.begin(), left.end());
  EXPECT_EQ(left, (std::vector<std::string>{(root() / "euroc").string(),
                                            (root() / "euroc" / "stereo").string(),
                                            (root() / "euroc" / "stereo" / "notes.txt").string()}));
}

TEST_F(ImageIngestTest, IndexRefusalRemovesTheWrittenLog) {
  // The sensor is on another platform for good: indexing (after the rename) must refuse, and
  // the log and its calibration copies must go again.
  index().Mount(index().AddSensor("stereo", "fleetmap.v1.StereoImagePair"),
                index().AddPlatform("other-robot"), 0, std::nullopt);
  ExpectError(ErrorCode::kConflict, [&] { Ingest(); });
  EXPECT_EQ(Contents(root()), std::vector<std::string>{});
  EXPECT_EQ(index().CountData(), 0);
}

TEST_F(ImageIngestTest, BadNamesAreRefusedBeforeWriting) {
  const StereoSequence sequence = LoadStereoSequence(folder_.dir());
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { IngestStereoImages(sequence, index(), root(), "a/b", "stereo"); }, "platform");
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { IngestStereoImages(sequence, index(), root(), "euroc", ".."); }, "sensor");
  EXPECT_FALSE(fs::exists(root()));
  EXPECT_EQ(index().CountData(), 0);
}

TEST_F(ImageIngestTest, KittiCalibrationIsWrittenAsEurocYamlThatReadsBack) {
  const SyntheticKitti kitti(scratch_ / "kitti", 3);
  const StereoSequence sequence = LoadStereoSequence(kitti.dir());
  const StereoImageIngestResult r =
      IngestStereoImages(sequence, index(), root(), "kitti", "stereo");
  // No times.txt: the pairs count from 0, 1970-01-01 UTC.
  EXPECT_EQ(r.record_file,
            (fs::absolute(root()) / "kitti/stereo/1970-01-01/kitti-stereo-19700101-000000.rec")
                .lexically_normal());
  EXPECT_EQ(r.pairs, 3);
  EXPECT_EQ(index().CountData(), 3);
  RecordReader reader(r.record_file);
  std::vector<Record> records;
  while (std::optional<Record> record = reader.Next()) records.push_back(std::move(*record));
  ASSERT_EQ(records.size(), 3u);
  v1::StereoImagePair pair;
  ASSERT_TRUE(pair.ParseFromString(records[2].payload));
  EXPECT_EQ(pair.stamp_ns(), 200'000'000);
  EXPECT_EQ(pair.width_px(), static_cast<std::uint32_t>(SyntheticKitti::kWidthPx));
  EXPECT_EQ(pair.right_image(), ReadFileBytes(kitti.Image(1, 2)));

  // The cameras made of calib.txt, as EuRoC sensor.yaml files: a StereoRectifier built from the
  // copies is the one built from the folder.
  const PinholeCamera left = LoadEurocCamera(r.left_calibration);
  const PinholeCamera right = LoadEurocCamera(r.right_calibration);
  for (const auto& [copy, original] :
       {std::pair{&left, &sequence.left}, std::pair{&right, &sequence.right}}) {
    EXPECT_EQ(copy->name, original->name);
    EXPECT_EQ(copy->width_px, original->width_px);
    EXPECT_DOUBLE_EQ(copy->fx, original->fx);
    EXPECT_DOUBLE_EQ(copy->cy, original->cy);
    EXPECT_EQ(copy->distortion, original->distortion);
    EXPECT_TRUE(copy->body_T_sensor.isApprox(original->body_T_sensor, 1e-12));
  }
  EXPECT_NEAR(StereoRectifier(left, right).geometry().baseline_m, SyntheticKitti::kBaselineM,
              1e-12);
}

// ---- The `fleetmap` executable ----

using testing::CliRun;

CliRun RunCli(const ScratchDir& scratch, const std::vector<std::string>& args) {
  return testing::RunFleetmapCli(scratch.path(), args);
}

class ImagesCommandTest : public ::testing::Test {
 protected:
  CliRun Ingest(const fs::path& dir) {
    return RunCli(scratch_, {"images", "ingest", dir.string(), "--root", root().string(), "--store",
                             store_uri()});
  }
  fs::path root() const { return scratch_ / "root"; }
  std::string store_uri() const { return "sqlite:" + (scratch_ / "index.db").string(); }

  ScratchDir scratch_{"fleetmap-images-command"};
  SyntheticEuroc folder_{scratch_ / "seq", kIngestPairs};
};

TEST_F(ImagesCommandTest, IngestPrintsTheSummaryAndPairsAreQueryable) {
  const CliRun run = Ingest(folder_.dir());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const fs::path file =
      (root() / RecordFilePath("euroc", "stereo", folder_.stamps().front())).lexically_normal();
  EXPECT_NE(run.out.find("5 stereo pairs ("), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("MB) ingested into " + file.string()), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("5 new index rows in " + store_uri()), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("euroc-stereo-20140625-165433.cam1.yaml"), std::string::npos);
  EXPECT_NE(run.err.find("images ingest"), std::string::npos) << "no progress: " << run.err;
  EXPECT_TRUE(fs::exists(file));

  const CliRun query =
      RunCli(scratch_, {"query", "nearest", "--platform", "euroc", "--sensor", "stereo", "--at",
                        std::to_string(folder_.stamps()[3] + 1), "--store", store_uri()});
  ASSERT_EQ(query.exit_code, 0) << query.err;
  EXPECT_NE(query.out.find(std::to_string(folder_.stamps()[3])), std::string::npos) << query.out;
  EXPECT_NE(query.out.find("fleetmap.v1.StereoImagePair"), std::string::npos) << query.out;

  const CliRun again = Ingest(folder_.dir());
  EXPECT_EQ(again.exit_code, 1);
  EXPECT_NE(again.err.find("fleetmap: conflict: record file " + file.string()), std::string::npos)
      << again.err;
}

TEST_F(ImagesCommandTest, MismatchedTimestampsExitOneNamingBothCsvFilesAndTheLine) {
  // cam1's second frame 2 ms late (its image renamed to match), so each camera alone is fine.
  const std::string late = std::to_string(folder_.stamps()[1] + 2 * kMs);
  fs::rename(folder_.Image(1, 1), folder_.CameraDir(1) / "data" / (late + ".png"));
  std::vector<std::string> rows;
  for (std::int64_t stamp : folder_.stamps()) {
    const std::string name = std::to_string(stamp);
    rows.push_back(name + "," + name + ".png");
  }
  rows[1] = late + "," + late + ".png";
  folder_.WriteCsv(1, rows);
  const CliRun run = Ingest(folder_.dir());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("fleetmap: invalid-argument: " + folder_.dir().string()),
            std::string::npos)
      << run.err;
  EXPECT_NE(run.err.find("cam0/data.csv line 3: " + std::to_string(folder_.stamps()[1]) +
                         " but cam1/data.csv line 3: " + late),
            std::string::npos)
      << run.err;
  EXPECT_TRUE(run.out.empty()) << run.out;
  EXPECT_FALSE(fs::exists(root()));
  EXPECT_FALSE(fs::exists(scratch_ / "index.db"));  // not even a store was created
}

TEST_F(ImagesCommandTest, UnreadableImageExitsOneAndLeavesNothing) {
  testing::WriteFileBytes(folder_.Image(0, 4), "garbage");
  const CliRun run = Ingest(folder_.dir());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("fleetmap: corrupt: image " + folder_.Image(0, 4).string()),
            std::string::npos)
      << run.err;
  EXPECT_EQ(Contents(root()), std::vector<std::string>{});
  EXPECT_EQ(GraphStore::Open(store_uri())->sensors().CountData(), 0);
}

TEST_F(ImagesCommandTest, MissingFolderExitsOne) {
  const fs::path missing = scratch_ / "no-such-folder";
  const CliRun run = Ingest(missing);
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(
      run.err.find("fleetmap: not-found: stereo sequence " + missing.string() + " does not exist"),
      std::string::npos)
      << run.err;
}

TEST_F(ImagesCommandTest, KittiFolderGoesUnderTheKittiPlatform) {
  const SyntheticKitti kitti(scratch_ / "kitti", 3);
  const CliRun run = Ingest(kitti.dir());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const fs::path file = (root() / RecordFilePath("kitti", "stereo", 0)).lexically_normal();
  EXPECT_NE(run.out.find("3 stereo pairs ("), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("ingested into " + file.string()), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("layout kitti-odometry, platform kitti; data: KITTI"), std::string::npos)
      << run.out;
  EXPECT_TRUE(fs::exists(StereoCalibrationPath(file, 1)));
  // And the EuRoC folder under "euroc", as before (another sensor name: the index mounts a sensor
  // on one platform at a time).
  const CliRun euroc =
      RunCli(scratch_, {"images", "ingest", folder_.dir().string(), "--root", root().string(),
                        "--store", store_uri(), "--sensor", "vi-sensor"});
  ASSERT_EQ(euroc.exit_code, 0) << euroc.err;
  EXPECT_NE(euroc.out.find("layout euroc, platform euroc"), std::string::npos) << euroc.out;
}

TEST_F(ImagesCommandTest, PlatformNamingADatasetPicksItsLayout) {
  // A folder with both kinds of folders: --platform kitti reads the KITTI one.
  const SyntheticKitti kitti(folder_.dir(), 2);
  const CliRun run =
      RunCli(scratch_, {"images", "ingest", folder_.dir().string(), "--root", root().string(),
                        "--store", store_uri(), "--platform", "kitti", "--sensor", "front"});
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("2 stereo pairs ("), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("layout kitti-odometry, platform kitti"), std::string::npos) << run.out;
  // Undetected, the same folder is EuRoC (tried first).
  const CliRun detected = Ingest(folder_.dir());
  ASSERT_EQ(detected.exit_code, 0) << detected.err;
  EXPECT_NE(detected.out.find("5 stereo pairs ("), std::string::npos) << detected.out;

  // --platform kitti on a folder that is only EuRoC: refused, saying what it is.
  const SyntheticEuroc euroc(scratch_ / "only-euroc", 2);
  const CliRun wrong =
      RunCli(scratch_, {"images", "ingest", euroc.dir().string(), "--root", root().string(),
                        "--store", store_uri(), "--platform", "kitti"});
  EXPECT_EQ(wrong.exit_code, 1);
  EXPECT_NE(wrong.err.find("is a euroc folder, but --platform kitti with --layout auto reads only "
                           "kitti layouts; give --layout euroc"),
            std::string::npos)
      << wrong.err;
  // An explicit --layout wins over the folder's look; one that does not fit names what is missing.
  const CliRun forced =
      RunCli(scratch_, {"images", "ingest", euroc.dir().string(), "--root", root().string(),
                        "--store", store_uri(), "--layout", "kitti-raw", "--platform", "car"});
  EXPECT_EQ(forced.exit_code, 1);
  EXPECT_NE(forced.err.find("not-found: left image folder " +
                            (euroc.dir() / "image_00" / "data").string()),
            std::string::npos)
      << forced.err;
  const CliRun unknown = RunCli(scratch_, {"images", "ingest", euroc.dir().string(), "--root",
                                           root().string(), "--layout", "kitti"});
  EXPECT_NE(unknown.exit_code, 0);
  EXPECT_NE(unknown.err.find("--layout"), std::string::npos) << unknown.err;
}

TEST_F(ImagesCommandTest, MalformedKittiCalibrationExitsOneNamingTheLine) {
  const SyntheticKitti kitti(scratch_ / "kitti", 2);
  testing::WriteTextFile(kitti.Calib(), SyntheticKitti::P0() + "\n1 2 3");
  const CliRun run = Ingest(kitti.dir());
  EXPECT_EQ(run.exit_code, 1);
  EXPECT_NE(run.err.find("fleetmap: invalid-argument: " + kitti.Calib().string() +
                         " line 2 (P1): expected 12 numbers, found 3"),
            std::string::npos)
      << run.err;
  EXPECT_FALSE(fs::exists(root()));
}

TEST_F(ImagesCommandTest, HelpAndMissingArguments) {
  const CliRun help = RunCli(scratch_, {"images", "ingest", "--help"});
  EXPECT_EQ(help.exit_code, 0);
  for (const char* text :
       {"--root", "--layout", "--platform", "--sensor", "--store", "cam0/", "data.csv",
        "kitti-odometry", "image_l/", "calib.txt", "kitti-raw", "calib_cam_to_cam.txt"}) {
    EXPECT_NE(help.out.find(text), std::string::npos) << text << " not in:\n" << help.out;
  }
  // `images` alone needs a subcommand; `ingest` needs --root.
  const CliRun bare = RunCli(scratch_, {"images"});
  EXPECT_NE(bare.exit_code, 0);
  EXPECT_NE((bare.out + bare.err).find("subcommand"), std::string::npos) << bare.out << bare.err;
  const CliRun no_root = RunCli(scratch_, {"images", "ingest", folder_.dir().string()});
  EXPECT_NE(no_root.exit_code, 0);
  EXPECT_NE(no_root.err.find("--root"), std::string::npos) << no_root.err;
  EXPECT_FALSE(fs::exists(scratch_ / "fleetmap.db"));
}

}  // namespace
}  // namespace fleetmap
