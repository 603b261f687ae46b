#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

#include "fleetmap/core/se3.h"

namespace fleetmap {

Eigen::Matrix3d Skew(const Eigen::Vector3d& w) {
  Eigen::Matrix3d s;
  s << 0, -w.z(), w.y(), w.z(), 0, -w.x(), -w.y(), w.x(), 0;
  return s;
}

Eigen::Matrix<double, 6, 6> Adjoint(const Se3& a_T_b) {
  // a_T_b exp(omega, v) a_T_b^-1 = exp(R omega, R v + t x R omega).
  const Eigen::Matrix3d r = a_T_b.linear();
  Eigen::Matrix<double, 6, 6> adjoint = Eigen::Matrix<double, 6, 6>::Zero();
  adjoint.topLeftCorner<3, 3>() = r;
  adjoint.bottomLeftCorner<3, 3>() = Skew(a_T_b.translation()) * r;
  adjoint.bottomRightCorner<3, 3>() = r;
  return adjoint;
}

PoseCovariance ComposeCovariance(const Se3& a_T_b, const PoseCovariance& ab,
                                 const PoseCovariance& bc) {
  const Eigen::Matrix<double, 6, 6> adjoint = Adjoint(a_T_b);
  return ab + adjoint * bc * adjoint.transpose();
}

PoseCovariance InverseCovariance(const Se3& a_T_b, const PoseCovariance& ab) {
  // b_T_a_true = b_T_a exp(-xi) = exp(-Ad(b_T_a) xi) b_T_a.
  const Eigen::Matrix<double, 6, 6> adjoint = Adjoint(a_T_b.inverse());
  return adjoint * ab * adjoint.transpose();
}

Eigen::Matrix3d PositionCovariance(const Se3& a_T_b, const PoseCovariance& ab) {
  // exp(omega, v) moves b's position t to t + v + omega x t = t + v - [t]x omega.
  Eigen::Matrix<double, 3, 6> j;
  j << -Skew(a_T_b.translation()), Eigen::Matrix3d::Identity();
  return j * ab * j.transpose();
}

double PositionSigma(const Se3& a_T_b, const PoseCovariance& ab) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(PositionCovariance(a_T_b, ab),
                                                              Eigen::EigenvaluesOnly);
  return std::sqrt(std::max(0.0, solver.eigenvalues().maxCoeff()));
}

PoseCovariance OdometryCovariance(double distance_m, const OdometryNoise& noise) {
  const double d = std::max(0.0, distance_m);
  const double rotation = noise.rotation_rad_per_m * d,
               translation = noise.translation_fraction * d;
  PoseCovariance covariance = PoseCovariance::Zero();
  covariance.diagonal() << rotation * rotation, rotation * rotation, rotation * rotation,
      translation * translation, translation * translation, translation * translation;
  return covariance;
}

bool IsValidPoseCovariance(const PoseCovariance& covariance) {
  if (!covariance.allFinite()) return false;
  if (!covariance.isApprox(covariance.transpose(), 1e-9) &&
      (covariance - covariance.transpose()).cwiseAbs().maxCoeff() > 1e-12) {
    return false;
  }
  const Eigen::SelfAdjointEigenSolver<PoseCovariance> solver(covariance, Eigen::EigenvaluesOnly);
  return solver.eigenvalues().minCoeff() >= -1e-12 * std::max(1.0, covariance.norm());
}

}  // namespace fleetmap
