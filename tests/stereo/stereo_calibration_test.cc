// EuRoC calibration files and the stereo rectification built from them (stereo_calibration.h).
#include "fleetmap/stereo/stereo_calibration.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/features2d.hpp>
#include <random>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_front_end.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::EurocCalibrationDir;

PinholeCamera Cam0() {
  return LoadEurocCamera(EurocCalibrationDir() / "cam0.yaml");
}
PinholeCamera Cam1() {
  return LoadEurocCamera(EurocCalibrationDir() / "cam1.yaml");
}

// Projects p (in `camera`'s own frame) through its intrinsics and distortion to a raw pixel.
Eigen::Vector2d ProjectRaw(const PinholeCamera& camera, const Eigen::Vector3d& p) {
  const cv::Mat K =
      (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
  const cv::Mat D = (cv::Mat_<double>(1, 5) << camera.distortion[0], camera.distortion[1],
                     camera.distortion[2], camera.distortion[3], camera.distortion[4]);
  std::vector<cv::Point3d> in{{p.x(), p.y(), p.z()}};
  std::vector<cv::Point2d> out;
  cv::projectPoints(in, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D, out);
  return {out[0].x, out[0].y};
}

TEST(StereoCalibrationTest, ReadsTheEurocYaml) {
  const PinholeCamera cam0 = Cam0();
  EXPECT_EQ(cam0.name, "VI-Sensor cam0 (MT9M034)");
  EXPECT_EQ(cam0.width_px, 752);
  EXPECT_EQ(cam0.height_px, 480);
  EXPECT_DOUBLE_EQ(cam0.fx, 458.654);
  EXPECT_DOUBLE_EQ(cam0.fy, 457.296);
  EXPECT_DOUBLE_EQ(cam0.cx, 367.215);
  EXPECT_DOUBLE_EQ(cam0.cy, 248.375);
  EXPECT_DOUBLE_EQ(cam0.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(cam0.distortion[3], 1.76187114e-05);
  EXPECT_EQ(cam0.distortion[4], 0.0);  // four terms in the yaml: k3 = 0
  EXPECT_DOUBLE_EQ(cam0.rate_hz, 20);
  EXPECT_NEAR(cam0.body_T_sensor.translation().x(), -0.0216401454975, 1e-12);
  EXPECT_NEAR(cam0.body_T_sensor.translation().y(), -0.064676986768, 1e-12);
  EXPECT_NEAR(cam0.body_T_sensor.linear()(0, 1), -0.999880929698, 1e-9);
}

// Scene points seen by both raw cameras, through their distortion and extrinsics, land on one
// rectified row (within 0.01 px) and, when `triangulate`, triangulate back to where they were
// (within 0.1 % of their depth). `seed` picks the points; more than 100 of 200 must be in view.
void ExpectRectifiedPointsAgree(const PinholeCamera& left, const PinholeCamera& right,
                                std::uint32_t seed, bool triangulate) {
  const StereoRectifier rectifier(left, right);
  const RectifiedStereoGeometry& g = rectifier.geometry();
  const Eigen::Isometry3d right_T_left = right.body_T_sensor.inverse() * left.body_T_sensor;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> lateral(-0.5, 0.5), depth(0.8, 9.0);
  int checked = 0;
  for (int i = 0; i < 200; ++i) {
    const double z = depth(rng);
    const Eigen::Vector3d p_left(lateral(rng) * z, lateral(rng) * 0.7 * z, z);
    const Eigen::Vector2d raw_left = ProjectRaw(left, p_left);
    const Eigen::Vector2d raw_right = ProjectRaw(right, right_T_left * p_left);
    const auto inside = [](const Eigen::Vector2d& px) {
      return px.x() > 5 && px.x() < 747 && px.y() > 5 && px.y() < 475;
    };
    if (!inside(raw_left) || !inside(raw_right)) continue;
    const Eigen::Vector2d l = rectifier.RectifyLeftPixel(raw_left);
    const Eigen::Vector2d r = rectifier.RectifyRightPixel(raw_right);
    ASSERT_NEAR(l.y(), r.y(), 0.01) << "point " << p_left.transpose();
    if (triangulate) {
      const Eigen::Vector3d p_rect = TriangulateRectified(g, l.x(), l.y(), l.x() - r.x());
      const Eigen::Vector3d back = g.rect_R_left.transpose() * p_rect;
      ASSERT_NEAR((back - p_left).norm() / z, 0, 1e-3) << "point " << p_left.transpose();
    }
    ++checked;
  }
  EXPECT_GT(checked, 100);
}

// The rig as the yaml files give it: the right camera about 11 cm to the right of the left.
TEST(StereoCalibrationTest, RectificationLinesUpRowsAndKeepsTheBaseline) {
  const PinholeCamera left = Cam0(), right = Cam1();
  const StereoRectifier rectifier(left, right);
  const RectifiedStereoGeometry& g = rectifier.geometry();
  const Eigen::Isometry3d right_T_left = right.body_T_sensor.inverse() * left.body_T_sensor;
  EXPECT_NEAR(g.baseline_m, right_T_left.translation().norm(), 1e-9);
  EXPECT_NEAR(g.baseline_m, 0.110, 0.002);
  EXPECT_GT(g.focal_px, 300);
  EXPECT_LT(g.focal_px, 500);

  // Scene points seen by both raw cameras, through distortion and the real extrinsics, land on
  // one rectified row and triangulate back to where they were.
  ExpectRectifiedPointsAgree(left, right, /*seed=*/7, /*triangulate=*/true);
}

// OpenCV's fifth term, k3, reaches the rectification: with it in the projection but not in the
// rectifier, rows near the image edges would part by pixels.
TEST(StereoCalibrationTest, RectificationUsesTheFifthDistortionTerm) {
  PinholeCamera left = Cam0(), right = Cam1();
  left.distortion[4] = 0.08;
  right.distortion[4] = -0.05;
  ExpectRectifiedPointsAgree(left, right, /*seed=*/11, /*triangulate=*/false);
}

TEST(StereoCalibrationTest, WrittenCalibrationReadsBack) {
  PinholeCamera camera = Cam1();
  camera.name = "KITTI odometry right (image_r, P1)";
  camera.distortion[4] = 0.0123456789012345;
  const fs::path file = fs::temp_directory_path() /
                        ("fleetmap-written-" + Uuid::GenerateRandom().ToString() + ".yaml");
  WriteEurocCamera(camera, file);
  const PinholeCamera back = LoadEurocCamera(file);
  fs::remove(file);
  EXPECT_EQ(back.name, camera.name);
  EXPECT_EQ(back.width_px, camera.width_px);
  EXPECT_EQ(back.height_px, camera.height_px);
  EXPECT_DOUBLE_EQ(back.fx, camera.fx);
  EXPECT_DOUBLE_EQ(back.fy, camera.fy);
  EXPECT_DOUBLE_EQ(back.cx, camera.cx);
  EXPECT_DOUBLE_EQ(back.cy, camera.cy);
  for (std::size_t i = 0; i < 5; ++i) EXPECT_DOUBLE_EQ(back.distortion[i], camera.distortion[i]);
  EXPECT_DOUBLE_EQ(back.rate_hz, camera.rate_hz);
  EXPECT_LE((back.body_T_sensor.matrix() - camera.body_T_sensor.matrix()).cwiseAbs().maxCoeff(),
            1e-12);
  ExpectError(
      ErrorCode::kBackend, [&] { WriteEurocCamera(camera, "/nonexistent-dir/cam0.yaml"); },
      "/nonexistent-dir/cam0.yaml");
}

TEST(StereoCalibrationTest, RectifyRefusesImagesOfTheWrongKind) {
  const StereoRectifier rectifier(Cam0(), Cam1());
  const cv::Mat good(480, 752, CV_8UC1, cv::Scalar(0));
  cv::Mat out_left, out_right;
  rectifier.Rectify(good, good, out_left, out_right);
  EXPECT_EQ(out_left.size(), good.size());
  const cv::Mat small(240, 376, CV_8UC1, cv::Scalar(0));
  const cv::Mat colour(480, 752, CV_8UC3, cv::Scalar(0, 0, 0));
  for (const auto& [l, r, which] :
       {std::tuple{small, good, "left"}, std::tuple{good, colour, "right"},
        std::tuple{cv::Mat(), good, "left"}}) {
    try {
      rectifier.Rectify(l, r, out_left, out_right);
      ADD_FAILURE() << "accepted a bad " << which << " image";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
      EXPECT_NE(std::string(e.what()).find(which), std::string::npos) << e.what();
    }
  }
}

TEST(StereoCalibrationTest, SwappedCamerasAreRefused) {
  try {
    StereoRectifier rectifier(Cam1(), Cam0());
    FAIL() << "a rig with the right camera on the left was accepted";
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    EXPECT_NE(std::string(e.what()).find("right camera"), std::string::npos) << e.what();
  }
}

class BadCalibrationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("fleetmap-calib-" + Uuid::GenerateRandom().ToString());
    fs::create_directories(dir_);
    std::ifstream in(EurocCalibrationDir() / "cam0.yaml");
    good_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The good file with `from` replaced by `to`; expects LoadEurocCamera to name `field`.
  void ExpectRefused(const std::string& from, const std::string& to, const std::string& field) {
    std::string text = good_;
    const auto at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    const fs::path file = dir_ / "sensor.yaml";
    std::ofstream(file) << text;
    try {
      LoadEurocCamera(file);
      ADD_FAILURE() << "accepted " << to;
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument) << e.what();
      EXPECT_NE(std::string(e.what()).find(field), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(file.string()), std::string::npos) << e.what();
    }
  }

  fs::path dir_;
  std::string good_;
};

TEST_F(BadCalibrationTest, EachBrokenFieldIsNamed) {
  ExpectRefused("intrinsics: [458.654, 457.296, 367.215, 248.375]", "intrinsics: [458.654]",
                "intrinsics");
  ExpectRefused("intrinsics:", "intrinsix:", "intrinsics");
  ExpectRefused("camera_model: pinhole", "camera_model: omni", "camera_model");
  ExpectRefused("distortion_model: radial-tangential", "distortion_model: equidistant",
                "distortion_model");
  // Four or five terms (k1 k2 p1 p2 [k3]); three or six are refused.
  ExpectRefused("distortion_coefficients: [", "distortion_coefficients: [0.1, 0.2, ",
                "distortion_coefficients: expected 4 or 5 values, not 6");
  ExpectRefused("distortion_coefficients: [-0.28340811, ", "distortion_coefficients: [",
                "distortion_coefficients: expected 4 or 5 values, not 3");
  ExpectRefused("resolution: [752, 480]", "resolution: [752, -480]", "resolution");
  // A T_BS whose rotation is scaled is not a pose.
  ExpectRefused("data: [0.0148655429818, -0.999880929698",
                "data: [0.0297310859636, -1.999761859396", "T_BS");
}

TEST_F(BadCalibrationTest, FiveDistortionTermsAreRead) {
  std::string text = good_;
  const std::string four = "1.76187114e-05]";
  text.replace(text.find(four), four.size(), "1.76187114e-05, -0.0123]");
  const fs::path file = dir_ / "five.yaml";
  std::ofstream(file) << text;
  const PinholeCamera camera = LoadEurocCamera(file);
  EXPECT_DOUBLE_EQ(camera.distortion[0], -0.28340811);
  EXPECT_DOUBLE_EQ(camera.distortion[3], 1.76187114e-05);
  EXPECT_DOUBLE_EQ(camera.distortion[4], -0.0123);
}

TEST_F(BadCalibrationTest, MissingAndUnreadableFiles) {
  try {
    LoadEurocCamera(dir_ / "absent.yaml");
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kNotFound);
    EXPECT_NE(std::string(e.what()).find("absent.yaml"), std::string::npos);
  }
  const fs::path garbage = dir_ / "garbage.yaml";
  std::ofstream(garbage) << "\x01\x02 this is { not : [ yaml";
  EXPECT_THROW(LoadEurocCamera(garbage), Error);
}

// On the real images: after rectification, the true ORB matches between the two images lie on
// one row. True matches are told from false ones without using rows: RANSAC on the fundamental
// matrix (any epipolar geometry) keeps the matches of one rigid scene.
TEST(StereoCalibrationTest, RealPairRectifiedRowsAgree) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence sequence = LoadEurocSequence(testing::EurocSequenceDir());
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoPairFiles& pair = sequence.pairs.front();
  const cv::Mat left = ReadMonoImage(pair.left_image, 752, 480);
  const cv::Mat right = ReadMonoImage(pair.right_image, 752, 480);
  cv::Mat left_rect, right_rect;
  rectifier.Rectify(left, right, left_rect, right_rect);
  const cv::Ptr<cv::ORB> orb = cv::ORB::create(1000);
  std::vector<cv::KeyPoint> kl, kr;
  cv::Mat dl, dr;
  orb->detectAndCompute(left_rect, cv::noArray(), kl, dl);
  orb->detectAndCompute(right_rect, cv::noArray(), kr, dr);
  cv::BFMatcher matcher(cv::NORM_HAMMING, /*crossCheck=*/true);
  std::vector<cv::DMatch> matches;
  matcher.match(dl, dr, matches);
  std::vector<cv::Point2f> pl, pr;
  for (const cv::DMatch& m : matches) {
    // The finest pyramid level only, where positions are exact to about a pixel.
    if (kl[static_cast<std::size_t>(m.queryIdx)].octave != 0) continue;
    pl.push_back(kl[static_cast<std::size_t>(m.queryIdx)].pt);
    pr.push_back(kr[static_cast<std::size_t>(m.trainIdx)].pt);
  }
  ASSERT_GT(pl.size(), 100u);
  std::vector<std::uint8_t> inlier;
  cv::findFundamentalMat(pl, pr, cv::FM_RANSAC, 1.0, 0.999, inlier);
  std::vector<double> dy;
  for (std::size_t i = 0; i < pl.size(); ++i) {
    if (inlier[i]) dy.push_back(std::abs(pl[i].y - pr[i].y));
  }
  ASSERT_GT(dy.size(), 50u);
  std::sort(dy.begin(), dy.end());
  EXPECT_LE(dy[dy.size() / 2], 0.5) << "median row difference of " << dy.size() << " matches";
  EXPECT_LE(dy[dy.size() * 9 / 10], 2.0) << "90th percentile (FAST corners move a pixel or two)";
}

}  // namespace
}  // namespace fleetmap
