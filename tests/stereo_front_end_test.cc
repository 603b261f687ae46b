// The ORB stereo front end: triangulation, row matching with a disparity range and a left-right
// check, whole synthetic pairs of known depth, and the real EuRoC pairs (stereo_front_end.h,
// stereo_matcher.h).
#include "fleetmap/experiments/stereo_front_end.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "euroc_test_data.h"
#include "fleetmap/common/error.h"
#include "fleetmap/common/localiser.h"
#include "fleetmap/experiments/euroc_sequence.h"

namespace fleetmap {
namespace {

// A rectified rig of the EuRoC camera's size and roughly its focal length and baseline.
RectifiedStereoGeometry SyntheticGeometry() {
  RectifiedStereoGeometry g;
  g.width_px = 752;
  g.height_px = 480;
  g.focal_px = 436.0;
  g.cx_px = 364.5;
  g.cy_px = 251.0;
  g.baseline_m = 0.11;
  return g;
}

TEST(StereoFrontEndTest, TriangulatesASyntheticPointPairWithKnownDepth) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  for (const Eigen::Vector3d& p :
       {Eigen::Vector3d(0.3, -0.2, 4.0), Eigen::Vector3d(-1.1, 0.4, 2.2),
        Eigen::Vector3d(0.0, 0.0, 0.6), Eigen::Vector3d(2.0, 1.0, 9.5)}) {
    const double u_left = g.cx_px + g.focal_px * p.x() / p.z();
    const double v = g.cy_px + g.focal_px * p.y() / p.z();
    const double u_right = g.cx_px + g.focal_px * (p.x() - g.baseline_m) / p.z();
    const Eigen::Vector3d q = TriangulateRectified(g, u_left, v, u_left - u_right);
    EXPECT_NEAR(q.z(), p.z(), 0.01 * p.z());
    EXPECT_NEAR((q - p).norm(), 0.0, 1e-9 * p.z());
  }
}

// Smooth random texture, so ORB finds corners everywhere and patches are distinctive.
cv::Mat Texture(int width, int height, std::uint32_t seed) {
  cv::Mat noise(height, width, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat smooth;
  cv::GaussianBlur(noise, smooth, cv::Size(0, 0), 1.5);
  cv::normalize(smooth, smooth, 0, 255, cv::NORM_MINMAX);
  return smooth;
}

// A fronto-parallel textured plane at depth z: the right image is the left shifted left by
// the disparity f B / z (sub-pixel, bilinear).
void PlanePair(const RectifiedStereoGeometry& g, double z, cv::Mat& left, cv::Mat& right) {
  const cv::Mat wide = Texture(g.width_px + 200, g.height_px, 3);
  left = wide(cv::Rect(100, 0, g.width_px, g.height_px)).clone();
  const double d = g.focal_px * g.baseline_m / z;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 100 + d, 0, 1, 0);
  cv::warpAffine(wide, right, shift, left.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
}

TEST(StereoFrontEndTest, PlaneOfKnownDepthTriangulatesWithinOnePercent) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  const StereoFrontEnd front_end(g, StereoFrontEndOptions{});
  for (const double z : {1.0, 2.5, 4.0}) {
    cv::Mat left, right;
    PlanePair(g, z, left, right);
    const StereoFrontEndResult r = front_end.Process(42, left, right);
    ASSERT_GT(r.frame.landmarks.size(), 200u) << "z = " << z;
    EXPECT_EQ(r.frame.stamp_ns, 42);
    EXPECT_EQ(r.frame.landmarks.size(), r.frame.landmarks.descriptors.size());
    std::vector<double> depths = r.depths_m;
    std::sort(depths.begin(), depths.end());
    EXPECT_NEAR(depths[depths.size() / 2], z, 0.01 * z) << "median, z = " << z;
    // Nearly every landmark, not just the median: the refinement works on each match.
    const auto near = std::count_if(depths.begin(), depths.end(),
                                    [&](double d) { return std::abs(d - z) < 0.03 * z; });
    EXPECT_GT(static_cast<double>(near), 0.95 * static_cast<double>(depths.size()));
    // Landmarks are in the left camera's frame (identity rectification here): z is depth.
    EXPECT_NEAR(r.frame.landmarks.points_camera[0].z(), r.depths_m[0], 1e-4);
  }
}

TEST(StereoFrontEndTest, DisparitiesOutsideTheRangeGiveNoLandmarks) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  StereoFrontEndOptions options;
  options.max_depth_m = 0;
  // The plane at 1 m has disparity 48 px: outside [1, 40], inside [1, 60].
  cv::Mat left, right;
  PlanePair(g, 1.0, left, right);
  options.matching.max_disparity_px = 40;
  EXPECT_LT(StereoFrontEnd(g, options).Process(0, left, right).frame.landmarks.size(), 5u);
  options.matching.max_disparity_px = 60;
  EXPECT_GT(StereoFrontEnd(g, options).Process(0, left, right).frame.landmarks.size(), 200u);
  // And max_depth_m drops what lies beyond it.
  options.max_depth_m = 0.9;
  EXPECT_EQ(StereoFrontEnd(g, options).Process(0, left, right).frame.landmarks.size(), 0u);
}

TEST(StereoFrontEndTest, BlankAndWrongImages) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  const StereoFrontEnd front_end(g, StereoFrontEndOptions{});
  const cv::Mat blank(g.height_px, g.width_px, CV_8UC1, cv::Scalar(128));
  const StereoFrontEndResult r = front_end.Process(0, blank, blank);
  EXPECT_EQ(r.left_keypoints, 0);
  EXPECT_EQ(r.frame.landmarks.size(), 0u);
  const cv::Mat small(100, 100, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(front_end.Process(0, small, blank), Error);
  EXPECT_THROW(front_end.Process(0, blank, cv::Mat()), Error);
  RectifiedStereoGeometry bad = g;
  bad.baseline_m = 0;
  EXPECT_THROW(StereoFrontEnd(bad, StereoFrontEndOptions{}), Error);
}

// Hand-made keypoints and descriptors: the row limit, the disparity range and the left-right
// check, one at a time (no refinement: no images).
class StereoRowMatchTest : public ::testing::Test {
 protected:
  static cv::Mat Descriptors(const std::vector<std::vector<std::uint8_t>>& rows) {
    cv::Mat d(static_cast<int>(rows.size()), 32, CV_8UC1, cv::Scalar(0));
    for (std::size_t i = 0; i < rows.size(); ++i) {
      for (std::size_t b = 0; b < rows[i].size(); ++b) {
        d.at<std::uint8_t>(static_cast<int>(i), static_cast<int>(b)) = rows[i][b];
      }
    }
    return d;
  }
  static StereoMatchOptions NoRefinement() {
    StereoMatchOptions o;
    o.refine_patch_radius_px = 0;
    o.ratio = 1.0;
    return o;
  }
};

TEST_F(StereoRowMatchTest, RowToleranceAndDisparityRange) {
  const std::vector<cv::KeyPoint> left{cv::KeyPoint(200, 100, 31), cv::KeyPoint(200, 300, 31),
                                       cv::KeyPoint(200, 400, 31)};
  // Same descriptors; the first right keypoint on the row at disparity 20, the second 5 rows
  // off, the third at a negative disparity.
  const std::vector<cv::KeyPoint> right{cv::KeyPoint(180, 101, 31), cv::KeyPoint(180, 305, 31),
                                        cv::KeyPoint(210, 400, 31)};
  const cv::Mat d = Descriptors({{0x0f}, {0xf0}, {0xff}});
  StereoMatchCounts counts;
  const std::vector<StereoMatch> m =
      MatchStereoRows(left, d, right, d, cv::Mat(), cv::Mat(), NoRefinement(), &counts);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].left_index, 0);
  EXPECT_EQ(m[0].right_index, 0);
  EXPECT_DOUBLE_EQ(m[0].disparity_px, 20);
  EXPECT_EQ(counts.no_candidate, 2);
}

TEST_F(StereoRowMatchTest, KeypointsTwoPyramidLevelsApartDoNotMatch) {
  // Same row, same descriptor, disparity 30; the left keypoint at level 0, the right at level
  // 1 (kept) or 2 (refused by max_octave_difference = 1).
  const std::vector<cv::KeyPoint> left{cv::KeyPoint(200, 100, 31, -1, 0, 0)};
  const cv::Mat d = Descriptors({{0x5a}});
  for (const int octave : {1, 2}) {
    const std::vector<cv::KeyPoint> right{cv::KeyPoint(170, 100, 31, -1, 0, octave)};
    const auto m = MatchStereoRows(left, d, right, d, cv::Mat(), cv::Mat(), NoRefinement());
    EXPECT_EQ(m.size(), octave == 1 ? 1u : 0u) << "right octave " << octave;
  }
}

TEST_F(StereoRowMatchTest, LeftRightCheckKeepsOnlyTheMutualBest) {
  // Two left keypoints whose best right candidate is the same one; only the closer descriptor
  // (left 1, one bit away) survives the check. Left 0's own best (2 bits) loses to it.
  const std::vector<cv::KeyPoint> left{cv::KeyPoint(300, 100, 31), cv::KeyPoint(320, 100, 31)};
  const std::vector<cv::KeyPoint> right{cv::KeyPoint(250, 100, 31)};
  const cv::Mat dl = Descriptors({{0x03}, {0x01}});
  const cv::Mat dr = Descriptors({{0x00}});
  StereoMatchOptions options = NoRefinement();
  StereoMatchCounts counts;
  std::vector<StereoMatch> m =
      MatchStereoRows(left, dl, right, dr, cv::Mat(), cv::Mat(), options, &counts);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].left_index, 1);
  EXPECT_EQ(counts.rejected_left_right, 1);
  options.left_right_check = false;
  m = MatchStereoRows(left, dl, right, dr, cv::Mat(), cv::Mat(), options);
  EXPECT_EQ(m.size(), 2u) << "without the check both claim the one right keypoint";
}

TEST_F(StereoRowMatchTest, BadArgumentsAreRefused) {
  const std::vector<cv::KeyPoint> one{cv::KeyPoint(10, 10, 31)};
  const cv::Mat d = Descriptors({{1}});
  const cv::Mat short_rows(1, 16, CV_8UC1, cv::Scalar(0));
  EXPECT_THROW(MatchStereoRows(one, short_rows, one, d, cv::Mat(), cv::Mat(), NoRefinement()),
               Error);
  StereoMatchOptions o = NoRefinement();
  o.min_disparity_px = 0;
  EXPECT_THROW(MatchStereoRows(one, d, one, d, cv::Mat(), cv::Mat(), o), Error);
  // Refinement needs the images.
  EXPECT_THROW(MatchStereoRows(one, d, one, d, cv::Mat(), cv::Mat(), StereoMatchOptions{}), Error);
}

// The real pairs: depths in the room's scale (a drone in a room of a few metres).
TEST(StereoFrontEndTest, RealPairsTriangulateAtTheRoomsScale) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence sequence = LoadEurocSequence(testing::EurocSequenceDir());
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoFrontEnd front_end(rectifier.geometry(), StereoFrontEndOptions{});
  for (std::size_t i = 0; i < sequence.pairs.size(); i += 30) {
    const StereoPairFiles& pair = sequence.pairs[i];
    cv::Mat left, right;
    rectifier.Rectify(ReadMonoImage(pair.left_image, 752, 480),
                      ReadMonoImage(pair.right_image, 752, 480), left, right);
    const StereoFrontEndResult r = front_end.Process(pair.stamp_ns, left, right);
    EXPECT_GT(r.frame.landmarks.size(), 200u) << "pair " << i;
    std::vector<double> depths = r.depths_m;
    std::sort(depths.begin(), depths.end());
    const double median = depths.empty() ? 0 : depths[depths.size() / 2];
    EXPECT_GT(median, 0.5) << "pair " << i;
    EXPECT_LT(median, 10.0) << "pair " << i;
    EXPECT_EQ(r.frame.stamp_ns, pair.stamp_ns);
  }
}

// A real frame localises against itself, and fails, without an exception, against frames made
// from its own pair turned by 180 degrees (the rows still line up, but every disparity changes
// sign, so the few landmarks left are mismatches) and from a blank pair (no landmarks at all).
TEST(StereoFrontEndTest, RealFrameFailsCleanlyAgainstItsPairRotatedOrBlank) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence sequence = LoadEurocSequence(testing::EurocSequenceDir());
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoFrontEnd front_end(rectifier.geometry(), StereoFrontEndOptions{});
  const StereoPairFiles& pair = sequence.pairs[10];
  cv::Mat left, right;
  rectifier.Rectify(ReadMonoImage(pair.left_image, 752, 480),
                    ReadMonoImage(pair.right_image, 752, 480), left, right);
  const Landmarks frame = front_end.Process(0, left, right).frame.landmarks;
  const Localiser localiser;
  const LocalisationResult itself = localiser.Localise(frame, frame);
  ASSERT_TRUE(itself.success);
  EXPECT_GT(itself.inliers, 200);

  cv::Mat left_turned, right_turned;
  cv::rotate(left, left_turned, cv::ROTATE_180);
  cv::rotate(right, right_turned, cv::ROTATE_180);
  const Landmarks turned = front_end.Process(0, left_turned, right_turned).frame.landmarks;
  EXPECT_LT(turned.size(), frame.size() / 2);
  LocalisationResult r = localiser.Localise(frame, turned);
  EXPECT_FALSE(r.success) << r.inliers << " inliers";
  r = localiser.Localise(turned, frame);
  EXPECT_FALSE(r.success) << r.inliers << " inliers";

  const cv::Mat blank(left.size(), CV_8UC1, cv::Scalar(128));
  const Landmarks nothing = front_end.Process(0, blank, blank).frame.landmarks;
  EXPECT_EQ(nothing.size(), 0u);
  r = localiser.Localise(frame, nothing);
  EXPECT_FALSE(r.success);
  EXPECT_EQ(r.inliers, 0);
  EXPECT_FALSE(localiser.Localise(nothing, frame).success);
}

}  // namespace
}  // namespace fleetmap
