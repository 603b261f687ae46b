// The ORB stereo front end: triangulation, row matching with a disparity range and a left-right
// check, whole synthetic pairs of known depth, and the real EuRoC pairs (stereo_front_end.h,
// stereo_matcher.h).
#include "fleetmap/stereo/stereo_front_end.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "euroc_test_data.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/stereo/euroc_sequence.h"

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
  // The plane at 1 m has disparity 48 px: outside [1, 40], inside [1, 60].
  cv::Mat left, right;
  PlanePair(g, 1.0, left, right);
  options.matching.max_disparity_px = 40;
  EXPECT_LT(StereoFrontEnd(g, options).Process(0, left, right).frame.landmarks.size(), 5u);
  options.matching.max_disparity_px = 60;
  EXPECT_GT(StereoFrontEnd(g, options).Process(0, left, right).frame.landmarks.size(), 200u);
}

// The depth cut is by disparity (sigma_z / z = disparity_sigma_px / d): with the defaults a
// point needs d >= 0.5 / 0.2 = 2.5 px, here f B = 47.96 px m, so 19.2 m. Matches below it are
// counted, not kept; the rest are kept whatever their depth in metres.
TEST(StereoFrontEndTest, PointsWhoseDepthIsTooUncertainAreDroppedAndCounted) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  const double f_b = g.focal_px * g.baseline_m;
  const StereoFrontEnd front_end(g, StereoFrontEndOptions{});
  {
    // 24 m: d = 2.0 px, inside the matcher's [1, 150] but below 2.5 px.
    cv::Mat left, right;
    PlanePair(g, f_b / 2.0, left, right);
    const StereoFrontEndResult r = front_end.Process(0, left, right);
    EXPECT_GT(r.matching.matched, 200) << "the far plane must match to test the cut";
    EXPECT_LT(r.frame.landmarks.size(), 5u) << "only mismatches could pass";
    EXPECT_EQ(r.dropped_uncertain_depth + static_cast<int>(r.frame.landmarks.size()),
              r.matching.matched);
    EXPECT_EQ(r.depths_m.size(), r.frame.landmarks.size());
    EXPECT_EQ(r.left_pixels.size(), r.frame.landmarks.size());
  }
  {
    // 12 m: d = 4.0 px, farther than the old 12 m cut allowed for, and kept.
    cv::Mat left, right;
    PlanePair(g, f_b / 4.0, left, right);
    const StereoFrontEndResult r = front_end.Process(0, left, right);
    EXPECT_GT(r.frame.landmarks.size(), 200u);
    EXPECT_LT(r.dropped_uncertain_depth, 5);
    EXPECT_EQ(r.dropped_uncertain_depth + static_cast<int>(r.frame.landmarks.size()),
              r.matching.matched);
  }
  // The same 1 m plane (d = 48 px) on either side of the cut, moved by the options alone.
  cv::Mat left, right;
  PlanePair(g, 1.0, left, right);
  StereoFrontEndOptions options;
  options.disparity_sigma_px = 1.0;
  options.max_relative_depth_sigma = 1.0 / 60;  // d >= 60 px
  StereoFrontEndResult r = StereoFrontEnd(g, options).Process(0, left, right);
  EXPECT_EQ(r.frame.landmarks.size(), 0u);
  EXPECT_GT(r.dropped_uncertain_depth, 200);
  EXPECT_EQ(r.dropped_uncertain_depth, r.matching.matched);
  options.max_relative_depth_sigma = 1.0 / 40;  // d >= 40 px
  r = StereoFrontEnd(g, options).Process(0, left, right);
  EXPECT_GT(r.frame.landmarks.size(), 200u);
  EXPECT_LT(r.dropped_uncertain_depth, 5);
}

TEST(StereoFrontEndTest, OptionsOutOfRangeAreRefused) {
  const RectifiedStereoGeometry g = SyntheticGeometry();
  EXPECT_NO_THROW(StereoFrontEnd(g, StereoFrontEndOptions{}));
  const auto refused = [&](const char* what, auto change) {
    StereoFrontEndOptions o;
    change(o);
    EXPECT_THROW(StereoFrontEnd(g, o), Error) << what;
  };
  refused("grid_columns 0", [](StereoFrontEndOptions& o) { o.grid_columns = 0; });
  refused("grid_rows 0", [](StereoFrontEndOptions& o) { o.grid_rows = 0; });
  refused("grid_rows -1", [](StereoFrontEndOptions& o) { o.grid_rows = -1; });
  refused("oversampling 0.99", [](StereoFrontEndOptions& o) { o.detect_oversampling = 0.99; });
  refused("oversampling NaN", [](StereoFrontEndOptions& o) { o.detect_oversampling = NAN; });
  refused("disparity sigma 0", [](StereoFrontEndOptions& o) { o.disparity_sigma_px = 0; });
  refused("disparity sigma -1", [](StereoFrontEndOptions& o) { o.disparity_sigma_px = -1; });
  refused("relative depth sigma 0",
          [](StereoFrontEndOptions& o) { o.max_relative_depth_sigma = 0; });
  refused("relative depth sigma -0.2",
          [](StereoFrontEndOptions& o) { o.max_relative_depth_sigma = -0.2; });
  // The edges of the ranges are accepted: one cell, no oversampling is plain ORB.
  StereoFrontEndOptions plain;
  plain.grid_columns = 1;
  plain.grid_rows = 1;
  plain.detect_oversampling = 1.0;
  EXPECT_NO_THROW(StereoFrontEnd(g, plain));
}

// The landmarks carry the camera that made them, so the localiser can weigh them by pixels:
// focal length, baseline and the rectification rotation as a quaternion (w, x, y, z).
TEST(StereoFrontEndTest, LandmarksCarryTheRectifiedStereoCamera) {
  RectifiedStereoGeometry g = SyntheticGeometry();
  const Eigen::Matrix3d rect_R_left =
      Eigen::AngleAxisd(0.05, Eigen::Vector3d(0.2, 1.0, -0.3).normalized()).toRotationMatrix();
  g.rect_R_left = rect_R_left;
  const StereoFrontEnd front_end(g, StereoFrontEndOptions{});
  cv::Mat left, right;
  PlanePair(g, 2.5, left, right);
  const StereoFrontEndResult r = front_end.Process(0, left, right);
  ASSERT_GT(r.frame.landmarks.size(), 200u);
  ASSERT_TRUE(r.frame.landmarks.stereo.has_value());
  const StereoCamera& camera = *r.frame.landmarks.stereo;
  EXPECT_FLOAT_EQ(camera.focal_px, static_cast<float>(g.focal_px));
  EXPECT_FLOAT_EQ(camera.baseline_m, static_cast<float>(g.baseline_m));
  const Eigen::Quaterniond expected(rect_R_left);
  const Eigen::Quaterniond q(camera.rect_q_camera[0], camera.rect_q_camera[1],
                             camera.rect_q_camera[2], camera.rect_q_camera[3]);
  EXPECT_NEAR(q.norm(), 1.0, 1e-6);
  // q and -q are the same rotation.
  EXPECT_NEAR(std::abs(q.dot(expected)), 1.0, 1e-6);
  EXPECT_TRUE(q.toRotationMatrix().isApprox(rect_R_left, 1e-6));
  // The points are in the left camera's own frame: rotated into the rectified one, z is depth.
  for (std::size_t i = 0; i < r.frame.landmarks.size(); i += 50) {
    const Eigen::Vector3d p_rect = rect_R_left * r.frame.landmarks.points_camera[i].cast<double>();
    EXPECT_NEAR(p_rect.z(), r.depths_m[i], 1e-4 * r.depths_m[i]) << "landmark " << i;
  }
  // Bucketing keeps at most orb_features left keypoints; the right image keeps all it found.
  EXPECT_LE(r.left_keypoints, StereoFrontEndOptions{}.orb_features);
  EXPECT_GT(r.right_keypoints, r.left_keypoints);
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

TEST_F(StereoRowMatchTest, EqualDistancesGoToTheFirstRowThenTheLowestIndex) {
  // Three right keypoints one bit from the left one: two on row 101 (index 0 to the right of
  // index 1) and one on row 99. The tie goes to row 99, as a scan of the rows in turn would
  // meet it first; without it, to index 0 (the lower index, though further left on its row).
  const std::vector<cv::KeyPoint> left{cv::KeyPoint(200, 100, 31)};
  const cv::Mat dl = Descriptors({{0x00}});
  const cv::Mat dr = Descriptors({{0x01}, {0x02}, {0x04}});
  const std::vector<cv::KeyPoint> three{cv::KeyPoint(180, 101, 31), cv::KeyPoint(150, 101, 31),
                                        cv::KeyPoint(170, 99, 31)};
  std::vector<StereoMatch> m =
      MatchStereoRows(left, dl, three, dr, cv::Mat(), cv::Mat(), NoRefinement());
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].right_index, 2);
  const std::vector<cv::KeyPoint> two(three.begin(), three.begin() + 2);
  m = MatchStereoRows(left, dl, two, dr.rowRange(0, 2), cv::Mat(), cv::Mat(), NoRefinement());
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].right_index, 0);
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

// ---- Grid bucketing (BucketKeypoints) ----

cv::KeyPoint At(float x, float y, float response) {
  cv::KeyPoint k(x, y, 31);
  k.response = response;
  return k;
}

// Which of a grid's cells a kept keypoint lies in, counted.
std::vector<int> PerCell(const std::vector<cv::KeyPoint>& keypoints, const std::vector<int>& kept,
                         int width, int height, int columns, int rows) {
  std::vector<int> counts(static_cast<std::size_t>(columns * rows), 0);
  for (const int i : kept) {
    const cv::KeyPoint& k = keypoints[static_cast<std::size_t>(i)];
    const int column = std::min(columns - 1, static_cast<int>(k.pt.x * columns / width));
    const int row = std::min(rows - 1, static_cast<int>(k.pt.y * rows / height));
    ++counts[static_cast<std::size_t>(row * columns + column)];
  }
  return counts;
}

// 800 x 400 in 4 x 2 cells of 200 x 200; keep 80, a share of 10 per cell. Cell 0 (top left) has
// 100 keypoints all stronger than any elsewhere; cells 1-6 have 5 weak ones each; cell 7 none.
class BucketKeypointsTest : public ::testing::Test {
 protected:
  static constexpr int kWidth = 800, kHeight = 400, kColumns = 4, kRows = 2, kKeep = 80;

  void SetUp() override {
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> in_cell(1.0f, 199.0f);
    for (int i = 0; i < 100; ++i) {
      keypoints_.push_back(At(in_cell(rng), in_cell(rng), 100.0f + static_cast<float>(i)));
    }
    for (int cell = 1; cell <= 6; ++cell) {
      const float x0 = static_cast<float>(200 * (cell % kColumns));
      const float y0 = static_cast<float>(200 * (cell / kColumns));
      for (int i = 0; i < 5; ++i) {
        keypoints_.push_back(
            At(x0 + in_cell(rng), y0 + in_cell(rng), 1.0f + static_cast<float>(i)));
      }
    }
    // Shuffled, so the result cannot lean on the input's order.
    std::shuffle(keypoints_.begin(), keypoints_.end(), rng);
  }

  std::vector<cv::KeyPoint> keypoints_;
};

TEST_F(BucketKeypointsTest, EveryCellKeepsItsShareAndLeftoversGoToTheStrongest) {
  const std::vector<int> kept =
      BucketKeypoints(keypoints_, kWidth, kHeight, kColumns, kRows, kKeep);
  ASSERT_EQ(kept.size(), static_cast<std::size_t>(kKeep));
  EXPECT_TRUE(std::is_sorted(kept.begin(), kept.end()));
  EXPECT_EQ(std::adjacent_find(kept.begin(), kept.end()), kept.end()) << "no index twice";
  // The sparse cells keep all they have (5 < their share of 10); cell 0 its share and the 40
  // that the sparse and empty cells left unused.
  EXPECT_EQ(PerCell(keypoints_, kept, kWidth, kHeight, kColumns, kRows),
            (std::vector<int>{50, 5, 5, 5, 5, 5, 5, 0}));
  // Cell 0's are its strongest 50 (responses 150..199).
  for (const int i : kept) {
    const cv::KeyPoint& k = keypoints_[static_cast<std::size_t>(i)];
    if (k.response >= 100) {
      EXPECT_GE(k.response, 150.0f);
    }
  }
  // Plain top-N would have kept cell 0 only.
  const std::vector<int> global = BucketKeypoints(keypoints_, kWidth, kHeight, 1, 1, kKeep);
  EXPECT_EQ(PerCell(keypoints_, global, kWidth, kHeight, kColumns, kRows),
            (std::vector<int>{80, 0, 0, 0, 0, 0, 0, 0}));
}

TEST_F(BucketKeypointsTest, WhenEveryCellIsFullEachKeepsExactlyItsShare) {
  // 8 keypoints in each of the 8 cells, keep 32: a share of 4 each, nothing left over.
  std::vector<cv::KeyPoint> keypoints;
  for (int cell = 0; cell < 8; ++cell) {
    for (int i = 0; i < 8; ++i) {
      keypoints.push_back(At(static_cast<float>(200 * (cell % 4) + 20 * i + 5),
                             static_cast<float>(200 * (cell / 4) + 100),
                             static_cast<float>(cell * 100 + i)));
    }
  }
  const std::vector<int> kept = BucketKeypoints(keypoints, kWidth, kHeight, 4, 2, 32);
  EXPECT_EQ(PerCell(keypoints, kept, kWidth, kHeight, 4, 2), std::vector<int>(8, 4));
  // Each cell's strongest 4: indices 4..7 of it.
  for (const int i : kept) EXPECT_GE(i % 8, 4) << i;
}

TEST_F(BucketKeypointsTest, KeepsExactlyWhatIsAskedOrAllThereAre) {
  const int n = static_cast<int>(keypoints_.size());  // 130
  for (const int keep : {0, 1, 7, 8, 9, 79, 80, 81, 129}) {
    EXPECT_EQ(BucketKeypoints(keypoints_, kWidth, kHeight, kColumns, kRows, keep).size(),
              static_cast<std::size_t>(keep))
        << "keep " << keep;
  }
  for (const int keep : {130, 131, 1000}) {
    const std::vector<int> kept =
        BucketKeypoints(keypoints_, kWidth, kHeight, kColumns, kRows, keep);
    ASSERT_EQ(kept.size(), static_cast<std::size_t>(n)) << "keep " << keep;
    for (int i = 0; i < n; ++i) EXPECT_EQ(kept[static_cast<std::size_t>(i)], i);
  }
  EXPECT_TRUE(BucketKeypoints({}, kWidth, kHeight, kColumns, kRows, 10).empty());
}

TEST_F(BucketKeypointsTest, TiesAreBrokenByIndexSoTheResultIsDeterministic) {
  // Four cells of 2 x 2, every response equal, the cells' keypoints interleaved by index:
  // index i lies in cell i % 4. A share of 2: each cell keeps its two lowest indices.
  std::vector<cv::KeyPoint> keypoints;
  for (int i = 0; i < 24; ++i) {
    const int cell = i % 4;
    keypoints.push_back(At(static_cast<float>(400 * (cell % 2) + 10 + i),
                           static_cast<float>(200 * (cell / 2) + 10 + i), 5.0f));
  }
  const std::vector<int> kept = BucketKeypoints(keypoints, kWidth, kHeight, 2, 2, 8);
  EXPECT_EQ(kept, (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7}));
  for (int run = 0; run < 5; ++run) {
    EXPECT_EQ(BucketKeypoints(keypoints, kWidth, kHeight, 2, 2, 8), kept);
  }
  // Leftovers among equals go to the lowest indices too: 9 kept, a share of 3 (ceil 9 / 4):
  // the first pass fills cells in index order until 9 are kept.
  EXPECT_EQ(BucketKeypoints(keypoints, kWidth, kHeight, 2, 2, 9),
            (std::vector<int>{0, 1, 2, 3, 4, 5, 6, 7, 8}));
  // One cell: the lowest indices.
  EXPECT_EQ(BucketKeypoints(keypoints, kWidth, kHeight, 1, 1, 3), (std::vector<int>{0, 1, 2}));
}

TEST_F(BucketKeypointsTest, OneCellIsTheGlobalTopN) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> x(0.0f, kWidth), y(0.0f, kHeight), response(0.0f, 1.0f);
  std::vector<cv::KeyPoint> keypoints;
  for (int i = 0; i < 500; ++i) keypoints.push_back(At(x(rng), y(rng), response(rng)));
  std::vector<int> by_response(keypoints.size());
  for (std::size_t i = 0; i < by_response.size(); ++i) by_response[i] = static_cast<int>(i);
  std::stable_sort(by_response.begin(), by_response.end(), [&](int a, int b) {
    return keypoints[static_cast<std::size_t>(a)].response >
           keypoints[static_cast<std::size_t>(b)].response;
  });
  for (const int keep : {1, 37, 250, 499}) {
    std::vector<int> top(by_response.begin(), by_response.begin() + keep);
    std::sort(top.begin(), top.end());
    EXPECT_EQ(BucketKeypoints(keypoints, kWidth, kHeight, 1, 1, keep), top) << "keep " << keep;
  }
}

TEST_F(BucketKeypointsTest, KeypointsOnTheFarEdgesBelongToTheLastCell) {
  // x == width and y == height (ORB keeps keypoints inside, but the cell must not overflow):
  // the bottom-right cell, with its neighbour inside it; a share of 1 (keep 2 of 8 cells) lets
  // only the stronger of the two in, and the weak keypoint of cell 0 takes the other place.
  const std::vector<cv::KeyPoint> keypoints{
      At(kWidth, kHeight, 10.0f), At(kWidth - 1.0f, kHeight - 1.0f, 9.0f), At(0, 0, 1.0f)};
  EXPECT_EQ(BucketKeypoints(keypoints, kWidth, kHeight, kColumns, kRows, 2),
            (std::vector<int>{0, 2}));
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
    // Each landmark carries its left keypoint's pyramid level; a real image has keypoints on
    // several levels, and the camera says by how much each level scales.
    const Landmarks& l = r.frame.landmarks;
    ASSERT_EQ(l.levels.size(), l.size()) << "pair " << i;
    EXPECT_GT(*std::max_element(l.levels.begin(), l.levels.end()), 2) << "pair " << i;
    EXPECT_LT(*std::max_element(l.levels.begin(), l.levels.end()),
              StereoFrontEndOptions{}.orb_levels);
    EXPECT_EQ(std::count(l.levels.begin(), l.levels.end(), 0) > 0, true) << "pair " << i;
    EXPECT_FLOAT_EQ(l.stereo->level_scale, StereoFrontEndOptions{}.orb_scale_factor);
  }
}

// The front end describes only the left keypoints bucketing keeps; its landmarks are those of
// describing every keypoint in both images first, bucketing the left with its descriptors, and
// matching (the same points, descriptors and levels, in the same order).
TEST(StereoFrontEndTest, RealPairGivesTheLandmarksOfDescribingEverything) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence sequence = LoadEurocSequence(testing::EurocSequenceDir());
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoFrontEndOptions o;
  const StereoFrontEnd front_end(rectifier.geometry(), o);
  const StereoPairFiles& pair = sequence.pairs[20];
  cv::Mat left, right;
  rectifier.Rectify(ReadMonoImage(pair.left_image, 752, 480),
                    ReadMonoImage(pair.right_image, 752, 480), left, right);
  const StereoFrontEndResult r = front_end.Process(0, left, right);

  std::vector<cv::KeyPoint> all_left, right_keypoints, kept_left;
  cv::Mat all_left_descriptors, right_descriptors;
  CreateOrbDetector(o)->detectAndCompute(left, cv::noArray(), all_left, all_left_descriptors);
  CreateOrbDetector(o)->detectAndCompute(right, cv::noArray(), right_keypoints, right_descriptors);
  const std::vector<int> kept =
      BucketKeypoints(all_left, left.cols, left.rows, o.grid_columns, o.grid_rows, o.orb_features);
  cv::Mat kept_descriptors;
  for (const int i : kept) {
    kept_left.push_back(all_left[static_cast<std::size_t>(i)]);
    kept_descriptors.push_back(all_left_descriptors.row(i));
  }
  const std::vector<StereoMatch> matches = MatchStereoRows(
      kept_left, kept_descriptors, right_keypoints, right_descriptors, left, right, o.matching);
  EXPECT_EQ(r.left_keypoints, static_cast<int>(kept_left.size()));
  EXPECT_EQ(r.right_keypoints, static_cast<int>(right_keypoints.size()));
  EXPECT_EQ(r.matching.matched, static_cast<int>(matches.size()));
  const double min_disparity_px = o.disparity_sigma_px / o.max_relative_depth_sigma;
  std::size_t n = 0;
  for (const StereoMatch& m : matches) {
    if (m.disparity_px < min_disparity_px) continue;
    ASSERT_LT(n, r.frame.landmarks.size());
    EXPECT_EQ(r.frame.landmarks.descriptors[n], DescriptorRow(kept_descriptors, m.left_index))
        << "landmark " << n;
    EXPECT_EQ(r.left_pixels[n], Eigen::Vector2d(m.u_left_px, m.v_px)) << "landmark " << n;
    ++n;
  }
  EXPECT_EQ(n, r.frame.landmarks.size());
  EXPECT_GT(n, 200u);
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
