// Visual odometry between consecutive frames by the localiser (visual_odometry.h): a known
// motion recovered, a frame that does not track, and the whole real sequence.
#include "fleetmap/stereo/visual_odometry.h"

#include <gtest/gtest.h>

#include <random>

#include "euroc_test_data.h"
#include "fleetmap/core/error.h"
#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "landmark_scene.h"

namespace fleetmap {
namespace {

// Landmarks spread through a room in front of the camera.
Landmarks RoomLandmarks(std::mt19937& rng, int n) {
  std::uniform_real_distribution<float> lateral(-2.0f, 2.0f), depth(1.0f, 6.0f);
  Landmarks l;
  for (int i = 0; i < n; ++i) {
    l.points_camera.emplace_back(lateral(rng), lateral(rng) * 0.6f, depth(rng));
  }
  l.descriptors = testing::RandomDescriptors(static_cast<std::size_t>(n), rng);
  return l;
}

// The same landmarks seen from a camera moved by prev_T_this: p_this = this_T_prev * p_prev.
Landmarks SeenAfter(const Landmarks& previous, const Se3& prev_T_this) {
  Landmarks l = previous;
  const Se3 this_T_prev = prev_T_this.inverse();
  for (Eigen::Vector3f& p : l.points_camera) p = (this_T_prev * p.cast<double>()).cast<float>();
  return l;
}

Frame MakeFrame(std::int64_t stamp_ns, Landmarks landmarks) {
  Frame f;
  f.stamp_ns = stamp_ns;
  f.landmarks = std::move(landmarks);
  return f;
}

TEST(VisualOdometryTest, RecoversAKnownMotionAndChainsIt) {
  std::mt19937 rng(11);
  const Landmarks room = RoomLandmarks(rng, 300);
  Se3 step = Se3::Identity();
  step.translate(Eigen::Vector3d(0.04, -0.01, 0.05));
  step.rotate(Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitY()));
  VisualOdometry vo;
  Frame first = MakeFrame(0, room);
  const OdometryStep s0 = vo.Track(first);
  EXPECT_FALSE(s0.estimated);
  EXPECT_TRUE(first.prev_T_this.isApprox(Se3::Identity()));
  Frame second = MakeFrame(50, SeenAfter(room, step));
  const OdometryStep s1 = vo.Track(second);
  ASSERT_TRUE(s1.estimated);
  EXPECT_GE(s1.inliers, 290);
  EXPECT_TRUE(Se3ApproxEqual(s1.prev_T_this, step, 1e-4, 1e-4));
  EXPECT_TRUE(Se3ApproxEqual(second.prev_T_this, step, 1e-4, 1e-4));
}

TEST(VisualOdometryTest, AFrameThatDoesNotTrackKeepsTheLastMotion) {
  std::mt19937 rng(12);
  const Landmarks room = RoomLandmarks(rng, 300);
  Se3 step = Se3::Identity();
  step.translate(Eigen::Vector3d(0.0, 0.0, 0.08));
  VisualOdometry vo;
  Frame a = MakeFrame(0, room);
  vo.Track(a);
  Frame b = MakeFrame(50, SeenAfter(room, step));
  ASSERT_TRUE(vo.Track(b).estimated);
  // A blank image: no landmarks at all.
  Frame blank = MakeFrame(100, Landmarks{});
  const OdometryStep lost = vo.Track(blank);
  EXPECT_FALSE(lost.estimated);
  EXPECT_EQ(lost.inliers, 0);
  EXPECT_TRUE(Se3ApproxEqual(lost.prev_T_this, step, 1e-4, 1e-4)) << "constant velocity";
  // Unrelated landmarks (another place): matched descriptors are random, RANSAC finds nothing.
  Frame elsewhere = MakeFrame(150, RoomLandmarks(rng, 300));
  Frame again = MakeFrame(200, RoomLandmarks(rng, 300));
  vo.Track(elsewhere);
  EXPECT_FALSE(vo.Track(again).estimated);
}

// A corridor driven in 40 steps, each frame seeing the same landmarks with its own depth noise
// (what stereo gives): chained steps drift. Each step averaged with the same step measured from
// the frame before the previous (fuse_frame_before) ends closer to the truth, over 6 drives.
TEST(VisualOdometryTest, FusingTheFrameBeforeDriftsLessThanFrameToFrame) {
  Se3 step = Se3::Identity();
  step.translate(Eigen::Vector3d(0.0, 0.0, 0.5));
  step.rotate(Eigen::AngleAxisd(0.01, Eigen::Vector3d::UnitY()));
  double fused_error_m = 0, plain_error_m = 0;
  for (unsigned seed = 1; seed <= 6; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<float> lateral(-8.f, 8.f), ahead(2.f, 60.f);
    Landmarks world;
    for (int i = 0; i < 1500; ++i) {
      world.points_camera.emplace_back(lateral(rng), lateral(rng) * 0.2f, ahead(rng));
    }
    world.descriptors = testing::RandomDescriptors(1500, rng);
    for (const bool fuse : {true, false}) {
      VisualOdometryOptions options;
      options.fuse_frame_before = fuse;
      VisualOdometry vo(options);
      std::mt19937 noise_rng(seed * 100);
      std::normal_distribution<double> depth_noise(0.0, 0.01);
      Se3 world_T_camera = Se3::Identity(), estimated = Se3::Identity();
      for (int k = 0; k < 40; ++k) {
        if (k > 0) world_T_camera = world_T_camera * step;
        Landmarks seen = SeenAfter(world, world_T_camera);
        // Stereo's error grows with the square of the depth and lies along the ray.
        for (Eigen::Vector3f& p : seen.points_camera) {
          p *= static_cast<float>(1.0 + depth_noise(noise_rng) * p.z() / 10.0);
        }
        Frame frame = MakeFrame(k, std::move(seen));
        vo.Track(frame);
        estimated = estimated * frame.prev_T_this;
      }
      const double error_m = (estimated.translation() - world_T_camera.translation()).norm();
      (fuse ? fused_error_m : plain_error_m) += error_m / 6;
    }
  }
  EXPECT_LT(fused_error_m, 0.6 * plain_error_m)
      << "fused " << fused_error_m << " m, frame to frame " << plain_error_m << " m";
}

TEST(VisualOdometryTest, OptionsOutOfRangeAreRefused) {
  VisualOdometryOptions o;
  o.min_inliers = o.localiser.min_inliers - 1;
  EXPECT_THROW(VisualOdometry{o}, Error);
}

// The whole EuRoC excerpt: VO chained over 94 steps ends where localising the last frame
// directly against the first puts it, within 3 cm and 1 degree (the drone barely moves in these
// 4.75 s, so any drift shows), and no step jumps more than 0.3 m.
TEST(VisualOdometryTest, ChainedOverTheRealSequenceAgreesWithTheDirectPose) {
  FLEETMAP_REQUIRE_EUROC_SEQUENCE();
  const EurocSequence sequence = LoadEurocSequence(testing::EurocSequenceDir());
  const StereoRectifier rectifier(sequence.left, sequence.right);
  const StereoFrontEnd front_end(rectifier.geometry(), StereoFrontEndOptions{});
  VisualOdometry vo;
  Se3 first_T_camera = Se3::Identity();
  Landmarks first, last;
  int tracked = 0;
  for (std::size_t i = 0; i < sequence.pairs.size(); ++i) {
    cv::Mat left, right;
    rectifier.Rectify(ReadMonoImage(sequence.pairs[i].left_image, 752, 480),
                      ReadMonoImage(sequence.pairs[i].right_image, 752, 480), left, right);
    Frame frame = front_end.Process(sequence.pairs[i].stamp_ns, left, right).frame;
    const OdometryStep step = vo.Track(frame);
    tracked += step.estimated && step.inliers >= 30 ? 1 : 0;
    EXPECT_LT(step.prev_T_this.translation().norm(), 0.3) << "step " << i;
    first_T_camera = first_T_camera * frame.prev_T_this;
    if (i == 0) first = frame.landmarks;
    last = frame.landmarks;
  }
  EXPECT_GE(tracked, 85) << "of 94 steps";
  const LocalisationResult direct = Localiser(StereoLocaliserOptions()).Localise(last, first);
  ASSERT_TRUE(direct.success);
  const Se3 disagreement = direct.node_T_frame.inverse() * first_T_camera;
  EXPECT_LT(disagreement.translation().norm(), 0.03);
  EXPECT_LT(RotationAngle(disagreement), 1.0 * 3.14159265358979 / 180.0);
}

}  // namespace
}  // namespace fleetmap
