// Stereo sequences of every layout (stereo_sequence.h): layout names and detection; the KITTI
// odometry reader (calib.txt with and without keys, times.txt present or not, poses.txt
// re-based); the KITTI raw reader (rectified and unrectified images, the latter checked through
// StereoRectifier against points projected by hand); EuRoC ground truth interpolated at the
// image stamps; each malformed calib/poses/times/timestamps line named in its error; and the
// shared KITTI and EuRoC excerpts.
#include "fleetmap/stereo/stereo_sequence.h"

#include <gtest/gtest-spi.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <random>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "expect_error.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "image_files.h"
#include "kitti_test_data.h"
#include "scratch_dir.h"
#include "synthetic_euroc.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::KittiNumbers;
using testing::SyntheticEuroc;
using testing::SyntheticKitti;
using testing::WriteNoiseImage;
using testing::WriteTextFile;

constexpr double kPi = 3.14159265358979323846;

Eigen::Isometry3d Pose(double yaw_rad, const Eigen::Vector3d& t, double pitch_rad = 0) {
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = (Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(pitch_rad, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = t;
  return pose;
}

// A pose as one poses.txt line: [R|t] row-major.
std::string PoseLine(const Eigen::Isometry3d& pose) {
  std::vector<double> values;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) values.push_back(pose.matrix()(r, c));
  }
  return KittiNumbers(values);
}

void ExpectNear(const Eigen::Isometry3d& actual, const Eigen::Isometry3d& expected, double tol,
                const std::string& what) {
  EXPECT_LE((actual.matrix() - expected.matrix()).cwiseAbs().maxCoeff(), tol)
      << what << ":\n"
      << actual.matrix() << "\nexpected\n"
      << expected.matrix();
}

// ---- Layout names and detection ----

TEST(StereoLayoutTest, NamesRoundTripAndUnknownNamesListTheKnownOnes) {
  for (const StereoLayout layout :
       {StereoLayout::kEuroc, StereoLayout::kKittiOdometry, StereoLayout::kKittiRaw}) {
    EXPECT_EQ(ParseStereoLayout(LayoutName(layout)), layout);
  }
  EXPECT_EQ(LayoutName(StereoLayout::kKittiOdometry), "kitti-odometry");
  EXPECT_EQ(LayoutFamily(StereoLayout::kKittiRaw), "kitti");
  EXPECT_EQ(LayoutFamily(StereoLayout::kEuroc), "euroc");
  ExpectError(
      ErrorCode::kInvalidArgument, [] { ParseStereoLayout("kitti"); },
      "'kitti' (known: euroc, kitti-odometry, kitti-raw)");
}

class DetectStereoLayoutTest : public ::testing::Test {
 protected:
  ScratchDir scratch_{"fleetmap-detect-layout"};
};

TEST_F(DetectStereoLayoutTest, EachLayoutByItsFolders) {
  const SyntheticEuroc euroc(scratch_ / "euroc", 1);
  EXPECT_EQ(DetectStereoLayout(euroc.dir()), StereoLayout::kEuroc);

  const SyntheticKitti odometry(scratch_ / "odometry", 1);
  EXPECT_EQ(DetectStereoLayout(odometry.dir()), StereoLayout::kKittiOdometry);
  const SyntheticKitti numbered(scratch_ / "numbered", 1, /*numbered_folders=*/true);
  EXPECT_EQ(DetectStereoLayout(numbered.dir()), StereoLayout::kKittiOdometry);
  fs::remove(numbered.Calib());  // image folders alone are not enough
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DetectStereoLayout(numbered.dir()); }, "calib.txt");

  // KITTI raw: the calibration beside the images, or one level up as the download has it.
  const fs::path date = scratch_ / "2011_09_26";
  const fs::path drive = date / "2011_09_26_drive_0001_sync";
  fs::create_directories(drive / "image_00" / "data");
  fs::create_directories(drive / "image_01" / "data");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { DetectStereoLayout(drive); }, "calib_cam_to_cam.txt");
  WriteTextFile(date / "calib_cam_to_cam.txt", "");
  EXPECT_EQ(DetectStereoLayout(drive), StereoLayout::kKittiRaw);
  EXPECT_EQ(DetectStereoLayout(drive.string() + "/"), StereoLayout::kKittiRaw);
  fs::rename(date / "calib_cam_to_cam.txt", drive / "calib_cam_to_cam.txt");
  EXPECT_EQ(DetectStereoLayout(drive), StereoLayout::kKittiRaw);
  EXPECT_TRUE(HasStereoLayout(drive, StereoLayout::kKittiRaw));
  EXPECT_FALSE(HasStereoLayout(drive, StereoLayout::kEuroc));
}

TEST_F(DetectStereoLayoutTest, MissingAndUnknownFolders) {
  const fs::path missing = scratch_ / "nothing-here";
  ExpectError(
      ErrorCode::kNotFound, [&] { DetectStereoLayout(missing); },
      "stereo sequence " + missing.string() + " does not exist");
  ExpectError(
      ErrorCode::kNotFound, [&] { LoadStereoSequence(missing); }, missing.string());
  fs::create_directories(scratch_ / "empty");
  for (const char* looked_for :
       {"cam0/ and cam1/", "image_l/ or image_0/", "image_00/data/", "calib_cam_to_cam.txt"}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { DetectStereoLayout(scratch_ / "empty"); }, looked_for);
  }
}

// ---- KITTI odometry ----

class KittiOdometryTest : public ::testing::Test {
 protected:
  static constexpr int kPairs = 5;

  StereoSequence Load() { return LoadStereoSequence(folder_.dir()); }
  void ExpectLoadError(ErrorCode code, const std::vector<std::string>& mentions) {
    for (const std::string& mention : mentions) {
      ExpectError(
          code, [&] { Load(); }, mention);
    }
  }
  std::string File(const fs::path& file) const { return file.string(); }

  ScratchDir scratch_{"fleetmap-kitti-odometry"};
  SyntheticKitti folder_{scratch_ / "seq", kPairs};
};

TEST_F(KittiOdometryTest, BareCalibrationWithoutTimesOrPoses) {
  const StereoSequence s = Load();
  EXPECT_EQ(s.layout, StereoLayout::kKittiOdometry);
  EXPECT_EQ(s.dir, folder_.dir());
  EXPECT_NE(s.credit.find("KITTI"), std::string::npos);
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  for (int i = 0; i < kPairs; ++i) {
    // KITTI's 10 Hz from 0 without times.txt.
    EXPECT_EQ(s.pairs[i].stamp_ns, i * 100'000'000LL);
    EXPECT_EQ(s.pairs[i].left_image, folder_.Image(0, i));
    EXPECT_EQ(s.pairs[i].right_image, folder_.Image(1, i));
  }
  for (const PinholeCamera* camera : {&s.left, &s.right}) {
    EXPECT_EQ(camera->width_px, SyntheticKitti::kWidthPx);
    EXPECT_EQ(camera->height_px, SyntheticKitti::kHeightPx);
    EXPECT_DOUBLE_EQ(camera->fx, SyntheticKitti::kFocalPx);
    EXPECT_DOUBLE_EQ(camera->fy, SyntheticKitti::kFocalPx);
    EXPECT_DOUBLE_EQ(camera->cx, SyntheticKitti::kCxPx);
    EXPECT_DOUBLE_EQ(camera->cy, SyntheticKitti::kCyPx);
    EXPECT_EQ(camera->distortion, (std::array<double, 5>{}));
  }
  EXPECT_TRUE(s.left.body_T_sensor.isApprox(Eigen::Isometry3d::Identity()));
  EXPECT_TRUE(s.right.body_T_sensor.linear().isIdentity());
  EXPECT_NEAR(
      (s.right.body_T_sensor.translation() - Eigen::Vector3d(SyntheticKitti::kBaselineM, 0, 0))
          .norm(),
      0, 1e-12);
  EXPECT_FALSE(s.has_ground_truth());
  EXPECT_TRUE(s.first_T_left.empty());

  // Already rectified: rectifying again keeps focal length, principal point and baseline.
  const StereoRectifier rectifier(s.left, s.right);
  const RectifiedStereoGeometry& g = rectifier.geometry();
  EXPECT_NEAR(g.baseline_m, SyntheticKitti::kBaselineM, 1e-9);
  EXPECT_NEAR(g.focal_px, SyntheticKitti::kFocalPx, 1e-6 * SyntheticKitti::kFocalPx);
  EXPECT_TRUE(g.rect_R_left.isIdentity(1e-12));
  const Eigen::Vector2d px(20.25, 11.5);
  EXPECT_NEAR((rectifier.RectifyLeftPixel(px) - px).norm(), 0, 1e-6);
  EXPECT_NEAR((rectifier.RectifyRightPixel(px) - px).norm(), 0, 1e-6);
}

TEST_F(KittiOdometryTest, KeyedCalibrationWithTimesAndNumberedFolders) {
  const SyntheticKitti numbered(scratch_ / "numbered", 3, /*numbered_folders=*/true);
  // The benchmark's calib.txt: all four cameras and the velodyne transform, keyed, CRLF.
  const std::string p2 =
      KittiNumbers({9, 0, 8, 46.9, 0, 9, 7, 0.06, 0, 0, 1, 0.0027});  // not read: P2 is ignored
  WriteTextFile(numbered.Calib(), "P0: " + SyntheticKitti::P0() +
                                      "\r\nP1: " + SyntheticKitti::P1(0.25) + "\r\nP2: " + p2 +
                                      "\r\nP3: " + p2 + "\r\nTr: 1 2 3\r\n");
  WriteTextFile(numbered.Times(), "0.000000e+00\n1.036700e-01\n2.073410e-01\n");
  const StereoSequence s = LoadStereoSequence(numbered.dir());
  ASSERT_EQ(s.pairs.size(), 3u);
  EXPECT_EQ(s.pairs[0].stamp_ns, 0);
  EXPECT_EQ(s.pairs[1].stamp_ns, 103'670'000);
  EXPECT_EQ(s.pairs[2].stamp_ns, 207'341'000);
  EXPECT_EQ(s.pairs[2].left_image, numbered.dir() / "image_0" / "000002.png");
  EXPECT_EQ(s.pairs[2].right_image, numbered.dir() / "image_1" / "000002.png");
  EXPECT_NEAR(s.right.body_T_sensor.translation().x(), 0.25, 1e-12);
  // Keys in another order.
  WriteTextFile(numbered.Calib(),
                "P1: " + SyntheticKitti::P1(0.3) + "\nP0: " + SyntheticKitti::P0() + "\n");
  EXPECT_NEAR(LoadStereoSequence(numbered.dir()).right.body_T_sensor.translation().x(), 0.3, 1e-12);
}

// KITTI's colour cameras sit a few millimetres forward of camera 0: P = K [I | t] with t_z != 0
// puts cx t_z into P[0][3]. The baseline is t_x alone (camera 3 of sequences 04-12 as P1:
// 0.4733 m, where -P1[0][3] / P1[0][0] would say 0.4692 m), and a left camera that is itself
// offset (camera 2 as P0) counts from its own centre.
TEST_F(KittiOdometryTest, BaselineLeavesOutTheCamerasForwardOffset) {
  const double f = SyntheticKitti::kFocalPx, cx = SyntheticKitti::kCxPx;
  const double cy = SyntheticKitti::kCyPx;
  const auto projection = [&](double tx, double ty, double tz) {
    return KittiNumbers({f, 0, cx, f * tx + cx * tz, 0, f, cy, f * ty + cy * tz, 0, 0, 1, tz});
  };
  WriteTextFile(folder_.Calib(), SyntheticKitti::P0() + "\n" + projection(-0.4733, 0.002, 0.0049));
  EXPECT_NEAR(LoadStereoSequence(folder_.dir()).right.body_T_sensor.translation().x(), 0.4733,
              1e-9);
  WriteTextFile(folder_.Calib(),
                projection(0.06, 0.0002, 0.0027) + "\n" + projection(-0.4733, 0.002, 0.0049));
  EXPECT_NEAR(LoadStereoSequence(folder_.dir()).right.body_T_sensor.translation().x(), 0.5333,
              1e-9);
}

TEST_F(KittiOdometryTest, PosesAreRebasedOnTheFirstLine) {
  // The excerpt was cut out of a longer drive: line 1 is not the identity.
  const Eigen::Isometry3d world_T_first = Pose(0.7, {12.0, -0.4, 80.0});
  std::vector<Eigen::Isometry3d> first_T_left;
  std::string text;
  for (int i = 0; i < kPairs; ++i) {
    first_T_left.push_back(Pose(0.05 * i, {0.1 * i, -0.01 * i, 1.1 * i}, 0.01 * i));
    text += PoseLine(world_T_first * first_T_left.back()) + "\n";
  }
  WriteTextFile(folder_.Poses(), text);
  const StereoSequence s = Load();
  ASSERT_TRUE(s.has_ground_truth());
  ASSERT_EQ(s.first_T_left.size(), static_cast<std::size_t>(kPairs));
  for (int i = 0; i < kPairs; ++i) {
    ASSERT_TRUE(s.first_T_left[i].has_value()) << i;
    // %.12e keeps 13 digits; products with t around 80 m lose a few.
    ExpectNear(*s.first_T_left[i], first_T_left[i], 1e-9, "pose " + std::to_string(i));
  }
}

TEST_F(KittiOdometryTest, CalibLineWithTheWrongCount) {
  WriteTextFile(folder_.Calib(), SyntheticKitti::P0() + "\n" + SyntheticKitti::P1() + " 1");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Calib()) + " line 2 (P1): expected 12 numbers, found 13"});
  WriteTextFile(folder_.Calib(), "P0: 1 2 3 4 5 6 7 8 9 10 11\nP1: " + SyntheticKitti::P1());
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Calib()) + " line 1 (P0): expected 12 numbers, found 11"});
}

TEST_F(KittiOdometryTest, CalibValueNotANumber) {
  std::string p1 = SyntheticKitti::P1();
  p1.replace(p1.find(' '), 1, " 7,0 ");  // a decimal comma, and one number too many
  WriteTextFile(folder_.Calib(), "\n" + SyntheticKitti::P0() + "\n" + p1 + "\n");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Calib()) + " line 3 (P1): '7,0' (value 2) is not a number"});
}

TEST_F(KittiOdometryTest, CalibWithoutP1) {
  WriteTextFile(folder_.Calib(), SyntheticKitti::P0() + "\n");
  ExpectLoadError(ErrorCode::kInvalidArgument, {File(folder_.Calib()) + ": no P1 line"});
  WriteTextFile(folder_.Calib(), "P0: " + SyntheticKitti::P0() + "\nP2: " + SyntheticKitti::P1());
  ExpectLoadError(ErrorCode::kInvalidArgument, {File(folder_.Calib()) + ": no P1 line"});
  WriteTextFile(folder_.Calib(), "P0: " + SyntheticKitti::P0() + "\nP0: " + SyntheticKitti::P0());
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Calib()) + " line 2 (P0): a second P0 (the first is on line 1)"});
  // Without calib.txt the folder is not detected as KITTI odometry; named, it is a missing file.
  fs::remove(folder_.Calib());
  ExpectError(
      ErrorCode::kNotFound,
      [&] { LoadStereoSequence(folder_.dir(), StereoLayout::kKittiOdometry); },
      "camera calibration " + File(folder_.Calib()) + " does not exist");
}

TEST_F(KittiOdometryTest, NonPositiveBaseline) {
  // The right camera's P with the sign of its translation flipped: it would sit on the left.
  WriteTextFile(folder_.Calib(), SyntheticKitti::P0() + "\n" + SyntheticKitti::P1(-0.54));
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Calib()) + " line 2 (P1): baseline (P1's centre x less P0's",
                   "= -0.54 m", "not positive"});
  WriteTextFile(folder_.Calib(), SyntheticKitti::P0() + "\n" + SyntheticKitti::P0());
  ExpectLoadError(ErrorCode::kInvalidArgument, {"line 2 (P1): baseline", "= 0 m"});
}

TEST_F(KittiOdometryTest, PosesNotANumberOrWrongCount) {
  std::string text;
  for (int i = 0; i < kPairs; ++i) text += PoseLine(Pose(0, {0, 0, 1.0 * i})) + "\n";
  std::string bad = text;
  const std::size_t line3 = [&] {
    std::size_t at = 0;
    for (int k = 0; k < 2; ++k) at = bad.find('\n', at) + 1;
    return at;
  }();
  bad.replace(line3, 1, "x");  // "x.000000000000e+00"
  WriteTextFile(folder_.Poses(), bad);
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Poses()) + " line 3: 'x.000000000000e+00'", "is not a number"});
  // The last line one number short.
  text.erase(text.rfind(' ', text.size() - 1));
  WriteTextFile(folder_.Poses(), text + "\n");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Poses()) + " line 5: expected 12 numbers, found 11"});
}

TEST_F(KittiOdometryTest, PoseWhoseRotationIsNotOrthonormal) {
  std::string text = PoseLine(Eigen::Isometry3d::Identity()) + "\n";
  text += KittiNumbers({1.01, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1}) + "\n";  // scaled by 1 %
  for (int i = 2; i < kPairs; ++i) text += PoseLine(Pose(0, {0, 0, 1.0 * i})) + "\n";
  WriteTextFile(folder_.Poses(), text);
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Poses()) + " line 2: the rotation is not orthonormal"});
  // A reflection is orthogonal but not a rotation.
  text = PoseLine(Eigen::Isometry3d::Identity()) + "\n" +
         KittiNumbers({-1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 1}) + "\n";
  for (int i = 2; i < kPairs; ++i) text += PoseLine(Pose(0, {0, 0, 1.0 * i})) + "\n";
  WriteTextFile(folder_.Poses(), text);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"line 2: the rotation is not orthonormal"});
}

TEST_F(KittiOdometryTest, CountMismatches) {
  std::string text;
  for (int i = 0; i < kPairs - 1; ++i) text += PoseLine(Pose(0, {0, 0, 1.0 * i})) + "\n";
  WriteTextFile(folder_.Poses(), text + "\n\n");  // trailing blank lines are not poses
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Poses()) + " has 4 lines but there are 5 image pairs"});
  fs::remove(folder_.Poses());
  WriteTextFile(folder_.Times(), "0\n0.1\n0.2\n0.3\n0.4\n0.5");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Times()) + " has 6 lines but there are 5 image pairs"});
}

TEST_F(KittiOdometryTest, TimeThatDoesNotIncrease) {
  WriteTextFile(folder_.Times(), "0.0\n0.1\n0.1\n0.3\n0.4\n");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Times()) + " line 3: 0.1 does not come after line 2's 0.1",
                   "times must increase"});
  WriteTextFile(folder_.Times(), "0.0\n0.1\n0.2 0.25\n0.3\n0.4\n");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Times()) + " line 3: expected 1 number, found 2"});
  WriteTextFile(folder_.Times(), "0.0\n0.1\nnan\n0.3\n0.4\n");
  ExpectLoadError(ErrorCode::kInvalidArgument,
                  {File(folder_.Times()) + " line 3: 'nan' (value 1) is not a number"});
}

TEST_F(KittiOdometryTest, ImageMissingOnOneSide) {
  fs::remove(folder_.Image(1, 3));
  ExpectLoadError(ErrorCode::kNotFound, {"image " + File(folder_.Image(1, 3)) + " does not exist",
                                         "its partner " + File(folder_.Image(0, 3))});
  WriteNoiseImage(folder_.Image(1, 3), SyntheticKitti::kWidthPx, SyntheticKitti::kHeightPx, 3);
  WriteNoiseImage(folder_.Image(1, 7), SyntheticKitti::kWidthPx, SyntheticKitti::kHeightPx, 7);
  ExpectLoadError(ErrorCode::kNotFound, {"image " + File(folder_.Image(0, 7)) + " does not exist"});
}

TEST_F(KittiOdometryTest, UnreadableOrMissingImages) {
  WriteTextFile(folder_.Image(0, 0), "not a PNG");
  ExpectLoadError(ErrorCode::kCorrupt, {"image " + File(folder_.Image(0, 0)) + " does not decode"});
  WriteNoiseImage(folder_.Image(0, 0), 32, SyntheticKitti::kHeightPx, 0);
  ExpectLoadError(ErrorCode::kInvalidArgument, {"differ in size", File(folder_.Image(0, 0))});
  for (int i = 0; i < kPairs; ++i) {
    fs::remove(folder_.Image(0, i));
    fs::remove(folder_.Image(1, i));
  }
  ExpectLoadError(ErrorCode::kInvalidArgument, {"no stereo pairs", "hold no .png images"});
  fs::remove_all(folder_.dir() / "image_r");
  ExpectError(
      ErrorCode::kNotFound,
      [&] { LoadStereoSequence(folder_.dir(), StereoLayout::kKittiOdometry); },
      "no right image folder (image_r/ or image_1/)");
}

// ---- KITTI raw ----

// A KITTI raw drive folder: image_00/01 with timestamps, and calib_cam_to_cam.txt one level up.
class KittiRawTest : public ::testing::Test {
 protected:
  // The rectified and unrectified sizes of this synthetic rig (KITTI's are 1242x375 and
  // 1392x512; smaller here to keep the PNGs small).
  static constexpr int kRectWidthPx = 600, kRectHeightPx = 180;
  static constexpr int kRawWidthPx = 640, kRawHeightPx = 200;
  static constexpr int kPairs = 3;

  fs::path Drive() const { return scratch_ / "2011_09_26" / "2011_09_26_drive_0001_sync"; }
  fs::path Calib() const { return scratch_ / "2011_09_26" / "calib_cam_to_cam.txt"; }
  fs::path Timestamps() const { return Drive() / "image_00" / "timestamps.txt"; }
  fs::path Image(int camera, int i) const {
    char name[32];
    std::snprintf(name, sizeof name, "%010d.png", i);
    return Drive() / ("image_0" + std::to_string(camera)) / "data" / name;
  }

  void WriteImages(int width_px, int height_px) {
    for (int camera = 0; camera < 2; ++camera) {
      for (int i = 0; i < kPairs; ++i) {
        // Flat images: this reader only looks at their size.
        testing::WritePngFile(Image(camera, i),
                              cv::Mat(height_px, width_px, CV_8UC1, cv::Scalar(40 * i + camera)));
      }
    }
  }

  // Raw cameras: K, D (five terms), and the extrinsics x_cam = R x_ref + T, the reference
  // being camera 0 (so R_00 = I, T_00 = 0 as in KITTI's files).
  struct RawCamera {
    Eigen::Matrix3d K;
    std::array<double, 5> D;
    Eigen::Matrix3d R;
    Eigen::Vector3d T;
  };
  static RawCamera Camera0() {
    RawCamera c;
    c.K << 480.5, 0, 318.2, 0, 481.7, 101.3, 0, 0, 1;
    c.D = {-0.37, 0.21, 0.0011, -0.0009, -0.07};
    c.R.setIdentity();
    c.T.setZero();
    return c;
  }
  static RawCamera Camera1() {
    RawCamera c;
    c.K << 478.9, 0, 322.8, 0, 479.6, 98.7, 0, 0, 1;
    c.D = {-0.36, 0.19, -0.0008, 0.0012, -0.06};
    // Slightly rotated and to the right: points move left in this camera, x_cam1 = x - 0.537.
    c.R = (Eigen::AngleAxisd(0.004, Eigen::Vector3d::UnitY()) *
           Eigen::AngleAxisd(-0.003, Eigen::Vector3d::UnitX()) *
           Eigen::AngleAxisd(0.002, Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
    c.T = Eigen::Vector3d(-0.537, 0.0048, -0.0112);
    return c;
  }

  static std::vector<double> RowMajor(const Eigen::MatrixXd& m) {
    std::vector<double> values;
    for (int r = 0; r < m.rows(); ++r) {
      for (int c = 0; c < m.cols(); ++c) values.push_back(m(r, c));
    }
    return values;
  }

  // The file as the raw download has it, for this synthetic rig.
  std::vector<std::string> CalibLines() const {
    std::vector<std::string> lines = {"calib_time: 09-Jan-2012 13:57:47",
                                      "corner_dist: 9.950000e-02"};
    const Eigen::Matrix3d rect_K =
        (Eigen::Matrix3d() << 450.0, 0, 300.5, 0, 450.0, 90.25, 0, 0, 1).finished();
    for (int camera = 0; camera < 2; ++camera) {
      const RawCamera c = camera == 0 ? Camera0() : Camera1();
      const std::string n = "0" + std::to_string(camera);
      Eigen::Matrix<double, 3, 4> P_rect;
      P_rect << rect_K, Eigen::Vector3d(camera == 0 ? 0.0 : -450.0 * 0.537, 0, 0);
      lines.push_back("S_" + n + ": " + KittiNumbers({kRawWidthPx, kRawHeightPx}));
      lines.push_back("K_" + n + ": " + KittiNumbers(RowMajor(c.K)));
      lines.push_back("D_" + n + ": " + KittiNumbers({c.D.begin(), c.D.end()}));
      lines.push_back("R_" + n + ": " + KittiNumbers(RowMajor(c.R)));
      lines.push_back("T_" + n + ": " + KittiNumbers(RowMajor(c.T)));
      lines.push_back("S_rect_" + n + ": " + KittiNumbers({kRectWidthPx, kRectHeightPx}));
      lines.push_back("R_rect_" + n + ": " + KittiNumbers(RowMajor(Eigen::Matrix3d::Identity())));
      lines.push_back("P_rect_" + n + ": " + KittiNumbers(RowMajor(P_rect)));
    }
    return lines;
  }
  void WriteCalib(const std::vector<std::string>& lines) const {
    std::string text;
    for (const std::string& line : lines) text += line + "\n";
    WriteTextFile(Calib(), text);
  }
  // CalibLines() with the line starting with `key` replaced by `line` (removed when empty).
  void WriteCalibWith(const std::string& key, const std::string& line) const {
    std::vector<std::string> lines = CalibLines();
    for (auto it = lines.begin(); it != lines.end(); ++it) {
      if (it->starts_with(key + ":")) {
        if (line.empty()) {
          lines.erase(it);
        } else {
          *it = line;
        }
        break;
      }
    }
    WriteCalib(lines);
  }
  // The line number (from 1) of `key` in CalibLines().
  int CalibLine(const std::string& key) const {
    const std::vector<std::string> lines = CalibLines();
    for (std::size_t i = 0; i < lines.size(); ++i) {
      if (lines[i].starts_with(key + ":")) return static_cast<int>(i) + 1;
    }
    return 0;
  }

  void SetUp() override {
    for (int camera = 0; camera < 2; ++camera) {
      fs::create_directories(Image(camera, 0).parent_path());
    }
    WriteCalib(CalibLines());
    WriteTextFile(Timestamps(), std::string("2011-09-26 13:02:25.964389445\n") +
                                    "2011-09-26 13:02:26.068279825\n" +
                                    "2011-09-26 13:02:26.172157\n");
  }

  ScratchDir scratch_{"fleetmap-kitti-raw"};
};

TEST_F(KittiRawTest, RectifiedImagesUseTheRectifiedProjections) {
  WriteImages(kRectWidthPx, kRectHeightPx);
  const StereoSequence s = LoadStereoSequence(Drive());
  EXPECT_EQ(s.layout, StereoLayout::kKittiRaw);
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  // 2011-09-26 13:02:25 UTC is 1317042145 s after 1970-01-01 00:00:00 UTC.
  EXPECT_EQ(s.pairs[0].stamp_ns, 1'317'042'145'964'389'445LL);
  EXPECT_EQ(s.pairs[1].stamp_ns, 1'317'042'146'068'279'825LL);
  EXPECT_EQ(s.pairs[2].stamp_ns, 1'317'042'146'172'157'000LL);  // 6 fraction digits
  EXPECT_EQ(s.pairs[2].right_image, Image(1, 2));
  EXPECT_EQ(s.left.width_px, kRectWidthPx);
  EXPECT_DOUBLE_EQ(s.left.fx, 450.0);
  EXPECT_DOUBLE_EQ(s.right.cx, 300.5);
  EXPECT_DOUBLE_EQ(s.right.cy, 90.25);
  EXPECT_EQ(s.left.distortion, (std::array<double, 5>{}));
  EXPECT_NEAR(s.right.body_T_sensor.translation().x(), 0.537, 1e-12);
  EXPECT_FALSE(s.has_ground_truth());  // oxts is not read
  EXPECT_NEAR(StereoRectifier(s.left, s.right).geometry().baseline_m, 0.537, 1e-9);
}

// The raw cameras' extrinsics (x_cam = R x_ref + T) must reach StereoRectifier the right way
// round: a scene point projected by hand through each raw camera's K, D, R, T lands on one
// rectified row in both images, and its disparity gives back its depth.
TEST_F(KittiRawTest, UnrectifiedImagesRectifyOntoOneRow) {
  WriteImages(kRawWidthPx, kRawHeightPx);
  const StereoSequence s = LoadStereoSequence(Drive());
  ASSERT_EQ(s.left.width_px, kRawWidthPx);
  EXPECT_DOUBLE_EQ(s.left.fx, 480.5);
  EXPECT_DOUBLE_EQ(s.right.cy, 98.7);
  EXPECT_DOUBLE_EQ(s.right.distortion[4], -0.06);  // k3 kept
  const StereoRectifier rectifier(s.left, s.right);
  const RectifiedStereoGeometry& g = rectifier.geometry();
  EXPECT_NEAR(g.baseline_m, Camera1().T.norm(), 1e-9);

  const auto project = [](const RawCamera& c, const Eigen::Vector3d& p_ref) {
    const Eigen::Vector3d p = c.R * p_ref + c.T;
    cv::Mat K(3, 3, CV_64F), D(1, 5, CV_64F);
    for (int r = 0; r < 3; ++r) {
      for (int k = 0; k < 3; ++k) K.at<double>(r, k) = c.K(r, k);
    }
    for (int i = 0; i < 5; ++i) D.at<double>(0, i) = c.D[static_cast<std::size_t>(i)];
    std::vector<cv::Point2d> out;
    cv::projectPoints(std::vector<cv::Point3d>{{p.x(), p.y(), p.z()}}, cv::Vec3d(0, 0, 0),
                      cv::Vec3d(0, 0, 0), K, D, out);
    return Eigen::Vector2d(out[0].x, out[0].y);
  };
  std::mt19937 rng(18);
  std::uniform_real_distribution<double> lateral(-0.5, 0.5), depth(3.0, 40.0);
  int checked = 0;
  for (int i = 0; i < 300; ++i) {
    const double z = depth(rng);
    const Eigen::Vector3d p_ref(lateral(rng) * z, lateral(rng) * 0.25 * z, z);
    const Eigen::Vector2d raw_left = project(Camera0(), p_ref);
    const Eigen::Vector2d raw_right = project(Camera1(), p_ref);
    const auto inside = [](const Eigen::Vector2d& px) {
      return px.x() > 10 && px.x() < kRawWidthPx - 10 && px.y() > 10 && px.y() < kRawHeightPx - 10;
    };
    if (!inside(raw_left) || !inside(raw_right)) continue;
    const Eigen::Vector2d l = rectifier.RectifyLeftPixel(raw_left);
    const Eigen::Vector2d r = rectifier.RectifyRightPixel(raw_right);
    ASSERT_NEAR(l.y(), r.y(), 0.05) << "point " << p_ref.transpose();
    const Eigen::Vector3d p_rect = TriangulateRectified(g, l.x(), l.y(), l.x() - r.x());
    ASSERT_NEAR((g.rect_R_left.transpose() * p_rect - p_ref).norm() / z, 0, 1e-3)
        << "point " << p_ref.transpose();
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

TEST_F(KittiRawTest, BadTimestampLine) {
  WriteImages(kRectWidthPx, kRectHeightPx);
  for (const std::string bad : {"2011-09-26T13:02:26.068279825", "2011/09/26 13:02:26.068279825",
                                "2011-02-30 13:02:26.068279825", "2011-09-26 25:02:26.068279825",
                                "2011-09-26 13:02:26.0682798251"}) {
    WriteTextFile(Timestamps(),
                  "2011-09-26 13:02:25.964389445\n" + bad + "\n2011-09-26 13:02:26.172157\n");
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
        Timestamps().string() + " line 2: '" + bad + "' is not a time");
  }
  WriteTextFile(Timestamps(),
                "2011-09-26 13:02:25.964389445\n2011-09-26 13:02:25.964389445\n"
                "2011-09-26 13:02:26.172157\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Timestamps().string() + " line 2: 2011-09-26 13:02:25.964389445 does not come after line 1");
  WriteTextFile(Timestamps(), "2011-09-26 13:02:25.964389445\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Timestamps().string() + " has 1 line but there are 3 image pairs");
  fs::remove(Timestamps());
  ExpectError(
      ErrorCode::kNotFound, [&] { LoadStereoSequence(Drive()); }, Timestamps().string());
}

TEST_F(KittiRawTest, MissingCalibrationField) {
  WriteImages(kRectWidthPx, kRectHeightPx);
  WriteCalibWith("P_rect_01", "");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Calib().string() + ": no P_rect_01 line (rectified images)");
  WriteImages(kRawWidthPx, kRawHeightPx);
  WriteCalibWith("K_01", "");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Calib().string() + ": no K_01 line (camera 01 of unrectified images)");
  WriteCalibWith("S_00", "");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      "640x200 px) match no calibrated size: S_rect_00 (rectified) = 600x180");
  fs::remove(Calib());
  ExpectError(
      ErrorCode::kNotFound, [&] { LoadStereoSequence(Drive(), StereoLayout::kKittiRaw); },
      "calib_cam_to_cam.txt");
}

TEST_F(KittiRawTest, MalformedCalibrationLines) {
  WriteImages(kRawWidthPx, kRawHeightPx);
  WriteCalibWith("D_00", "D_00: -0.37 0.21 0.0011 -0.0009");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Calib().string() + " line " + std::to_string(CalibLine("D_00")) +
          " (D_00): expected 5 numbers, found 4");
  WriteCalibWith("T_01", "T_01: -0.537 O.0048 -0.0112");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      " line " + std::to_string(CalibLine("T_01")) + " (T_01): 'O.0048' (value 2) is not a number");
  WriteCalibWith("R_01", "R_01: 2 0 0 0 1 0 0 0 1");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      " line " + std::to_string(CalibLine("R_01")) + " (R_01): the rotation is not orthonormal");
  WriteCalibWith("calib_time", "just some words");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(Drive()); },
      Calib().string() + " line 1: expected \"KEY: values\"");
}

// ---- EuRoC ----

class EurocStereoSequenceTest : public ::testing::Test {
 protected:
  static constexpr int kPairs = 5;
  static constexpr std::int64_t kMs = 1'000'000;

  fs::path GroundTruth() const { return folder_.dir() / kEurocGroundTruthCsv; }
  std::int64_t Stamp(int i) const { return folder_.stamps()[static_cast<std::size_t>(i)]; }

  // One csv row: the body at `t` with a yaw of `yaw_deg` about the world's z axis.
  static std::string Row(std::int64_t stamp_ns, const Eigen::Vector3d& p, double yaw_deg) {
    const double half = yaw_deg * kPi / 360.0;
    char text[256];
    std::snprintf(text, sizeof text, "%lld,%.9f,%.9f,%.9f,%.12f,0,0,%.12f,0.1,0.2,0.3,0,0,0,0,0,0",
                  static_cast<long long>(stamp_ns), p.x(), p.y(), p.z(), std::cos(half),
                  std::sin(half));
    return text;
  }
  static Eigen::Isometry3d Body(const Eigen::Vector3d& p, double yaw_deg) {
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = Eigen::AngleAxisd(yaw_deg * kPi / 180.0, Eigen::Vector3d::UnitZ()).matrix();
    pose.translation() = p;
    return pose;
  }

  ScratchDir scratch_{"fleetmap-euroc-stereo"};
  SyntheticEuroc folder_{scratch_ / "seq", kPairs};
};

TEST_F(EurocStereoSequenceTest, WithoutGroundTruth) {
  const StereoSequence s = LoadStereoSequence(folder_.dir());
  EXPECT_EQ(s.layout, StereoLayout::kEuroc);
  EXPECT_EQ(s.credit, "EuRoC MAV dataset, ASL, ETH Zurich");
  ASSERT_EQ(s.pairs.size(), static_cast<std::size_t>(kPairs));
  EXPECT_EQ(s.pairs[3].stamp_ns, Stamp(3));
  EXPECT_EQ(s.pairs[3].right_image, folder_.Image(1, 3));
  EXPECT_NEAR(s.left.fx, 458.654, 1e-9);
  EXPECT_TRUE(s.first_T_left.empty());
  EXPECT_FALSE(s.has_ground_truth());
}

// Pair 0 before the csv's first row, pair 1 between two rows (interpolated), pair 2 on a row,
// pair 3 in a gap of 60 ms between rows, pair 4 after the last row.
TEST_F(EurocStereoSequenceTest, GroundTruthInterpolatedAtTheImageStamps) {
  fs::create_directories(GroundTruth().parent_path());
  const std::string header =
      "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y [], "
      "q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad s^-1], "
      "b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], "
      "b_a_RS_S_z [m s^-2]\n";
  WriteTextFile(GroundTruth(), header + Row(Stamp(1) - 2 * kMs, {1, 0, 0.5}, 0) + "\n" +
                                   Row(Stamp(1) + 3 * kMs, {2, 1, 0.5}, 10) + "\n" +
                                   Row(Stamp(2), {3, 0, 1}, 30) + "\n" +
                                   Row(Stamp(2) + 10 * kMs, {3, 0, 1}, 30) + "\n" +
                                   Row(Stamp(3) + 20 * kMs, {4, 0, 1}, 40) + "\n");
  const StereoSequence s = LoadStereoSequence(folder_.dir());
  ASSERT_TRUE(s.has_ground_truth());
  ASSERT_EQ(s.first_T_left.size(), static_cast<std::size_t>(kPairs));
  EXPECT_FALSE(s.first_T_left[0].has_value()) << "before the first row";
  EXPECT_FALSE(s.first_T_left[3].has_value()) << "in a gap of 60 ms";
  EXPECT_FALSE(s.first_T_left[4].has_value()) << "after the last row";
  ASSERT_TRUE(s.first_T_left[1] && s.first_T_left[2]);

  // By hand: pair 1 lies 2 of the 5 ms from the first row to the second, so the body is 40 % of
  // the way: (1.4, 0.4, 0.5) with a yaw of 4 deg. Pair 2 is on the third row. Pair 1, the first
  // covered one, is the reference.
  const Eigen::Isometry3d& body_T_cam0 = s.left.body_T_sensor;
  const Eigen::Isometry3d world_T_left1 = Body({1.4, 0.4, 0.5}, 4) * body_T_cam0;
  const Eigen::Isometry3d world_T_left2 = Body({3, 0, 1}, 30) * body_T_cam0;
  ExpectNear(*s.first_T_left[1], Eigen::Isometry3d::Identity(), 1e-12, "reference pair 1");
  ExpectNear(*s.first_T_left[2], world_T_left1.inverse() * world_T_left2, 1e-8, "pair 2");

  // The same through InterpolateBodyPose directly.
  const std::vector<EurocBodyPose> poses = ReadEurocGroundTruth(GroundTruth());
  ASSERT_EQ(poses.size(), 5u);
  ExpectNear(*InterpolateBodyPose(poses, Stamp(1)), Body({1.4, 0.4, 0.5}, 4), 1e-8, "at pair 1");
  EXPECT_FALSE(InterpolateBodyPose(poses, Stamp(1) - 2 * kMs - 1));
  ExpectNear(*InterpolateBodyPose(poses, Stamp(3) + 20 * kMs), Body({4, 0, 1}, 40), 1e-8,
             "on the last row");
}

TEST_F(EurocStereoSequenceTest, MalformedGroundTruthRows) {
  fs::create_directories(GroundTruth().parent_path());
  const std::string good = Row(Stamp(0), {0, 0, 0}, 0);
  WriteTextFile(GroundTruth(), "#header\n" + good + "\n1403715273300000000,1,2,3,1,0,0\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(folder_.dir()); },
      GroundTruth().string() + " line 3: expected at least 8 comma-separated fields");
  WriteTextFile(GroundTruth(), "#header\n" + good + "\n1403715273300000000,1,two,3,1,0,0,0\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(folder_.dir()); },
      GroundTruth().string() + " line 3: p_RS_R_y: 'two' is not a number");
  WriteTextFile(GroundTruth(), "#header\n" + good + "\n1403715273300000000,1,2,3,2,0,0,0\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(folder_.dir()); },
      GroundTruth().string() + " line 3: quaternion");
  WriteTextFile(GroundTruth(), "#header\n" + good + "\n" + good + "\n");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { LoadStereoSequence(folder_.dir()); },
      GroundTruth().string() + " line 3: timestamp " + std::to_string(Stamp(0)) +
          " does not come after line 2");
}

// ---- The shared excerpts ----

TEST(KittiExcerptsTest, AMissingExcerptFailsSayingWhereItLookedAndHowToSetIt) {
  EXPECT_FATAL_FAILURE(testing::RequireKittiExcerpts("", "/nowhere/a and /nowhere/b"),
                       "CMake looked in /nowhere/a and /nowhere/b");
  EXPECT_FATAL_FAILURE(testing::RequireKittiExcerpts("", "/nowhere/a"), "-DFLEETMAP_KITTI_DIR=");
  EXPECT_FATAL_FAILURE(testing::RequireKittiExcerpts("/nowhere/kitti", "/nowhere/kitti"),
                       "the KITTI odometry excerpts /nowhere/kitti (FLEETMAP_KITTI_DIR) have no");
  // Here the data is present (CI has it too); where it is not, this fails as the tests would.
  EXPECT_EQ(testing::KittiExcerptsMissing(), std::nullopt) << *testing::KittiExcerptsMissing();
}

struct KittiExcerpt {
  const char* name;
  int width_px, height_px;
  double focal_px;
  double baseline_m;  // seq2's right images are KITTI's camera 3 (../shared/data/README.md)
  double path_m;      // the ground truth's length, frame to frame
  double turn_deg;
};

class KittiExcerptTest : public ::testing::TestWithParam<KittiExcerpt> {};

TEST_P(KittiExcerptTest, LoadsWithCalibrationAndGroundTruth) {
  FLEETMAP_REQUIRE_KITTI_EXCERPTS();
  const KittiExcerpt& e = GetParam();
  const StereoSequence s = LoadStereoSequence(testing::KittiExcerptsDir() / e.name);
  EXPECT_EQ(s.layout, StereoLayout::kKittiOdometry);
  ASSERT_EQ(s.pairs.size(), 51u);
  EXPECT_EQ(s.pairs.back().stamp_ns, 5'000'000'000LL);  // no times.txt: 10 Hz
  EXPECT_EQ(s.left.width_px, e.width_px);
  EXPECT_EQ(s.left.height_px, e.height_px);
  EXPECT_DOUBLE_EQ(s.left.fx, e.focal_px);
  const StereoRectifier rectifier(s.left, s.right);
  EXPECT_NEAR(rectifier.geometry().baseline_m, e.baseline_m, 0.0001);
  EXPECT_NEAR(rectifier.geometry().focal_px, e.focal_px, 1e-6 * e.focal_px);

  ASSERT_EQ(s.first_T_left.size(), 51u);
  double path_m = 0;
  for (std::size_t i = 0; i < s.first_T_left.size(); ++i) {
    ASSERT_TRUE(s.first_T_left[i].has_value()) << i;
    if (i > 0) {
      path_m += (s.first_T_left[i]->translation() - s.first_T_left[i - 1]->translation()).norm();
    }
  }
  EXPECT_NEAR(path_m, e.path_m, 0.5);
  EXPECT_TRUE(s.first_T_left.front()->isApprox(Eigen::Isometry3d::Identity(), 1e-9));
  const double turn_deg = Eigen::AngleAxisd(s.first_T_left.back()->linear()).angle() * 180.0 / kPi;
  EXPECT_NEAR(turn_deg, e.turn_deg, 3.0);
  // A real street, not a blank frame.
  const cv::Mat left = ReadMonoImage(s.pairs[25].left_image, e.width_px, e.height_px);
  cv::Scalar mean, stddev;
  cv::meanStdDev(left, mean, stddev);
  EXPECT_GT(stddev[0], 10.0);
  // The car's speed from the ground truth: the path's length over its 5 s, pair by pair; the
  // last pair from the one before it; none out of range.
  const int last = static_cast<int>(s.pairs.size()) - 1;
  double speed_path_m = 0;
  for (int i = 0; i < last; ++i) {
    const double dt_s = static_cast<double>(s.pairs[i + 1].stamp_ns - s.pairs[i].stamp_ns) * 1e-9;
    speed_path_m += GroundTruthSpeedMps(s, i).value_or(-1000) * dt_s;
  }
  EXPECT_NEAR(speed_path_m, e.path_m, 0.01 * e.path_m);
  EXPECT_NEAR(*GroundTruthSpeedMps(s, last), *GroundTruthSpeedMps(s, last - 1), 1e-12);
  EXPECT_FALSE(GroundTruthSpeedMps(s, last + 1).has_value());
  EXPECT_FALSE(GroundTruthSpeedMps(s, -1).has_value());
}

// seq1 drives about 60 m straight ahead; seq2 about 52 m with a 98 deg turn (data README).
INSTANTIATE_TEST_SUITE_P(
    SharedData, KittiExcerptTest,
    ::testing::Values(KittiExcerpt{"seq1", 1226, 370, 707.0912, 0.5372, 59.86, 0},
                      KittiExcerpt{"seq2", 1241, 376, 718.856, 0.4733, 51.76, 98}),
    [](const auto& test) { return std::string(test.param.name); });

TEST(EurocExcerptTest, LoadsAsAStereoSequenceWithoutGroundTruth) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const StereoSequence s = LoadStereoSequence(testing::EurocSequenceDir());
  EXPECT_EQ(s.layout, StereoLayout::kEuroc);
  EXPECT_EQ(s.pairs.size(), 95u);
  EXPECT_FALSE(s.has_ground_truth());
  EXPECT_NEAR(StereoRectifier(s.left, s.right).geometry().baseline_m, 0.110, 0.002);
}

}  // namespace
}  // namespace fleetmap
