#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "fleetmap/core/se3.h"

namespace fleetmap {
namespace {

Se3 Pose(double yaw, double pitch, const Eigen::Vector3d& t) {
  Se3 pose = Se3::Identity();
  pose.linear() = (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY()) *
                   Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()))
                      .toRotationMatrix();
  pose.translation() = t;
  return pose;
}

// exp of (omega, v) as the left perturbation the header defines (first order is all the
// covariance claims; the tests perturb by small steps).
Se3 Exp(const Eigen::Matrix<double, 6, 1>& xi) {
  Se3 step = Se3::Identity();
  const Eigen::Vector3d omega = xi.head<3>();
  if (omega.norm() > 0) {
    step.linear() = Eigen::AngleAxisd(omega.norm(), omega.normalized()).toRotationMatrix();
  }
  step.translation() = xi.tail<3>();
  return step;
}

// A random SPD covariance of small poses.
PoseCovariance RandomCovariance(std::mt19937& rng, double scale) {
  std::normal_distribution<double> n(0.0, scale);
  Eigen::Matrix<double, 6, 6> a;
  for (int i = 0; i < 36; ++i) a(i / 6, i % 6) = n(rng);
  return a * a.transpose() + 1e-6 * scale * scale * PoseCovariance::Identity();
}

TEST(PoseCovariance, SkewIsTheCrossProduct) {
  const Eigen::Vector3d w(0.3, -1.2, 2.0), x(-0.7, 0.4, 1.1);
  EXPECT_TRUE((Skew(w) * x).isApprox(w.cross(x), 1e-15));
  EXPECT_TRUE((Skew(w) + Skew(w).transpose()).isZero());
}

TEST(PoseCovariance, AdjointMovesAPerturbationFromTheRightToTheLeft) {
  const Se3 a_T_b = Pose(0.4, -0.2, {1.0, -2.0, 3.0});
  Eigen::Matrix<double, 6, 1> xi;
  xi << 1e-4, -2e-4, 3e-4, 1e-3, 2e-3, -1e-3;
  const Se3 right = a_T_b * Exp(xi);
  const Se3 left = Exp(Adjoint(a_T_b) * xi) * a_T_b;
  EXPECT_LT((right.matrix() - left.matrix()).cwiseAbs().maxCoeff(), 1e-6);
}

// Monte Carlo: compose two noisy poses many times and compare the spread of the result's
// position with the first-order prediction.
TEST(PoseCovariance, ComposedPositionSpreadMatchesAMonteCarloDraw) {
  std::mt19937 rng(7);
  const Se3 a_T_b = Pose(0.3, 0.1, {5.0, 0.0, 2.0});
  const Se3 b_T_c = Pose(-0.5, 0.0, {3.0, 1.0, 0.0});
  const PoseCovariance ab = RandomCovariance(rng, 0.01), bc = RandomCovariance(rng, 0.01);
  const Eigen::LLT<PoseCovariance> lab(ab), lbc(bc);
  std::normal_distribution<double> n(0.0, 1.0);
  const auto draw = [&](const Eigen::LLT<PoseCovariance>& l) {
    Eigen::Matrix<double, 6, 1> z;
    for (int i = 0; i < 6; ++i) z(i) = n(rng);
    return Exp(Eigen::Matrix<double, 6, 1>(l.matrixL() * z));
  };
  const Se3 a_T_c = a_T_b * b_T_c;
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  constexpr int kDraws = 20000;
  for (int i = 0; i < kDraws; ++i) {
    const Se3 noisy = draw(lab) * a_T_b * draw(lbc) * b_T_c;
    const Eigen::Vector3d d = noisy.translation() - a_T_c.translation();
    spread += d * d.transpose();
  }
  spread /= kDraws;
  const Eigen::Matrix3d predicted = PositionCovariance(a_T_c, ComposeCovariance(a_T_b, ab, bc));
  EXPECT_LT((spread - predicted).norm() / predicted.norm(), 0.05) << "drawn\n"
                                                                  << spread << "\npredicted\n"
                                                                  << predicted;
  // Without the second pose's noise the prediction is visibly wrong: the test can fail.
  const Eigen::Matrix3d without =
      PositionCovariance(a_T_c, ComposeCovariance(a_T_b, ab, PoseCovariance::Zero()));
  EXPECT_GT((spread - without).norm() / predicted.norm(), 0.2);
}

TEST(PoseCovariance, InverseOfAnInverseIsTheOriginal) {
  std::mt19937 rng(3);
  const Se3 a_T_b = Pose(1.0, 0.3, {-1.0, 4.0, 0.5});
  const PoseCovariance ab = RandomCovariance(rng, 0.1);
  const PoseCovariance back = InverseCovariance(a_T_b.inverse(), InverseCovariance(a_T_b, ab));
  EXPECT_LT((back - ab).cwiseAbs().maxCoeff(), 1e-12);
}

TEST(PoseCovariance, PositionSigmaGrowsWithTheLeverOfARotationError) {
  PoseCovariance yaw_only = PoseCovariance::Zero();
  yaw_only(1, 1) = 0.01 * 0.01;  // 0.01 rad about the camera's y axis
  const double near = PositionSigma(Pose(0, 0, {0, 0, 1}), yaw_only);
  const double far = PositionSigma(Pose(0, 0, {0, 0, 20}), yaw_only);
  EXPECT_NEAR(near, 0.01, 1e-9);
  EXPECT_NEAR(far, 0.20, 1e-9);
}

TEST(PoseCovariance, OdometryGrowsWithDistanceAndIsZeroStanding) {
  const OdometryNoise noise{.translation_fraction = 0.02, .rotation_rad_per_m = 0.001};
  EXPECT_EQ(OdometryCovariance(0.0, noise), PoseCovariance::Zero());
  EXPECT_EQ(OdometryCovariance(-1.0, noise), PoseCovariance::Zero());
  const PoseCovariance ten = OdometryCovariance(10.0, noise);
  EXPECT_NEAR(std::sqrt(ten(3, 3)), 0.2, 1e-12);
  EXPECT_NEAR(std::sqrt(ten(0, 0)), 0.01, 1e-12);
  EXPECT_GT(OdometryCovariance(20.0, noise).trace(), ten.trace());
}

TEST(PoseCovariance, ValidityRefusesWhatAStoreMustNotKeep) {
  std::mt19937 rng(5);
  const PoseCovariance good = RandomCovariance(rng, 0.1);
  EXPECT_TRUE(IsValidPoseCovariance(good));
  EXPECT_TRUE(IsValidPoseCovariance(PoseCovariance::Zero()));
  PoseCovariance nan = good;
  nan(2, 3) = std::nan("");
  EXPECT_FALSE(IsValidPoseCovariance(nan));
  PoseCovariance skew = good;
  skew(0, 5) += 1.0;
  EXPECT_FALSE(IsValidPoseCovariance(skew));
  EXPECT_FALSE(IsValidPoseCovariance(-good));
}

}  // namespace
}  // namespace fleetmap
