// SE(3) helpers on Eigen, and the uncertainty of a pose.
//
// Conventions (as Sophus and Ceres):
// - A pose is an Eigen::Isometry3d named a_T_b: it maps points expressed in frame b into
//   frame a (p_a = a_T_b * p_b). Composition reads right to left: a_T_c = a_T_b * b_T_c.
// - Translation in metres. Quaternions are Hamilton, unit norm, stored w, x, y, z.
// - An edge's pose is from_T_to: the pose of the `to` node in the frame of the `from` node.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace fleetmap {

using Se3 = Eigen::Isometry3d;

// Builds a_T_b from a translation and a quaternion (w, x, y, z).
// REQUIRES: |q| within 1e-6 of 1 after normalisation of rounding; a quaternion whose norm is
// far from 1 (or zero) is a caller bug and throws Error(kInvalidArgument).
Se3 Se3FromTranslationQuaternion(const Eigen::Vector3d& translation_m,
                                 const Eigen::Quaterniond& rotation);

// Unit quaternion of a pose, w >= 0 (one canonical sign, so equal poses compare equal).
Eigen::Quaterniond RotationQuaternion(const Se3& a_T_b);

// Rotation angle of a pose in radians, in [0, pi].
double RotationAngle(const Se3& a_T_b);

// True when translations differ by at most tolerance_m and rotations by at most
// tolerance_rad.
bool Se3ApproxEqual(const Se3& a, const Se3& b, double tolerance_m = 1e-9,
                    double tolerance_rad = 1e-9);

// The uncertainty of a relative pose, and how it composes along a chain of poses.
//
// Convention (the localiser's Gauss-Newton uses the same, stereo_reprojection.h): the true pose
// is the estimate perturbed on the left, a_T_b_true = exp(xi) * a_T_b, with xi = (omega, v), a
// rotation vector in radians and a translation in metres, both in a's frame. A PoseCovariance
// is the 6 x 6 covariance of xi in that order.
//
// Composing a_T_c = a_T_b * b_T_c moves b's perturbation into a's frame by the adjoint of a_T_b,
// so to first order Σ_ac = Σ_ab + Ad(a_T_b) Σ_bc Ad(a_T_b)^T (Barfoot, "State Estimation for
// Robotics", §7.3.3).

using PoseCovariance = Eigen::Matrix<double, 6, 6>;

// The matrix of the cross product: Skew(w) * x = w.cross(x).
Eigen::Matrix3d Skew(const Eigen::Vector3d& w);

// The adjoint of a_T_b on (omega, v): exp(Ad xi) a_T_b = a_T_b exp(xi).
Eigen::Matrix<double, 6, 6> Adjoint(const Se3& a_T_b);

// Σ of a_T_c = a_T_b * b_T_c from Σ of a_T_b and Σ of b_T_c, the two independent.
PoseCovariance ComposeCovariance(const Se3& a_T_b, const PoseCovariance& ab,
                                 const PoseCovariance& bc);

// Σ of b_T_a from Σ of a_T_b.
PoseCovariance InverseCovariance(const Se3& a_T_b, const PoseCovariance& ab);

// The covariance of b's position in a's frame (metres^2).
Eigen::Matrix3d PositionCovariance(const Se3& a_T_b, const PoseCovariance& ab);

// The standard deviation of b's position along its least certain direction, in metres: the
// square root of PositionCovariance's largest eigenvalue.
double PositionSigma(const Se3& a_T_b, const PoseCovariance& ab);

// How visual odometry's error grows with the distance it runs: per metre travelled, a
// translation error of translation_fraction of the metre on each axis and a rotation error of
// rotation_rad_per_m about each axis, one standard deviation.
struct OdometryNoise {
  double translation_fraction = 0.02;
  double rotation_rad_per_m = 0.002;
};

// Σ of a pose odometry composed over `distance_m`: taken as one step of that length, which
// bounds a random walk of shorter steps from above (its standard deviation grows with the
// distance, not its square root).
PoseCovariance OdometryCovariance(double distance_m, const OdometryNoise& noise);

// True when `covariance` is a symmetric positive semi-definite matrix of finite numbers (what
// a store accepts).
bool IsValidPoseCovariance(const PoseCovariance& covariance);

}  // namespace fleetmap
