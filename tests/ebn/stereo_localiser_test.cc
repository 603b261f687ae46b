// The localiser's stereo reprojection mode (localiser.h): which matches are
// inliers, worked by hand on a scene whose RANSAC answer is exact; the Gauss-Newton refinement
// recovering a known motion from noisy KITTI-like stereo; mixed and absent cameras; options.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <vector>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/ebn/localiser.h"
#include "landmark_scene.h"

namespace fleetmap {
namespace {

using testing::RandomDescriptor;

// --- A reference projection, written from the definition in localiser.h --------------------

// (u_left, v, u_right) = f (x, y, x - b) / z of a point in the rectified left frame.
Eigen::Vector3d Project(double f, double b, const Eigen::Vector3d& q) {
  return Eigen::Vector3d(f * q.x(), f * q.y(), f * (q.x() - b)) / q.z();
}

// The larger of the two views' pixel residuals of one match (both cameras `camera`): the node's
// point against the frame point carried into the node, and the frame's point against the node
// point carried into the frame. A match is a stereo inlier iff this is below the threshold.
double WorstResidualPx(const StereoCamera& camera, const Se3& node_T_frame,
                       const Eigen::Vector3f& p_frame, const Eigen::Vector3f& p_node) {
  const auto& q = camera.rect_q_camera;
  const Eigen::Matrix3d rect_R_camera =
      Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  const double f = camera.focal_px, b = camera.baseline_m;
  const Eigen::Vector3d frame = p_frame.cast<double>(), node = p_node.cast<double>();
  const double in_node =
      (Project(f, b, rect_R_camera * (node_T_frame * frame)) - Project(f, b, rect_R_camera * node))
          .norm();
  const double in_frame = (Project(f, b, rect_R_camera * (node_T_frame.inverse() * node)) -
                           Project(f, b, rect_R_camera * frame))
                              .norm();
  return std::max(in_node, in_frame);
}

// --- The hand-worked scene ------------------------------------------------------------------
//
// Camera: f = 500 px, b = 0.5 m, rectified (identity rotation); node_T_frame = identity, so
// each frame point is its node point, exactly for the 40 anchors and with a depth error for
// the three probes. A stereo depth error lies along the viewing ray: u_left = f x / z and
// v = f y / z stay, and only the disparity d = f b / z moves, so the pixel residual of a probe
// at depth z seen at depth z' is |u_right - u_right'| = f b |1/z - 1/z'| = 250 |1/z - 1/z'|,
// the same in the node's view and in the frame's (the pose is the identity).
//
//   far probe:   node (2, 0, 40), frame (2.05, 0, 41): u_left 25 = 25,
//                u_right 500 * 1.5 / 40 = 18.75 vs 500 * 1.55 / 41 = 18.902439,
//                residual 250 / 40 - 250 / 41 = 6.25 - 6.097561 = 0.152439 px  < 2.8: inlier.
//                In metres |(0.05, 0, 1)| = 1.00125 m > 0.15: an outlier of the 3-D test.
//   near inlier: node (1, 0, 5), frame (1.056, 0, 5.28): u_left 100 = 100,
//                residual 250 / 5 - 250 / 5.28 = 50 - 47.348485 = 2.651515 px < 2.8: inlier.
//   near outlier: node (-1, 0, 5), frame (-0.944, 0, 4.72): u_left -100 = -100,
//                residual 250 / 4.72 - 250 / 5 = 52.966102 - 50 = 2.966102 px > 2.8: outlier.
//                Both near probes are 0.28 m deep, |(0.056, 0, 0.28)| = 0.285545 m in 3-D.
// The near probes err in opposite directions, so the one the refinement sees (the inlier)
// pulls the pose away from, not towards, explaining the other.
//
// So with the stereo camera: 40 + far + near inlier = 42 inliers; 3-D test: the 40 anchors.

constexpr int kAnchors = 40;

struct Probe {
  Eigen::Vector3f node, frame;
  double residual_px;  // worked by hand above
};

const std::vector<Probe>& Probes() {
  static const std::vector<Probe> probes = {
      {{2.f, 0.f, 40.f}, {2.05f, 0.f, 41.f}, 250.0 / 40 - 250.0 / 41},       // 0.152439
      {{1.f, 0.f, 5.f}, {1.056f, 0.f, 5.28f}, 250.0 / 5 - 250.0 / 5.28},     // 2.651515
      {{-1.f, 0.f, 5.f}, {-0.944f, 0.f, 4.72f}, 250.0 / 4.72 - 250.0 / 5}};  // 2.966102
  return probes;
}

StereoCamera HandCamera() {
  return {.focal_px = 500.f, .baseline_m = 0.5f};
}

struct HandScene {
  Landmarks frame, node;
};

// Anchors spread over 5-60 m ahead with their own random descriptors, so that every exact
// three-point sample gives the identity; the probes last, with descriptors of their own.
HandScene MakeHandScene(std::optional<StereoCamera> frame_camera,
                        std::optional<StereoCamera> node_camera) {
  std::mt19937 rng(2024);
  // Uniform in inverse depth (disparity 4-50 px), as stereo sees a street: enough near anchors
  // to hold the translation, which far ones barely fix.
  std::uniform_real_distribution<float> across(-0.5f, 0.5f), up(-0.2f, 0.2f),
      inverse_depth(1.f / 60.f, 1.f / 5.f);
  HandScene scene;
  const auto add = [&](const Eigen::Vector3f& p_node, const Eigen::Vector3f& p_frame) {
    const Descriptor256 d = RandomDescriptor(rng);
    scene.node.points_camera.push_back(p_node);
    scene.node.descriptors.push_back(d);
    scene.frame.points_camera.push_back(p_frame);
    scene.frame.descriptors.push_back(d);
  };
  for (int k = 0; k < kAnchors; ++k) {
    const float z = 1.f / inverse_depth(rng);
    const Eigen::Vector3f p(across(rng) * z, up(rng) * z, z);
    add(p, p);
  }
  for (const Probe& probe : Probes()) add(probe.node, probe.frame);
  scene.frame.stereo = frame_camera;
  scene.node.stereo = node_camera;
  return scene;
}

TEST(StereoLocaliser, HandWorkedResidualsAreWhatTheReferenceProjectionGives) {
  // The numbers of the comment above, from the definition; the localiser tests below rely on
  // them.
  for (const Probe& probe : Probes()) {
    EXPECT_NEAR(WorstResidualPx(HandCamera(), Se3::Identity(), probe.frame, probe.node),
                probe.residual_px, 1e-4);
  }
  EXPECT_NEAR(Probes()[0].residual_px, 0.152439, 1e-6);
  EXPECT_NEAR(Probes()[1].residual_px, 2.651515, 1e-6);
  EXPECT_NEAR(Probes()[2].residual_px, 2.966102, 1e-6);
  EXPECT_NEAR((Probes()[0].frame - Probes()[0].node).norm(), 1.00125, 1e-5);
  EXPECT_NEAR((Probes()[1].frame - Probes()[1].node).norm(), 0.285545, 1e-5);
}

// RANSAC's best hypothesis is the exact identity; the Gauss-Newton refinement that follows
// then leans a little towards the near inlier (2.65 px is a large residual for a point 5 m
// away, and the anchors fix the pose only so well): about 2 mm and 0.15 mrad, which moves the
// probes' residuals by about a tenth of a pixel, each staying on its side of 2.8 px.
void ExpectNearIdentityJudgedAsByHand(const Se3& node_T_frame, const StereoCamera& camera) {
  EXPECT_TRUE(Se3ApproxEqual(node_T_frame, Se3::Identity(), 0.005, 0.0005))
      << node_T_frame.translation().transpose() << ", " << RotationAngle(node_T_frame) << " rad";
  const HandScene scene = MakeHandScene(camera, camera);
  for (std::size_t k = 0; k < Probes().size(); ++k) {
    const double residual =
        WorstResidualPx(camera, node_T_frame, scene.frame.points_camera[kAnchors + k],
                        scene.node.points_camera[kAnchors + k]);
    EXPECT_NEAR(residual, Probes()[k].residual_px, 0.2) << "probe " << k;
    EXPECT_EQ(residual < 2.8, Probes()[k].residual_px < 2.8) << "probe " << k;
  }
}

TEST(StereoLocaliser, FarDepthErrorIsAnInlierInPixelsButAnOutlierInMetres) {
  const HandScene stereo = MakeHandScene(HandCamera(), HandCamera());
  const LocalisationResult in_pixels = Localiser().Localise(stereo.frame, stereo.node);
  ASSERT_TRUE(in_pixels.success);
  EXPECT_TRUE(in_pixels.stereo_residuals);
  EXPECT_EQ(in_pixels.matches, kAnchors + 3);
  EXPECT_EQ(in_pixels.inliers, kAnchors + 2);  // the far probe and the near inlier
  ExpectNearIdentityJudgedAsByHand(in_pixels.node_T_frame, HandCamera());

  const HandScene metric = MakeHandScene(std::nullopt, std::nullopt);
  const LocalisationResult in_metres = Localiser().Localise(metric.frame, metric.node);
  ASSERT_TRUE(in_metres.success);
  EXPECT_FALSE(in_metres.stereo_residuals);
  EXPECT_EQ(in_metres.inliers, kAnchors);  // 1.00 m and 0.29 m are beyond 0.15 m
  EXPECT_TRUE(Se3ApproxEqual(in_metres.node_T_frame, Se3::Identity(), 1e-4, 1e-5));
}

// The threshold bites exactly at the worked residuals: about a hundredth of a pixel either side of
// each one moves that probe, and only that probe, across.
TEST(StereoLocaliser, ThresholdBitesAtTheWorkedResiduals) {
  const HandScene scene = MakeHandScene(HandCamera(), HandCamera());
  const std::vector<std::pair<double, int>> threshold_inliers = {
      {0.14, kAnchors},      // below 0.152439: no probe
      {0.16, kAnchors + 1},  // the far probe
      {2.64, kAnchors + 1},  // below 2.651515
      {2.66, kAnchors + 2},  // the near inlier
      {2.80, kAnchors + 2},  // the default
      {2.95, kAnchors + 2},  // below 2.966102
      {2.98, kAnchors + 3},  // the near outlier too
  };
  for (const auto& [threshold, inliers] : threshold_inliers) {
    const LocalisationResult r =
        Localiser({.reprojection_threshold_px = threshold}).Localise(scene.frame, scene.node);
    ASSERT_TRUE(r.success) << threshold;
    EXPECT_EQ(r.inliers, inliers) << "threshold " << threshold << " px";
  }
  EXPECT_EQ(LocaliserOptions{}.reprojection_threshold_px, 2.8);
}

// A keypoint found at pyramid level l was measured scale^l times less precisely, and is judged
// per that sigma (stereo_reprojection.h). The near outlier (2.966102 px) at level 1 with scale
// 1.2 is 2.471752 sigma: an inlier once both views say so, still an outlier when only the frame
// does (the node's view judges its own measurement by its own level). Levels not given are 0.
TEST(StereoLocaliser, PyramidLevelsScaleEachMatchsThreshold) {
  StereoCamera camera = HandCamera();
  camera.level_scale = 1.2f;
  HandScene scene = MakeHandScene(camera, camera);
  std::vector<std::uint8_t> levels(scene.frame.size(), 0);
  levels.back() = 1;  // the near outlier
  scene.frame.levels = levels;
  EXPECT_EQ(Localiser().Localise(scene.frame, scene.node).inliers, kAnchors + 2);
  scene.node.levels = levels;
  EXPECT_EQ(Localiser().Localise(scene.frame, scene.node).inliers, kAnchors + 3);
  // The same levels with a scale of 1 (unknown) change nothing.
  scene.frame.stereo->level_scale = scene.node.stereo->level_scale = 1.0f;
  EXPECT_EQ(Localiser().Localise(scene.frame, scene.node).inliers, kAnchors + 2);
  // A higher level of the near inlier (2.651515 px) keeps it; level 0 everywhere is as before.
  scene.frame.levels.assign(scene.frame.size(), 0);
  scene.node.levels = scene.frame.levels;
  EXPECT_EQ(Localiser().Localise(scene.frame, scene.node).inliers, kAnchors + 2);
}

TEST(StereoLocaliser, LevelsThatDoNotFitThePointsAreRefused) {
  HandScene scene = MakeHandScene(HandCamera(), HandCamera());
  scene.frame.levels.assign(scene.frame.size() - 1, 0);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { Localiser().Localise(scene.frame, scene.node); },
      "42 pyramid levels");
  scene.frame.levels.assign(scene.frame.size(), 0);
  scene.node.levels.assign(scene.node.size(), Landmarks::kMaxLevel + 1);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { Localiser().Localise(scene.frame, scene.node); },
      "pyramid level above 31");
}

// rect_q_camera is honoured: the whole scene expressed in an unrectified camera frame pitched
// 25 degrees from the rectified one (p_camera = rect_R_camera^T p_rect), with that rotation
// given, is judged exactly as the rectified scene. Judged in the unrectified frame instead (the
// rotation ignored), the near probes' depths would shrink by cos 25 deg and their residuals grow
// to 2.651515 / 0.906308 = 2.93 px and 3.27 px: both outliers, 41 inliers, not 42.
TEST(StereoLocaliser, RectificationRotationIsApplied) {
  const Eigen::Quaterniond rect_q_camera(
      Eigen::AngleAxisd(25.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()));
  StereoCamera camera = HandCamera();
  camera.rect_q_camera = {
      static_cast<float>(rect_q_camera.w()), static_cast<float>(rect_q_camera.x()),
      static_cast<float>(rect_q_camera.y()), static_cast<float>(rect_q_camera.z())};
  HandScene scene = MakeHandScene(camera, camera);
  const Eigen::Matrix3f camera_R_rect = rect_q_camera.toRotationMatrix().transpose().cast<float>();
  for (Landmarks* side : {&scene.frame, &scene.node}) {
    for (Eigen::Vector3f& p : side->points_camera) p = camera_R_rect * p;
  }
  int inliers_if_ignored = kAnchors;
  for (std::size_t k = 0; k < Probes().size(); ++k) {
    const double ignored =
        WorstResidualPx(HandCamera(), Se3::Identity(), scene.frame.points_camera[kAnchors + k],
                        scene.node.points_camera[kAnchors + k]);
    const double honoured =
        WorstResidualPx(camera, Se3::Identity(), scene.frame.points_camera[kAnchors + k],
                        scene.node.points_camera[kAnchors + k]);
    EXPECT_NEAR(honoured, Probes()[k].residual_px, 1e-3) << "probe " << k;
    if (ignored < 2.8) ++inliers_if_ignored;
  }
  ASSERT_EQ(inliers_if_ignored, kAnchors + 1);  // the test tells the two apart

  const LocalisationResult r = Localiser().Localise(scene.frame, scene.node);
  ASSERT_TRUE(r.success);
  EXPECT_EQ(r.inliers, kAnchors + 2);
  EXPECT_TRUE(Se3ApproxEqual(r.node_T_frame, Se3::Identity(), 0.005, 0.0005));
}

// --- Mixed and absent cameras ---------------------------------------------------------------

// One camera is enough for pixel residuals: the known side's view judges alone. With the pose
// the identity both views see the same residuals, so either side alone gives the same count.
TEST(StereoLocaliser, EitherSideAloneUsesStereoResiduals) {
  for (const bool frame_has_camera : {true, false}) {
    SCOPED_TRACE(frame_has_camera ? "frame only" : "node only");
    const HandScene scene = frame_has_camera ? MakeHandScene(HandCamera(), std::nullopt)
                                             : MakeHandScene(std::nullopt, HandCamera());
    const LocalisationResult r = Localiser().Localise(scene.frame, scene.node);
    ASSERT_TRUE(r.success);
    EXPECT_TRUE(r.stereo_residuals);
    EXPECT_EQ(r.inliers, kAnchors + 2);
    ExpectNearIdentityJudgedAsByHand(r.node_T_frame, HandCamera());
  }
}

// Neither side: the 3-D test as before. The metric threshold decides (1.1 m takes every probe
// in), the pixel threshold is not looked at, and the result is the same bit for bit whatever
// it is.
TEST(StereoLocaliser, NeitherSideKeepsTheMetricTest) {
  const HandScene scene = MakeHandScene(std::nullopt, std::nullopt);
  const LocalisationResult plain = Localiser().Localise(scene.frame, scene.node);
  const LocalisationResult tiny_px =
      Localiser({.reprojection_threshold_px = 1e-6}).Localise(scene.frame, scene.node);
  EXPECT_FALSE(plain.stereo_residuals);
  EXPECT_EQ(plain.inliers, kAnchors);
  EXPECT_EQ(tiny_px.inliers, plain.inliers);
  EXPECT_EQ(tiny_px.node_T_frame.matrix(), plain.node_T_frame.matrix());
  EXPECT_EQ(Localiser({.inlier_threshold_m = 0.29}).Localise(scene.frame, scene.node).inliers,
            kAnchors + 2);  // the near probes, 0.2855 m off
  EXPECT_EQ(Localiser({.inlier_threshold_m = 1.1}).Localise(scene.frame, scene.node).inliers,
            kAnchors + 3);

  // And on the usual synthetic scene (no cameras) nothing changed: the localiser_test numbers.
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.translate(Eigen::Vector3d(0.4, -0.1, 1.2));
  node_T_frame.rotate(Eigen::AngleAxisd(0.15, Eigen::Vector3d(0.1, 1.0, 0.2).normalized()));
  const auto synthetic = testing::MakeLandmarkScene(node_T_frame, {});
  const LocalisationResult r = Localiser().Localise(synthetic.frame, synthetic.node);
  ASSERT_TRUE(r.success);
  EXPECT_FALSE(r.stereo_residuals);
  const Se3 error = node_T_frame.inverse() * r.node_T_frame;
  EXPECT_LT(error.translation().norm(), 0.01);
}

TEST(StereoLocaliser, NonPositiveReprojectionThresholdIsRefused) {
  for (const double bad : {0.0, -1.0, -2.8, std::numeric_limits<double>::quiet_NaN()}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { Localiser({.reprojection_threshold_px = bad}); },
        "reprojection_threshold_px");
  }
  EXPECT_NO_THROW(Localiser({.reprojection_threshold_px = 1e-9}));
}

// --- Refinement on noisy KITTI-like stereo --------------------------------------------------

constexpr double kKittiFocal_px = 718.856;
constexpr double kKittiBaseline_m = 0.537;

StereoCamera KittiCamera() {
  return {.focal_px = static_cast<float>(kKittiFocal_px),
          .baseline_m = static_cast<float>(kKittiBaseline_m)};
}

// About 1 m forward and 2 degrees of yaw (about the camera's y axis, which points down).
Se3 KittiMotion() {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.translate(Eigen::Vector3d(0.06, -0.02, 1.0));
  node_T_frame.rotate(Eigen::AngleAxisd(2.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()));
  return node_T_frame;
}

struct KittiScene {
  Landmarks frame, node;
  int true_matches = 0;
};

// 300 node points at 3-80 m inside a KITTI image (|u| < 600 px, |v| < 180 px about the
// principal point), exact; the frame sees each through node_T_frame and measures it with
// 0.3 px of noise on u_left, v and the disparity, then triangulates it back. Then 20 % (60)
// outliers: node landmarks whose frame copy sits at a random point of the view.
KittiScene MakeKittiScene(const Se3& node_T_frame, std::uint32_t seed) {
  constexpr int kPoints = 300, kOutliers = 60;
  const double f = kKittiFocal_px, b = kKittiBaseline_m;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-600, 600), v(-180, 180), z(3, 80);
  std::normal_distribution<double> noise_px(0.0, 0.3);
  const auto in_view = [&] {
    const double depth = z(rng);
    return Eigen::Vector3d(u(rng) * depth / f, v(rng) * depth / f, depth);
  };
  const Se3 frame_T_node = node_T_frame.inverse();
  KittiScene scene;
  const auto add = [&](const Eigen::Vector3d& p_node, const Eigen::Vector3d& p_frame) {
    const Descriptor256 d = RandomDescriptor(rng);
    scene.node.points_camera.push_back(p_node.cast<float>());
    scene.node.descriptors.push_back(d);
    scene.frame.points_camera.push_back(p_frame.cast<float>());
    scene.frame.descriptors.push_back(d);
  };
  for (int k = 0; k < kPoints; ++k) {
    const Eigen::Vector3d p_node = in_view();
    const Eigen::Vector3d p_frame = frame_T_node * p_node;
    // Measure (u_left, v, disparity) with noise and triangulate back.
    const double u_left = f * p_frame.x() / p_frame.z() + noise_px(rng);
    const double v_px = f * p_frame.y() / p_frame.z() + noise_px(rng);
    const double disparity = f * b / p_frame.z() + noise_px(rng);
    const double depth = f * b / disparity;
    add(p_node, Eigen::Vector3d(u_left * depth / f, v_px * depth / f, depth));
  }
  for (int k = 0; k < kOutliers; ++k) add(in_view(), in_view());
  scene.true_matches = kPoints;
  scene.node.stereo = scene.frame.stereo = KittiCamera();
  return scene;
}

TEST(StereoLocaliser, RefinementRecoversAKnownMotionFromNoisyStereo) {
  const Se3 truth = KittiMotion();
  const double motion_m = truth.translation().norm();
  for (std::uint32_t seed = 1; seed <= 10; ++seed) {
    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    const KittiScene scene = MakeKittiScene(truth, seed);
    const LocalisationResult r = Localiser().Localise(scene.frame, scene.node);
    ASSERT_TRUE(r.success);
    EXPECT_TRUE(r.stereo_residuals);
    EXPECT_EQ(r.matches, 360);
    // Every true match (0.3 px of noise a coordinate is far inside 2.8 px), no random outlier.
    EXPECT_EQ(r.inliers, scene.true_matches);
    const Se3 error = truth.inverse() * r.node_T_frame;
    EXPECT_LT(error.translation().norm(), 0.02 * motion_m);
    EXPECT_LT(RotationAngle(error), 0.05 * M_PI / 180.0);
  }
}

TEST(StereoLocaliser, SameInputsSameResultBitForBit) {
  const KittiScene scene = MakeKittiScene(KittiMotion(), 77);
  const LocalisationResult a = Localiser().Localise(scene.frame, scene.node);
  const Localiser localiser;
  localiser.Localise(scene.frame, scene.node);  // an earlier call must not matter
  const LocalisationResult b = localiser.Localise(scene.frame, scene.node);
  ASSERT_TRUE(a.success);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.matches, b.matches);
  EXPECT_EQ(a.stereo_residuals, b.stereo_residuals);
  EXPECT_EQ(a.node_T_frame.matrix(), b.node_T_frame.matrix());
}

}  // namespace
}  // namespace fleetmap
