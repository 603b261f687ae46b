// Reading EuRoC stereo folders (euroc_sequence.h): a synthetic folder with each way it can be
// broken (missing folders and files, malformed csv rows, stamps out of order or different in
// the two cameras, unreadable or wrongly sized images), each refused with the right code and a
// message naming the culprit; and the real V1_01 excerpt from ../shared/data.
#include "fleetmap/stereo/euroc_sequence.h"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "expect_error.h"
#include "image_files.h"
#include "scratch_dir.h"
#include "synthetic_euroc.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::kEurocHeightPx;
using testing::kEurocWidthPx;
using testing::SyntheticEuroc;

constexpr int kPairs = 5;

class EurocSequenceTest : public ::testing::Test {
 protected:
  std::string Stamp(int i) const { return std::to_string(folder_.stamps()[i]); }
  // The csv rows as the folder wrote them, for editing one.
  std::vector<std::string> Rows() const {
    std::vector<std::string> rows;
    for (int i = 0; i < kPairs; ++i) rows.push_back(Stamp(i) + "," + Stamp(i) + ".png");
    return rows;
  }
  void ExpectLoadError(ErrorCode code, const std::vector<std::string>& mentions) {
    for (const std::string& mention : mentions) {
      ExpectError(
          code, [&] { LoadEurocSequence(folder_.dir()); }, mention);
    }
  }

  ScratchDir scratch_{"fleetmap-euroc-sequence"};
  SyntheticEuroc folder_{scratch_ / "seq", kPairs};
};

TEST_F(EurocSequenceTest, LoadsPairsInOrderWithBothCalibrations) {
  const EurocSequence s = LoadEurocSequence(folder_.dir());
  EXPECT_EQ(s.dir, folder_.dir());
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  for (int i = 0; i < kPairs; ++i) {
    EXPECT_EQ(s.pairs[i].stamp_ns, folder_.stamps()[i]);
    EXPECT_EQ(s.pairs[i].left_image, folder_.Image(0, i));
    EXPECT_EQ(s.pairs[i].right_image, folder_.Image(1, i));
  }
  EXPECT_EQ(s.left.width_px, kEurocWidthPx);
  EXPECT_EQ(s.left.height_px, kEurocHeightPx);
  EXPECT_EQ(s.right.width_px, kEurocWidthPx);
  // The two yamls differ (cam1 sits ~11 cm to the side): each camera got its own.
  EXPECT_NE(s.left.body_T_sensor.translation(), s.right.body_T_sensor.translation());
}

TEST_F(EurocSequenceTest, AcceptsCrLfBlankLinesAndSpaces) {
  std::vector<std::string> rows = Rows();
  for (std::string& row : rows) row = " " + row.replace(row.find(','), 1, " , ") + "\r";
  rows.insert(rows.begin() + 2, "");
  for (int camera = 0; camera < 2; ++camera) folder_.WriteCsv(camera, rows);
  const EurocSequence s = LoadEurocSequence(folder_.dir());
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  EXPECT_EQ(s.pairs[4].right_image, folder_.Image(1, 4));
}

TEST_F(EurocSequenceTest, MissingDirectory) {
  const fs::path missing = scratch_ / "no-such-sequence";
  ExpectError(
      ErrorCode::kNotFound, [&] { LoadEurocSequence(missing); }, missing.string());
}

TEST_F(EurocSequenceTest, MissingCameraFolder) {
  fs::remove_all(folder_.CameraDir(1));
  ExpectLoadError(ErrorCode::kNotFound, {folder_.CameraDir(1).string(), "does not exist"});
}

TEST_F(EurocSequenceTest, MissingCsv) {
  fs::remove(folder_.Csv(0));
  ExpectLoadError(ErrorCode::kNotFound, {folder_.Csv(0).string()});
}

TEST_F(EurocSequenceTest, MissingSensorYaml) {
  const fs::path yaml = folder_.CameraDir(1) / "sensor.yaml";
  fs::remove(yaml);
  ExpectLoadError(ErrorCode::kNotFound, {yaml.string()});
}

TEST_F(EurocSequenceTest, ListedImageAbsent) {
  fs::remove(folder_.Image(1, 3));
  // Row 3 is line 5 (after the header and rows 0-2).
  ExpectLoadError(ErrorCode::kNotFound, {folder_.Image(1, 3).string(), "cam1/data.csv line 5"});
}

TEST_F(EurocSequenceTest, NonNumericStamp) {
  std::vector<std::string> rows = Rows();
  rows[1] = "14037152733x2143104," + Stamp(1) + ".png";
  folder_.WriteCsv(0, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {"cam0/data.csv line 3", "'14037152733x2143104'", folder_.dir().string()});
}

TEST_F(EurocSequenceTest, MissingFileName) {
  std::vector<std::string> rows = Rows();
  rows[2] = Stamp(2) + ",";
  folder_.WriteCsv(1, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam1/data.csv line 4", "no image file name"});
}

TEST_F(EurocSequenceTest, RowWithoutComma) {
  std::vector<std::string> rows = Rows();
  rows[0] = Stamp(0);
  folder_.WriteCsv(0, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam0/data.csv line 2", "no comma"});
}

TEST_F(EurocSequenceTest, FileNameOutsideDataFolder) {
  std::vector<std::string> rows = Rows();
  rows[0] = Stamp(0) + ",../sensor.yaml";
  folder_.WriteCsv(0, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam0/data.csv line 2", "../sensor.yaml"});
}

TEST_F(EurocSequenceTest, StampsNotIncreasing) {
  std::vector<std::string> rows = Rows();
  std::swap(rows[2], rows[3]);
  for (int camera = 0; camera < 2; ++camera) folder_.WriteCsv(camera, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {"cam0/data.csv line 5", "does not come after line 4", Stamp(2)});
  // A repeated stamp is not an increase either.
  rows = Rows();
  rows[3] = Stamp(2) + "," + Stamp(3) + ".png";
  folder_.WriteCsv(0, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam0/data.csv line 5"});
}

TEST_F(EurocSequenceTest, RowWhoseStampsDiffer) {
  // cam1's fourth frame 1 ms late, its image renamed to match: each camera alone is fine.
  const std::string late = std::to_string(folder_.stamps()[3] + 1'000'000);
  fs::rename(folder_.Image(1, 3), folder_.CameraDir(1) / "data" / (late + ".png"));
  std::vector<std::string> rows = Rows();
  rows[3] = late + "," + late + ".png";
  folder_.WriteCsv(1, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {"cam0/data.csv line 5: " + Stamp(3) + " but cam1/data.csv line 5: " + late,
                   folder_.dir().string()});
}

TEST_F(EurocSequenceTest, DifferentRowCounts) {
  // cam0 has a sixth frame (its image present) that cam1 does not list.
  const std::int64_t extra = folder_.stamps().back() + SyntheticEuroc::kStepNs;
  SyntheticEuroc::WriteNoisePng(folder_.CameraDir(0) / "data" / (std::to_string(extra) + ".png"),
                                kEurocWidthPx, kEurocHeightPx, 99);
  folder_.AppendCsvLine(0, std::to_string(extra) + "," + std::to_string(extra) + ".png");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {"cam0/data.csv has 6 rows, cam1/data.csv 5", "cam0/data.csv line 7",
                   "no partner in cam1/data.csv"});
  // And the other way round, the missing row in the middle: the stamps part at that row.
  folder_.WriteCsv(0, Rows());
  std::vector<std::string> rows = Rows();
  rows.erase(rows.begin() + 1);
  folder_.WriteCsv(1, rows);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam0/data.csv line 3", "cam1/data.csv line 3"});
}

TEST_F(EurocSequenceTest, TrailingRowsWithoutImagesAreDropped) {
  // As in the micro excerpt: cam1/data.csv lists frames past the copied images.
  for (int k = 1; k <= 4; ++k) {
    const std::string stamp = std::to_string(folder_.stamps().back() + k * SyntheticEuroc::kStepNs);
    folder_.AppendCsvLine(1, stamp + "," + stamp + ".png");
  }
  const EurocSequence s = LoadEurocSequence(folder_.dir());
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  EXPECT_EQ(s.pairs.back().stamp_ns, folder_.stamps().back());
}

TEST_F(EurocSequenceTest, NoImagesListed) {
  for (int camera = 0; camera < 2; ++camera) folder_.WriteCsv(camera, {});
  ExpectLoadError(ErrorCode::kInvalidArgument, {"cam0/data.csv lists no images"});
}

TEST_F(EurocSequenceTest, ReadMonoImageDecodesToGrey) {
  const cv::Mat image = ReadMonoImage(folder_.Image(0, 2), kEurocWidthPx, kEurocHeightPx);
  ASSERT_EQ(image.type(), CV_8UC1);
  const cv::Mat written = testing::ReadImageFile(folder_.Image(0, 2), ImagePixels::kAsStored);
  EXPECT_EQ(cv::norm(image, written, cv::NORM_INF), 0.0);
  // The same from bytes in memory.
  const cv::Mat decoded = DecodeMonoImage(testing::ReadFileBytes(folder_.Image(0, 2)), "pair 2",
                                          kEurocWidthPx, kEurocHeightPx);
  EXPECT_EQ(cv::norm(decoded, written, cv::NORM_INF), 0.0);
}

TEST_F(EurocSequenceTest, ColourImagesBecomeGrey) {
  const fs::path file = scratch_ / "colour.png";
  testing::WritePngFile(file,
                        cv::Mat(kEurocHeightPx, kEurocWidthPx, CV_8UC3, cv::Scalar(10, 200, 30)));
  const cv::Mat image = ReadMonoImage(file, kEurocWidthPx, kEurocHeightPx);
  EXPECT_EQ(image.type(), CV_8UC1);
  EXPECT_GT(image.at<unsigned char>(0, 0), 100);  // mostly green: a bright grey
}

TEST_F(EurocSequenceTest, UnreadableImage) {
  testing::WriteFileBytes(folder_.Image(0, 1), "this is not a PNG at all");
  ExpectError(
      ErrorCode::kCorrupt,
      [&] { ReadMonoImage(folder_.Image(0, 1), kEurocWidthPx, kEurocHeightPx); },
      folder_.Image(0, 1).string());
  // A real PNG cut in half.
  const std::string whole = testing::ReadFileBytes(folder_.Image(0, 2));
  testing::WriteFileBytes(folder_.Image(0, 2), whole.substr(0, whole.size() / 2));
  ExpectError(
      ErrorCode::kCorrupt,
      [&] { ReadMonoImage(folder_.Image(0, 2), kEurocWidthPx, kEurocHeightPx); },
      folder_.Image(0, 2).string());
  testing::WriteFileBytes(folder_.Image(0, 3), "");
  ExpectError(
      ErrorCode::kCorrupt,
      [&] { ReadMonoImage(folder_.Image(0, 3), kEurocWidthPx, kEurocHeightPx); }, "empty");
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeMonoImage("\x89PNG junk", "record 7", 752, 480); },
      "record 7");
}

TEST_F(EurocSequenceTest, ImageOfTheWrongSize) {
  SyntheticEuroc::WriteNoisePng(folder_.Image(1, 0), 640, 480, 5);
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { ReadMonoImage(folder_.Image(1, 0), kEurocWidthPx, kEurocHeightPx); },
      folder_.Image(1, 0).string());
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { ReadMonoImage(folder_.Image(1, 0), kEurocWidthPx, kEurocHeightPx); },
      "is 640x480 px, but the camera's calibration says 752x480");
}

TEST_F(EurocSequenceTest, MissingImageFile) {
  ExpectError(
      ErrorCode::kNotFound, [&] { ReadMonoImage(scratch_ / "gone.png", 752, 480); }, "gone.png");
}

// Without the sequence the real-image tests fail, saying where CMake looked and how to point
// at the data; they used to skip, and the suite passed having run none of them.
TEST(EurocRealSequenceTest, AMissingSequenceFailsSayingWhereItLookedAndHowToSetIt) {
  EXPECT_FATAL_FAILURE(testing::RequireEurocSequence("", "/nowhere/a and /nowhere/b"),
                       "CMake looked in /nowhere/a and /nowhere/b");
  EXPECT_FATAL_FAILURE(testing::RequireEurocSequence("", "/nowhere/a"), "-DFLEETMAP_EUROC_DIR=");
  EXPECT_FATAL_FAILURE(testing::RequireEurocSequence("/nowhere/euroc", "/nowhere/euroc"),
                       "the EuRoC sequence /nowhere/euroc (FLEETMAP_EUROC_DIR) has no");
  // Here the data is present (CI has it too); where it is not, this fails as the tests would.
  EXPECT_EQ(testing::EurocSequenceMissing(), std::nullopt) << *testing::EurocSequenceMissing();
}

TEST(EurocRealSequenceTest, LoadsTheV101Excerpt) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence s = LoadEurocSequence(FLEETMAP_EUROC_DIR);
  ASSERT_EQ(s.pairs.size(), 95u);
  for (std::size_t i = 1; i < s.pairs.size(); ++i) {
    EXPECT_GT(s.pairs[i].stamp_ns, s.pairs[i - 1].stamp_ns) << "pair " << i;
    // 20 Hz.
    EXPECT_NEAR(s.pairs[i].stamp_ns - s.pairs[i - 1].stamp_ns, 50'000'000, 1'000'000);
  }
  EXPECT_EQ(s.left.width_px, kEurocWidthPx);
  EXPECT_EQ(s.left.height_px, kEurocHeightPx);
  EXPECT_EQ(s.right.width_px, kEurocWidthPx);
  EXPECT_EQ(s.right.height_px, kEurocHeightPx);
  const cv::Mat left = ReadMonoImage(s.pairs.front().left_image, s.left.width_px, s.left.height_px);
  const cv::Mat right =
      ReadMonoImage(s.pairs.front().right_image, s.right.width_px, s.right.height_px);
  ASSERT_EQ(left.type(), CV_8UC1);
  ASSERT_EQ(right.type(), CV_8UC1);
  // A real view of a room, not a blank frame.
  cv::Scalar mean, stddev;
  cv::meanStdDev(left, mean, stddev);
  EXPECT_GT(stddev[0], 10.0);
}

}  // namespace
}  // namespace fleetmap
