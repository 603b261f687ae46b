#include "fleetmap/core/se3.h"

#include <gtest/gtest.h>

#include <cmath>

#include "fleetmap/core/error.h"
#include "fleetmap/core/proto_convert.h"

namespace fleetmap {
namespace {

Se3 Pose(double x, double y, double z, double yaw_rad) {
  return Se3FromTranslationQuaternion(
      Eigen::Vector3d(x, y, z),
      Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ())));
}

TEST(Se3, CompositionReadsRightToLeft) {
  const Se3 world_T_robot = Pose(10, 0, 0, M_PI / 2);
  const Se3 robot_T_camera = Pose(1, 0, 0, 0);
  const Se3 world_T_camera = world_T_robot * robot_T_camera;
  // The camera sits 1 m ahead of the robot, which faces +y in the world.
  EXPECT_NEAR(world_T_camera.translation().x(), 10.0, 1e-12);
  EXPECT_NEAR(world_T_camera.translation().y(), 1.0, 1e-12);
  const Eigen::Vector3d p_camera(0, 0, 0);
  EXPECT_TRUE((world_T_camera * p_camera).isApprox(Eigen::Vector3d(10, 1, 0), 1e-12));
  EXPECT_TRUE(Se3ApproxEqual(world_T_camera.inverse() * world_T_camera, Se3::Identity()));
}

TEST(Se3, RejectsNonUnitQuaternion) {
  EXPECT_THROW(
      Se3FromTranslationQuaternion(Eigen::Vector3d::Zero(), Eigen::Quaterniond(2, 0, 0, 0)), Error);
  EXPECT_THROW(
      Se3FromTranslationQuaternion(Eigen::Vector3d::Zero(), Eigen::Quaterniond(0, 0, 0, 0)), Error);
  EXPECT_THROW(
      Se3FromTranslationQuaternion(Eigen::Vector3d(NAN, 0, 0), Eigen::Quaterniond::Identity()),
      Error);
}

TEST(Se3, QuaternionHasCanonicalSign) {
  const Se3 a_T_b = Pose(0, 0, 0, 3.0);
  const Eigen::Quaterniond q = RotationQuaternion(a_T_b);
  EXPECT_GE(q.w(), 0.0);
  EXPECT_NEAR(q.norm(), 1.0, 1e-12);
  EXPECT_NEAR(RotationAngle(a_T_b), 3.0, 1e-12);
}

TEST(Se3, ProtoRoundTripIsWithinTolerance) {
  const Se3 a_T_b = Pose(1.5, -2.25, 0.125, 0.7) * Pose(0, 0, 0, 0.1);
  const Se3 back = FromProto(ToProto(a_T_b));
  EXPECT_TRUE(Se3ApproxEqual(a_T_b, back, 1e-12, 1e-12));
  EXPECT_FALSE(Se3ApproxEqual(a_T_b, Pose(1.5, -2.25, 0.125, 0.81), 1e-6, 1e-6));
}

}  // namespace
}  // namespace fleetmap
