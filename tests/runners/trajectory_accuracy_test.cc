// Drift and absolute trajectory error against ground truth (trajectory_accuracy.h), on
// trajectories whose errors are known by construction: a scale error, a heading error per metre,
// a rigid displacement of the whole estimate.
#include "fleetmap/runners/trajectory_accuracy.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "expect_error.h"

namespace fleetmap {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kDegree = kPi / 180.0;

Se3 Translation(double x, double y, double z) {
  Se3 t = Se3::Identity();
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}

// A turn about the camera's y axis (down, in the camera convention): a change of heading.
Se3 Yaw(double angle_rad) {
  Se3 r = Se3::Identity();
  r.linear() = Eigen::AngleAxisd(angle_rad, Eigen::Vector3d::UnitY()).toRotationMatrix();
  return r;
}

// first_T_camera of a drive of `steps` 1 m steps forward (camera z), turning by `yaw_rad` after
// each: steps + 1 poses, the first the identity.
std::vector<Se3> Drive(int steps, double yaw_rad = 0) {
  std::vector<Se3> poses{Se3::Identity()};
  for (int i = 0; i < steps; ++i)
    poses.push_back(poses.back() * Translation(0, 0, 1) * Yaw(yaw_rad));
  return poses;
}

// How many (first frame, length) sub-paths a straight drive of 1 m steps over `metres` has for
// the given lengths (whole metres): a sub-path of L starts at frames 0 .. metres - L.
int StraightSubPaths(int metres, const std::vector<double>& lengths_m) {
  int n = 0;
  for (const double l : lengths_m) n += metres - static_cast<int>(l) + 1;
  return n;
}

TEST(TrajectoryAccuracyTest, SubPathLengthsEveryTenMetresUpToThePath) {
  EXPECT_EQ(SubPathLengths(35), (std::vector<double>{10, 20, 30}));
  EXPECT_EQ(SubPathLengths(30), (std::vector<double>{10, 20, 30})) << "the path's own length";
  EXPECT_EQ(SubPathLengths(60), (std::vector<double>{10, 20, 30, 40, 50, 60}));
  EXPECT_TRUE(SubPathLengths(5).empty());
  EXPECT_TRUE(SubPathLengths(0).empty());
  EXPECT_EQ(SubPathLengths(7, 2.5), (std::vector<double>{2.5, 5.0}));
  EXPECT_TRUE(SubPathLengths(100, 0).empty()) << "a zero step must not loop forever";
}

TEST(TrajectoryAccuracyTest, PerfectEstimateHasNoDriftAndNoError) {
  const std::vector<Se3> truth = Drive(60, 1.0 * kDegree);
  const TrajectoryAccuracy a = MeasureTrajectory(truth, truth, SubPathLengths(60));
  EXPECT_GT(a.sub_paths, 0);
  EXPECT_NEAR(a.truth_length_m, 60.0, 1e-9);
  EXPECT_NEAR(a.translational_drift_percent, 0.0, 1e-9);
  EXPECT_NEAR(a.rotational_drift_deg_per_m, 0.0, 1e-9);
  EXPECT_NEAR(a.ate_rmse_m, 0.0, 1e-9);
  EXPECT_EQ(a.lengths_m, SubPathLengths(60));
}

// Every estimated step 10 % too long: each sub-path of L true metres is estimated as 1.1 L
// straight ahead, so the relative error is 0.1 L in translation, 10 % of L, and nothing in
// rotation, on every one of the 51 + 41 + 31 + 21 + 11 + 1 = 156 sub-paths.
TEST(TrajectoryAccuracyTest, ScaleErrorOfTenPercentIsTenPercentDrift) {
  const std::vector<Se3> truth = Drive(60);
  std::vector<Se3> estimated = truth;
  for (Se3& pose : estimated) pose.translation() *= 1.1;
  const std::vector<double> lengths = SubPathLengths(60);
  const TrajectoryAccuracy a = MeasureTrajectory(estimated, truth, lengths);
  EXPECT_EQ(a.sub_paths, 156);
  EXPECT_EQ(a.sub_paths, StraightSubPaths(60, lengths));
  EXPECT_NEAR(a.translational_drift_percent, 10.0, 1e-9);
  EXPECT_NEAR(a.rotational_drift_deg_per_m, 0.0, 1e-12);
  EXPECT_NEAR(a.truth_length_m, 60.0, 1e-12);
  // Stereo measures scale, so the alignment may not absorb it: positions 0..60 m against
  // 0..66 m, after the best rigid shift (the centroids, 30 and 33 m, laid on each other) are off
  // by 0.1 |z - 30| at true z, RMS 0.1 sqrt(mean((z - 30)^2)) over z = 0..60.
  double squares = 0;
  for (int z = 0; z <= 60; ++z) squares += (0.1 * (z - 30)) * (0.1 * (z - 30));
  EXPECT_NEAR(a.ate_rmse_m, std::sqrt(squares / 61), 1e-9);
}

// The estimate turns by e after each metre where the truth goes straight: over L metres its
// heading is off by L e, so the rotational drift is e per metre whatever the sub-path.
TEST(TrajectoryAccuracyTest, HeadingErrorPerMetreIsTheRotationalDrift) {
  const double e_deg_per_m = 0.02;
  const std::vector<Se3> truth = Drive(60);
  const std::vector<Se3> estimated = Drive(60, e_deg_per_m * kDegree);
  const TrajectoryAccuracy a = MeasureTrajectory(estimated, truth, SubPathLengths(60));
  EXPECT_EQ(a.sub_paths, 156);
  EXPECT_NEAR(a.rotational_drift_deg_per_m, e_deg_per_m, 1e-9);
  // The curved estimate also ends off to the side: some translational drift, small.
  EXPECT_GT(a.translational_drift_percent, 0.0);
  EXPECT_LT(a.translational_drift_percent, 1.0);
  EXPECT_GT(a.ate_rmse_m, 0.0);
}

// A whole estimate moved by one rigid motion (as VO would give in another start frame) has the
// same relative motions, so the same drift, and the alignment takes the motion out of the ATE.
TEST(TrajectoryAccuracyTest, RigidlyMovedEstimateIsAlignedAndDriftIsUnchanged) {
  const Se3 moved = Translation(4.0, -2.0, 7.5) *
                    Se3(Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  // On a curved drive, so the alignment has one answer (a straight line could spin about
  // itself).
  const std::vector<Se3> truth = Drive(60, 1.5 * kDegree);
  const std::vector<double> lengths = SubPathLengths(60);

  std::vector<Se3> moved_truth;
  for (const Se3& pose : truth) moved_truth.push_back(moved * pose);
  TrajectoryAccuracy a = MeasureTrajectory(moved_truth, truth, lengths);
  EXPECT_NEAR(a.ate_rmse_m, 0.0, 1e-9);
  EXPECT_NEAR(a.translational_drift_percent, 0.0, 1e-9);
  EXPECT_NEAR(a.rotational_drift_deg_per_m, 0.0, 1e-9);

  // An estimate with real errors (10 % scale, a heading error) keeps its figures when moved.
  std::vector<Se3> estimated = Drive(60, 1.6 * kDegree);
  for (Se3& pose : estimated) pose.translation() *= 1.1;
  const TrajectoryAccuracy where_it_was = MeasureTrajectory(estimated, truth, lengths);
  std::vector<Se3> moved_estimate;
  for (const Se3& pose : estimated) moved_estimate.push_back(moved * pose);
  a = MeasureTrajectory(moved_estimate, truth, lengths);
  EXPECT_GT(where_it_was.translational_drift_percent, 5.0);
  EXPECT_EQ(a.sub_paths, where_it_was.sub_paths);
  EXPECT_NEAR(a.translational_drift_percent, where_it_was.translational_drift_percent, 1e-9);
  EXPECT_NEAR(a.rotational_drift_deg_per_m, where_it_was.rotational_drift_deg_per_m, 1e-9);
  EXPECT_NEAR(a.ate_rmse_m, where_it_was.ate_rmse_m, 1e-9);
}

TEST(TrajectoryAccuracyTest, PathShorterThanEveryLengthHasNoSubPaths) {
  const std::vector<Se3> truth = Drive(5);
  std::vector<Se3> estimated = truth;
  for (Se3& pose : estimated) pose.translation() *= 1.1;
  const std::vector<double> lengths = SubPathLengths(5);
  ASSERT_TRUE(lengths.empty());
  TrajectoryAccuracy a = MeasureTrajectory(estimated, truth, lengths);
  EXPECT_EQ(a.sub_paths, 0);
  EXPECT_EQ(a.translational_drift_percent, 0.0);
  EXPECT_EQ(a.rotational_drift_deg_per_m, 0.0);
  EXPECT_NEAR(a.truth_length_m, 5.0, 1e-12);
  EXPECT_GT(a.ate_rmse_m, 0.0) << "the ATE needs no sub-paths";
  // A length longer than the path is no sub-path either.
  a = MeasureTrajectory(estimated, truth, {10.0});
  EXPECT_EQ(a.sub_paths, 0);
  EXPECT_EQ(a.translational_drift_percent, 0.0);
}

TEST(TrajectoryAccuracyTest, FewerThanTwoFramesMeasureNothing) {
  for (const std::size_t n : {0u, 1u}) {
    const std::vector<Se3> poses(n, Translation(1, 2, 3));
    const TrajectoryAccuracy a = MeasureTrajectory(poses, poses, {10.0});
    EXPECT_EQ(a.sub_paths, 0);
    EXPECT_EQ(a.ate_rmse_m, 0.0);
    EXPECT_EQ(a.truth_length_m, 0.0);
  }
}

TEST(TrajectoryAccuracyTest, DifferentNumbersOfPosesAreRefused) {
  const std::vector<Se3> truth = Drive(20);
  const std::vector<Se3> estimated = Drive(19);
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { MeasureTrajectory(estimated, truth, SubPathLengths(20)); });
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { MeasureTrajectory(truth, estimated, SubPathLengths(20)); });
}

}  // namespace
}  // namespace fleetmap

namespace fleetmap {
namespace {

// A drive of kilometres is measured as KITTI measures its sequences: 100, 200, ..., 800 m.
TEST(TrajectoryAccuracyTest, LongDrivesUseKittisOwnLengths) {
  EXPECT_EQ(SubPathLengths(800), (std::vector<double>{100, 200, 300, 400, 500, 600, 700, 800}));
  EXPECT_EQ(SubPathLengths(3700), SubPathLengths(800));
  EXPECT_EQ(SubPathLengths(799).size(), 79u);
}

// The lengths may come in any order, and a drive of thousands of frames is measured in one
// forward scan per start frame (a 4000-frame drive here, as long as KITTI's sequence 00).
TEST(TrajectoryAccuracyTest, ThousandsOfFramesAndUnsortedLengths) {
  std::vector<Se3> truth, scaled;
  for (int i = 0; i <= 4000; ++i) {
    Se3 t = Se3::Identity();
    t.translation() = Eigen::Vector3d(0, 0, i);
    truth.push_back(t);
    t.translation() *= 1.1;
    scaled.push_back(t);
  }
  const std::vector<double> lengths = SubPathLengths(4000);
  std::vector<double> reversed(lengths.rbegin(), lengths.rend());
  const TrajectoryAccuracy a = MeasureTrajectory(scaled, truth, reversed);
  const TrajectoryAccuracy b = MeasureTrajectory(scaled, truth, lengths);
  EXPECT_NEAR(a.translational_drift_percent, 10.0, 1e-9);
  EXPECT_EQ(a.sub_paths, b.sub_paths);
  EXPECT_EQ(a.sub_paths, StraightSubPaths(4000, lengths));
}

}  // namespace
}  // namespace fleetmap
