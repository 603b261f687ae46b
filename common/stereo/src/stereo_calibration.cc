// EuRoC calibration files and OpenCV's stereo rectification (stereo_calibration.h).
#include "fleetmap/stereo/stereo_calibration.h"

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

[[noreturn]] void Malformed(const std::filesystem::path& file, const std::string& field,
                            const std::string& what) {
  throw Error(ErrorCode::kInvalidArgument, file.string() + ": " + field + ": " + what);
}

// `expected` lists the sizes the field may have ("4" or "4 or 5").
std::vector<double> ReadNumbers(const cv::FileNode& node, const std::filesystem::path& file,
                                const std::string& field,
                                std::initializer_list<std::size_t> expected) {
  std::string sizes;
  for (const std::size_t n : expected) sizes += (sizes.empty() ? "" : " or ") + std::to_string(n);
  if (node.empty()) Malformed(file, field, "missing");
  if (!node.isSeq()) Malformed(file, field, "expected a list of " + sizes);
  std::vector<double> values;
  for (const cv::FileNode& item : node) {
    if (!item.isReal() && !item.isInt()) Malformed(file, field, "expected numbers");
    values.push_back(static_cast<double>(item));
  }
  if (std::find(expected.begin(), expected.end(), values.size()) == expected.end()) {
    Malformed(file, field, "expected " + sizes + " values, not " + std::to_string(values.size()));
  }
  return values;
}

std::string ReadString(const cv::FileNode& node, const std::filesystem::path& file,
                       const std::string& field) {
  if (node.empty() || !node.isString()) Malformed(file, field, "missing or not text");
  return static_cast<std::string>(node);
}

Eigen::Isometry3d ReadBodyTSensor(const cv::FileNode& node, const std::filesystem::path& file) {
  if (node.empty() || !node.isMap()) Malformed(file, "T_BS", "missing");
  const std::vector<double> data = ReadNumbers(node["data"], file, "T_BS.data", {16});
  Eigen::Matrix4d m;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) m(r, c) = data[static_cast<std::size_t>(4 * r + c)];
  }
  const Eigen::Matrix3d rotation = m.topLeftCorner<3, 3>();
  // The dataset prints rotations to 12 digits; 1e-6 allows for that and nothing sloppier.
  const double orthogonality =
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > 1e-6 || std::abs(rotation.determinant() - 1.0) > 1e-6 ||
      m.row(3) != Eigen::RowVector4d(0, 0, 0, 1)) {
    Malformed(file, "T_BS", "not a rigid transform");
  }
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  // Re-orthonormalise so later products stay rigid.
  pose.linear() = Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
  pose.translation() = m.topRightCorner<3, 1>();
  return pose;
}

cv::Mat Intrinsics(const PinholeCamera& camera) {
  return (cv::Mat_<double>(3, 3) << camera.fx, 0, camera.cx, 0, camera.fy, camera.cy, 0, 0, 1);
}

cv::Mat Distortion(const PinholeCamera& camera) {
  return (cv::Mat_<double>(1, 5) << camera.distortion[0], camera.distortion[1],
          camera.distortion[2], camera.distortion[3], camera.distortion[4]);
}

Eigen::Vector2d RectifyPixel(const PinholeCamera& camera, const cv::Mat& rect_R, const cv::Mat& P,
                             const Eigen::Vector2d& raw_px) {
  std::vector<cv::Point2d> in{{raw_px.x(), raw_px.y()}}, out;
  cv::undistortPoints(in, out, Intrinsics(camera), Distortion(camera), rect_R, P);
  return {out[0].x, out[0].y};
}

}  // namespace

void RequireMonoImage(const cv::Mat& image, const std::string& what, int width_px, int height_px) {
  if (image.empty() || image.type() != CV_8UC1 || image.cols != width_px ||
      image.rows != height_px) {
    throw Error(ErrorCode::kInvalidArgument,
                what + ": expected " + std::to_string(width_px) + "x" + std::to_string(height_px) +
                    " single-channel 8-bit, got " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows) + " with " + std::to_string(image.channels()) +
                    " channel(s) of " + std::to_string(image.elemSize1() * 8) + " bits");
  }
}

PinholeCamera LoadEurocCamera(const std::filesystem::path& sensor_yaml) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(sensor_yaml, ec)) {
    throw Error(ErrorCode::kNotFound, "camera calibration " + sensor_yaml.string() + " not found");
  }
  cv::FileStorage fs;
  try {
    fs.open(sensor_yaml.string(), cv::FileStorage::READ | cv::FileStorage::FORMAT_YAML);
  } catch (const cv::Exception& e) {
    throw Error(ErrorCode::kInvalidArgument,
                sensor_yaml.string() + ": not a readable YAML file: " + e.err);
  }
  if (!fs.isOpened()) {
    throw Error(ErrorCode::kInvalidArgument, sensor_yaml.string() + ": not a readable YAML file");
  }
  PinholeCamera camera;
  camera.name = fs["comment"].isString() ? static_cast<std::string>(fs["comment"])
                                         : sensor_yaml.filename().string();
  const std::string model = ReadString(fs["camera_model"], sensor_yaml, "camera_model");
  if (model != "pinhole") Malformed(sensor_yaml, "camera_model", "'" + model + "' unsupported");
  const std::string distortion_model =
      ReadString(fs["distortion_model"], sensor_yaml, "distortion_model");
  if (distortion_model != "radial-tangential") {
    Malformed(sensor_yaml, "distortion_model", "'" + distortion_model + "' unsupported");
  }
  const std::vector<double> resolution =
      ReadNumbers(fs["resolution"], sensor_yaml, "resolution", {2});
  camera.width_px = static_cast<int>(resolution[0]);
  camera.height_px = static_cast<int>(resolution[1]);
  if (camera.width_px <= 0 || camera.height_px <= 0) {
    Malformed(sensor_yaml, "resolution", "must be positive");
  }
  const std::vector<double> k = ReadNumbers(fs["intrinsics"], sensor_yaml, "intrinsics", {4});
  camera.fx = k[0];
  camera.fy = k[1];
  camera.cx = k[2];
  camera.cy = k[3];
  if (!(camera.fx > 0 && camera.fy > 0)) Malformed(sensor_yaml, "intrinsics", "focal <= 0");
  // EuRoC gives four terms; OpenCV (and KITTI's D_0x) give a fifth radial term, k3.
  const std::vector<double> d =
      ReadNumbers(fs["distortion_coefficients"], sensor_yaml, "distortion_coefficients", {4, 5});
  std::copy(d.begin(), d.end(), camera.distortion.begin());
  camera.body_T_sensor = ReadBodyTSensor(fs["T_BS"], sensor_yaml);
  if (fs["rate_hz"].isReal() || fs["rate_hz"].isInt()) {
    camera.rate_hz = static_cast<double>(fs["rate_hz"]);
  }
  return camera;
}

void WriteEurocCamera(const PinholeCamera& camera, const std::filesystem::path& sensor_yaml) {
  try {
    cv::FileStorage fs(sensor_yaml.string(), cv::FileStorage::WRITE | cv::FileStorage::FORMAT_YAML);
    if (!fs.isOpened()) {
      throw Error(ErrorCode::kBackend, "cannot write camera calibration " + sensor_yaml.string());
    }
    const auto list = [&fs](const std::string& key, const auto& values) {
      fs << key << "[:";
      for (const double v : values) fs << v;
      fs << "]";
    };
    fs << "sensor_type"
       << "camera";
    fs << "comment" << camera.name;
    // T_BS as EuRoC writes it: a map of cols, rows and the 16 numbers row-major.
    const Eigen::Matrix4d m = camera.body_T_sensor.matrix();
    std::vector<double> data;
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) data.push_back(m(r, c));
    }
    fs << "T_BS"
       << "{"
       << "cols" << 4 << "rows" << 4;
    list("data", data);
    fs << "}";
    fs << "rate_hz" << camera.rate_hz;
    fs << "resolution"
       << "[:" << camera.width_px << camera.height_px << "]";
    fs << "camera_model"
       << "pinhole";
    list("intrinsics", std::vector<double>{camera.fx, camera.fy, camera.cx, camera.cy});
    fs << "distortion_model"
       << "radial-tangential";
    list("distortion_coefficients", camera.distortion);
    fs.release();
  } catch (const cv::Exception& e) {
    throw Error(ErrorCode::kBackend,
                "cannot write camera calibration " + sensor_yaml.string() + ": " + e.err);
  }
}

StereoRectifier::StereoRectifier(const PinholeCamera& left, const PinholeCamera& right)
    : left_(left), right_(right) {
  if (left.width_px != right.width_px || left.height_px != right.height_px) {
    throw Error(ErrorCode::kInvalidArgument, "stereo cameras of different sizes");
  }
  // OpenCV wants the right camera's pose relative to the left: p_right = R p_left + T.
  const Eigen::Isometry3d right_T_left = right.body_T_sensor.inverse() * left.body_T_sensor;
  cv::Mat R, T;
  cv::eigen2cv(Eigen::Matrix3d(right_T_left.linear()), R);
  cv::eigen2cv(Eigen::Vector3d(right_T_left.translation()), T);
  // A horizontal rig: the right camera's centre lies at +x in the left camera's frame.
  const Eigen::Vector3d right_centre_in_left = right_T_left.inverse().translation();
  if (right_centre_in_left.x() <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "the right camera is not to the right of the left one (its centre at x = " +
                    std::to_string(right_centre_in_left.x()) + " m in the left camera)");
  }
  const cv::Size size(left.width_px, left.height_px);
  cv::Mat Q;
  cv::stereoRectify(Intrinsics(left), Distortion(left), Intrinsics(right), Distortion(right), size,
                    R, T, left_R_, right_R_, left_P_, right_P_, Q, cv::CALIB_ZERO_DISPARITY,
                    /*alpha=*/0, size);
  geometry_.width_px = left.width_px;
  geometry_.height_px = left.height_px;
  geometry_.focal_px = left_P_.at<double>(0, 0);
  geometry_.cx_px = left_P_.at<double>(0, 2);
  geometry_.cy_px = left_P_.at<double>(1, 2);
  // P2 = [f 0 cx -f B; ...] for a horizontal rig.
  geometry_.baseline_m = -right_P_.at<double>(0, 3) / right_P_.at<double>(0, 0);
  if (!(geometry_.baseline_m > 0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "rectification gave a non-positive baseline; is the rig vertical or swapped?");
  }
  cv::cv2eigen(left_R_, geometry_.rect_R_left);
  cv::initUndistortRectifyMap(Intrinsics(left), Distortion(left), left_R_, left_P_, size, CV_32FC1,
                              left_map_x_, left_map_y_);
  cv::initUndistortRectifyMap(Intrinsics(right), Distortion(right), right_R_, right_P_, size,
                              CV_32FC1, right_map_x_, right_map_y_);
}

void StereoRectifier::Rectify(const cv::Mat& left_raw, const cv::Mat& right_raw, cv::Mat& left_rect,
                              cv::Mat& right_rect) const {
  RequireMonoImage(left_raw, "left image", geometry_.width_px, geometry_.height_px);
  RequireMonoImage(right_raw, "right image", geometry_.width_px, geometry_.height_px);
  cv::remap(left_raw, left_rect, left_map_x_, left_map_y_, cv::INTER_LINEAR);
  cv::remap(right_raw, right_rect, right_map_x_, right_map_y_, cv::INTER_LINEAR);
}

Eigen::Vector2d StereoRectifier::RectifyLeftPixel(const Eigen::Vector2d& raw_px) const {
  return RectifyPixel(left_, left_R_, left_P_, raw_px);
}

Eigen::Vector2d StereoRectifier::RectifyRightPixel(const Eigen::Vector2d& raw_px) const {
  return RectifyPixel(right_, right_R_, right_P_, raw_px);
}

}  // namespace fleetmap
