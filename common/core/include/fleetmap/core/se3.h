// SE(3) helpers on Eigen.
//
// Conventions (as Sophus and Ceres):
// - A pose is an Eigen::Isometry3d named a_T_b: it maps points expressed in frame b into
//   frame a (p_a = a_T_b * p_b). Composition reads right to left: a_T_c = a_T_b * b_T_c.
// - Translation in metres. Quaternions are Hamilton, unit norm, stored w, x, y, z.
// - An edge's pose is from_T_to: the pose of the `to` node in the frame of the `from` node.
#pragma once

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

}  // namespace fleetmap
