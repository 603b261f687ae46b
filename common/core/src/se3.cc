#include "fleetmap/core/se3.h"

#include <cmath>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

Se3 Se3FromTranslationQuaternion(const Eigen::Vector3d& translation_m,
                                 const Eigen::Quaterniond& rotation) {
  const double norm = rotation.norm();
  // Stored quaternions are unit to double precision; anything far off is not a rotation.
  if (!std::isfinite(norm) || std::abs(norm - 1.0) > 1e-6) {
    throw Error(ErrorCode::kInvalidArgument,
                "quaternion is not unit (norm " + std::to_string(norm) + ")");
  }
  if (!translation_m.allFinite()) {
    throw Error(ErrorCode::kInvalidArgument, "translation is not finite");
  }
  Se3 a_T_b = Se3::Identity();
  a_T_b.linear() = rotation.normalized().toRotationMatrix();
  a_T_b.translation() = translation_m;
  return a_T_b;
}

Eigen::Quaterniond RotationQuaternion(const Se3& a_T_b) {
  Eigen::Quaterniond q(a_T_b.rotation());
  q.normalize();
  if (q.w() < 0) q.coeffs() = -q.coeffs();
  return q;
}

double RotationAngle(const Se3& a_T_b) {
  return Eigen::AngleAxisd(a_T_b.rotation()).angle();
}

bool Se3ApproxEqual(const Se3& a, const Se3& b, double tolerance_m, double tolerance_rad) {
  const Se3 a_T_b = a.inverse() * b;
  return (a.translation() - b.translation()).norm() <= tolerance_m &&
         RotationAngle(a_T_b) <= tolerance_rad;
}

}  // namespace fleetmap
