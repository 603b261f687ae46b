// A stereo calibration from two sensor_msgs/CameraInfo (camera_info_calibration.h).
#include "camera_info_calibration.h"

#include <Eigen/Core>
#include <cmath>

namespace fleetmap::internal {
namespace {

Eigen::Matrix3d Matrix(const std::array<double, 9>& row_major) {
  Eigen::Matrix3d m;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) m(r, c) = row_major[static_cast<std::size_t>(3 * r + c)];
  }
  return m;
}

// One camera's intrinsics, or the reason it has none we can keep.
std::optional<PinholeCamera> Intrinsics(const RosCameraInfo& info, const std::string& side,
                                        int width_px, int height_px, std::string& why_not) {
  const auto fail = [&](const std::string& why) {
    why_not = "the " + side + " camera_info " + why;
    return std::nullopt;
  };
  if (info.k[0] <= 0 || info.k[4] <= 0) return fail("has no intrinsics (K is zero: uncalibrated)");
  if (info.binning_x > 1 || info.binning_y > 1) return fail("has binning, which is not kept");
  const bool full_roi = (info.roi_width == 0 && info.roi_height == 0) ||
                        (info.roi_x_offset == 0 && info.roi_y_offset == 0 &&
                         info.roi_width == info.width && info.roi_height == info.height);
  if (!full_roi) return fail("has a region of interest, which is not kept");
  if (static_cast<int>(info.width) != width_px || static_cast<int>(info.height) != height_px) {
    return fail("is for " + std::to_string(info.width) + "x" + std::to_string(info.height) +
                " images but the images are " + std::to_string(width_px) + "x" +
                std::to_string(height_px));
  }
  PinholeCamera camera;
  camera.width_px = width_px;
  camera.height_px = height_px;
  camera.fx = info.k[0];
  camera.fy = info.k[4];
  camera.cx = info.k[2];
  camera.cy = info.k[5];
  const bool plumb_bob =
      info.distortion_model == "plumb_bob" || (info.distortion_model.empty() && info.d.empty());
  if (!plumb_bob || (info.d.size() != 0 && info.d.size() != 4 && info.d.size() != 5)) {
    return fail("has distortion model '" + info.distortion_model + "' with " +
                std::to_string(info.d.size()) +
                " coefficients; only plumb_bob (4 or 5: k1, k2, p1, p2, k3) is kept");
  }
  for (std::size_t i = 0; i < info.d.size(); ++i) camera.distortion[i] = info.d[i];
  return camera;
}

bool IsRotation(const Eigen::Matrix3d& r) {
  return (r * r.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() < 1e-6 &&
         std::abs(r.determinant() - 1.0) < 1e-6;
}

}  // namespace

std::optional<RosStereoCalibration> StereoCalibrationFromCameraInfo(const RosCameraInfo& left,
                                                                    const RosCameraInfo& right,
                                                                    int width_px, int height_px,
                                                                    const std::string& name,
                                                                    std::string& why_not) {
  std::optional<PinholeCamera> left_camera = Intrinsics(left, "left", width_px, height_px, why_not);
  if (!left_camera) return std::nullopt;
  std::optional<PinholeCamera> right_camera =
      Intrinsics(right, "right", width_px, height_px, why_not);
  if (!right_camera) return std::nullopt;
  const Eigen::Matrix3d rect_R_left = Matrix(left.r);
  const Eigen::Matrix3d rect_R_right = Matrix(right.r);
  if (!IsRotation(rect_R_left) || !IsRotation(rect_R_right)) {
    why_not = "a camera_info's R is not a rotation (a stereo calibration gives both cameras one)";
    return std::nullopt;
  }
  if (left.p[3] != 0) {
    why_not = "the left camera_info's P[0][3] is not 0: it is not the first camera of the pair";
    return std::nullopt;
  }
  if (right.p[0] <= 0) {
    why_not = "the right camera_info has no projection (P[0][0] is not positive)";
    return std::nullopt;
  }
  const double baseline_m = -right.p[3] / right.p[0];
  if (!(baseline_m > 0)) {
    why_not = "the right camera_info's P gives a baseline of " + std::to_string(baseline_m) +
              " m; the right camera must lie to the right of the left (P[0][3] = -fx' * B < 0)";
    return std::nullopt;
  }
  RosStereoCalibration rig;
  rig.left = *left_camera;
  rig.right = *right_camera;
  rig.left.name = name + "/cam0";
  rig.right.name = name + "/cam1";
  rig.left.body_T_sensor = Eigen::Isometry3d::Identity();
  rig.right.body_T_sensor = Eigen::Isometry3d::Identity();
  rig.right.body_T_sensor.linear() = rect_R_left.transpose() * rect_R_right;
  rig.right.body_T_sensor.translation() =
      rect_R_left.transpose() * Eigen::Vector3d(baseline_m, 0, 0);
  rig.baseline_m = baseline_m;
  return rig;
}

}  // namespace fleetmap::internal
