// A calibrated stereo camera and its rectification: the first step of the real-image front end
// (docs/ebn-core.md; seed 002 §III-A's stereo VO needs rectified pairs to triangulate).
//
// Conventions:
// - Camera frames as in OpenCV: x right, y down, z forward (the optical axis), metres.
// - body_T_sensor is EuRoC's T_BS: p_body = body_T_sensor * p_sensor.
// - Distortion is radial-tangential (OpenCV's plumb_bob) in OpenCV's order (k1, k2, p1, p2, k3);
//   k3 is 0 for a four-term calibration (EuRoC's yaml files give four, KITTI's D_0x five).
// - Pixels: (0, 0) is the centre of the top-left pixel.
// - Rectification (OpenCV stereoRectify, zero disparity at infinity, no scaling alpha = 0)
//   rotates both cameras about their centres so their image rows line up; a point p_left in the
//   left camera's own frame is rect_R_left * p_left in the rectified left frame, where a pixel
//   (u, v) with disparity d = u_left - u_right > 0 lies at depth z = focal_px * baseline_m / d.
#pragma once

#include <Eigen/Geometry>
#include <array>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>

namespace fleetmap {

struct PinholeCamera {
  std::string name;  // the yaml's `comment`, else its file name
  int width_px = 0;
  int height_px = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;  // pixels
  std::array<double, 5> distortion{};     // k1, k2, p1, p2, k3
  Eigen::Isometry3d body_T_sensor = Eigen::Isometry3d::Identity();
  double rate_hz = 0;  // 0 when the file does not say
};

// Reads a EuRoC camera `sensor.yaml` (%YAML:1.0: T_BS as rows/cols/data, resolution,
// camera_model pinhole, intrinsics [fu, fv, cu, cv], distortion_model radial-tangential,
// distortion_coefficients: four (k1, k2, p1, p2; k3 = 0) or five (k1, k2, p1, p2, k3)).
// Throws Error(kNotFound) for a missing file and Error(kInvalidArgument) naming the file and
// the field for anything missing, of the wrong size, or unsupported (another camera or
// distortion model, a T_BS that is not rigid).
PinholeCamera LoadEurocCamera(const std::filesystem::path& sensor_yaml);

// Writes `camera` as a EuRoC camera `sensor.yaml` (the fields LoadEurocCamera reads, through
// OpenCV's FileStorage; distortion with all five terms), so a calibration that came from another
// dataset's files (KITTI's calib.txt) reads back like a EuRoC one. Overwrites `sensor_yaml`.
// Throws Error(kBackend) naming the file when it cannot be written.
void WriteEurocCamera(const PinholeCamera& camera, const std::filesystem::path& sensor_yaml);

// Throws Error(kInvalidArgument) unless `image` is single-channel 8-bit of width_px x height_px,
// saying what it is instead; `what` names the image ("left image").
void RequireMonoImage(const cv::Mat& image, const std::string& what, int width_px, int height_px);

// What the triangulation needs of a rectified pair.
struct RectifiedStereoGeometry {
  int width_px = 0, height_px = 0;
  double focal_px = 0;          // both rectified cameras, both axes
  double cx_px = 0, cy_px = 0;  // both rectified cameras (CALIB_ZERO_DISPARITY)
  double baseline_m = 0;  // the right camera's centre lies at (+baseline_m, 0, 0) in rectified left
  Eigen::Matrix3d rect_R_left = Eigen::Matrix3d::Identity();
};

// Immutable once built; Rectify is safe from many threads.
class StereoRectifier {
 public:
  // REQUIRES: both cameras of one size; the right camera's centre to the right of the left's
  // (a horizontal rig). Throws Error(kInvalidArgument) otherwise.
  StereoRectifier(const PinholeCamera& left, const PinholeCamera& right);

  const RectifiedStereoGeometry& geometry() const { return geometry_; }

  // Undistorts and rectifies a raw pair (bilinear). REQUIRES: both images single-channel 8-bit of
  // the calibrated size, else Error(kInvalidArgument) saying which and what size.
  void Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_rect,
               cv::Mat& right_rect) const;

  // Where a raw pixel of each camera lands in its rectified image (for tests and overlays).
  Eigen::Vector2d RectifyLeftPixel(const Eigen::Vector2d& raw_px) const;
  Eigen::Vector2d RectifyRightPixel(const Eigen::Vector2d& raw_px) const;

 private:
  PinholeCamera left_, right_;
  RectifiedStereoGeometry geometry_;
  cv::Mat left_R_, left_P_, right_R_, right_P_;  // stereoRectify's R1, P1, R2, P2
  cv::Mat left_map_x_, left_map_y_, right_map_x_, right_map_y_;
};

}  // namespace fleetmap
