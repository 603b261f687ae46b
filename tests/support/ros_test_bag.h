// ROS bags for the tests of `fleetmap records import-bag`, written by ROS's own bag writer
// (librosbag-storage's rosbag::Bag) with ROS's own message types (sensor_msgs) and
// serialisation, so fleetmap's reader and decoders (common/rosbag) are checked against the
// reference implementation, not against a second reading of the spec by the same hands.
//
// ROS's generated message headers do not compile as C++20 (std::allocator<void>::rebind), so
// everything that touches them is in ros_test_bag.cc, built as C++17 (the library
// fleetmap_ros_test_bag); this header, included by both, is plain C++17 without ROS. Messages
// are described with fleetmap's own decoded structs (RosCameraInfo, RosImu, RosNavSatFix) and,
// for images, TestImage and TestCompressedImage (which own their bytes); the writer copies them
// field by field into sensor_msgs types.
//
// StereoBagContent holds what a stereo robot records: left and right images paired by stamp
// (the right one a little later, as two cameras triggered together stamp their frames), each
// camera's CameraInfo (a rectified horizontal pair with a known baseline), IMU samples at
// 100 Hz and GPS fixes at 10 Hz.
#pragma once

#include <algorithm>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap::testing {

// 2024-05-01T08:30:00Z.
inline constexpr std::int64_t kBagStartNs = 1'714'552'200'000'000'000;

// A sensor_msgs/Image that owns its bytes.
struct TestImage {
  std::int64_t stamp_ns = 0;
  std::string frame_id = "camera";
  std::uint32_t width = 0, height = 0;
  std::string encoding;
  bool is_bigendian = false;
  std::uint32_t step = 0;
  std::string data;
};

// A sensor_msgs/CompressedImage that owns its bytes.
struct TestCompressedImage {
  std::int64_t stamp_ns = 0;
  std::string frame_id = "camera";
  std::string format;  // "png", "mono8; png compressed mono8", ...
  std::string data;
};

// Images go on left_topic / right_topic, compressed images (image_transport's compressed
// topics) on left_compressed_topic / right_compressed_topic.
struct StereoBagContent {
  std::string left_topic = "/stereo/left/image_raw";
  std::string right_topic = "/stereo/right/image_raw";
  std::string left_compressed_topic = "/stereo/left/image_raw/compressed";
  std::string right_compressed_topic = "/stereo/right/image_raw/compressed";
  std::string left_info_topic = "/stereo/left/camera_info";
  std::string right_info_topic = "/stereo/right/camera_info";
  std::string imu_topic = "/imu/data";
  std::string gps_topic = "/gps/fix";
  std::vector<TestImage> left, right;
  std::vector<TestCompressedImage> left_compressed, right_compressed;
  std::vector<RosCameraInfo> left_info, right_info;
  std::vector<RosImu> imu;
  std::vector<RosNavSatFix> gps;
  double baseline_m = 0.11;
};

enum class BagCompression { kNone, kBz2, kLz4 };

// Writes `c` into `file` with rosbag::Bag, every message received 1 ms after its stamp, in
// receive order, in chunks of about `chunk_bytes`.
void WriteRosBag(const std::filesystem::path& file, const StereoBagContent& c,
                 BagCompression compression, std::uint32_t chunk_bytes = 16 * 1024);

// A message serialised by ROS (ros::serialization of the sensor_msgs type).
std::string SerialiseWithRos(const TestImage& m);
std::string SerialiseWithRos(const TestCompressedImage& m);
std::string SerialiseWithRos(const RosCameraInfo& m);
std::string SerialiseWithRos(const RosImu& m);
std::string SerialiseWithRos(const RosNavSatFix& m);
// ROS's md5sum of "sensor_msgs/Image", ..., from the generated types.
std::string RosMd5Sum(std::string_view type);

// An image message of `pixels` (CV_8UC1 for mono8, CV_16UC1 for mono16, CV_8UC3 for rgb8 /
// bgr8 in that channel order), rows `pad` bytes longer than needed (padding bytes 0xEE).
inline TestImage ImageMessage(const cv::Mat& pixels, const std::string& encoding,
                              std::int64_t stamp_ns, std::uint32_t pad = 0) {
  TestImage m;
  m.stamp_ns = stamp_ns;
  m.height = static_cast<std::uint32_t>(pixels.rows);
  m.width = static_cast<std::uint32_t>(pixels.cols);
  m.encoding = encoding;
  const std::size_t row = pixels.cols * pixels.elemSize();
  m.step = static_cast<std::uint32_t>(row + pad);
  m.data.assign(std::size_t{m.step} * m.height, '\xEE');
  for (int r = 0; r < pixels.rows; ++r) {
    std::copy(pixels.ptr<char>(r), pixels.ptr<char>(r) + row,
              m.data.begin() + static_cast<std::ptrdiff_t>(r * m.step));
  }
  return m;
}

// A rectified pair's CameraInfo: the right camera `baseline_m` to the right (P[3] = -fx * B).
inline RosCameraInfo CameraInfoMessage(int width, int height, bool right, double baseline_m,
                                       std::int64_t stamp_ns) {
  RosCameraInfo m;
  m.header.stamp_ns = stamp_ns;
  m.header.frame_id = right ? "right_camera" : "left_camera";
  m.width = static_cast<std::uint32_t>(width);
  m.height = static_cast<std::uint32_t>(height);
  m.distortion_model = "plumb_bob";
  m.d = {-0.28, 0.07, 0.0002, 0.00002, 0.0};
  const double f = 0.61 * width, cx = width / 2.0 - 0.5, cy = height / 2.0 + 0.25;
  m.k = {f, 0, cx, 0, f * 1.001, cy, 0, 0, 1};
  m.r = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  m.p = {f, 0, cx, right ? -f * baseline_m : 0.0, 0, f, cy, 0, 0, 0, 1, 0};
  return m;
}

// `pairs` stereo pairs of `left_frames` / `right_frames` (cycled) at 10 Hz, the right frame
// `right_lag_ns` after the left, odd left frames with padded rows; two CameraInfo per camera;
// `imu` samples at 100 Hz and `gps` fixes at 10 Hz, from kBagStartNs on.
inline StereoBagContent MakeStereoBagContent(const std::vector<cv::Mat>& left_frames,
                                             const std::vector<cv::Mat>& right_frames, int pairs,
                                             int imu, int gps,
                                             const std::string& encoding = "mono8",
                                             std::int64_t right_lag_ns = 200'000) {
  StereoBagContent c;
  for (int i = 0; i < pairs; ++i) {
    const std::int64_t t = kBagStartNs + i * 100'000'000LL;
    c.left.push_back(ImageMessage(left_frames[i % left_frames.size()], encoding, t, i % 2 ? 3 : 0));
    c.right.push_back(
        ImageMessage(right_frames[i % right_frames.size()], encoding, t + right_lag_ns));
  }
  for (int i = 0; i < 2; ++i) {
    const std::int64_t t = kBagStartNs + i * 500'000'000LL;
    const cv::Mat& frame = left_frames.front();
    c.left_info.push_back(CameraInfoMessage(frame.cols, frame.rows, false, c.baseline_m, t));
    c.right_info.push_back(CameraInfoMessage(frame.cols, frame.rows, true, c.baseline_m, t));
  }
  for (int i = 0; i < imu; ++i) {
    RosImu m;
    m.header.stamp_ns = kBagStartNs + i * 10'000'000LL + 123;
    m.header.frame_id = "imu_link";
    m.orientation_xyzw = {0.01 * i, -0.02, 0.03, 0.999};
    m.orientation_covariance = {1e-4, 0, 0, 0, 1e-4, 0, 0, 0, 2e-4};
    m.angular_velocity = {0.1 + 0.001 * i, -0.2, 0.3 * i};
    m.angular_velocity_covariance = {-1, 0, 0, 0, 0, 0, 0, 0, 0};  // "not given"
    m.linear_acceleration = {0.5, -0.25 * i, 9.81};
    m.linear_acceleration_covariance = {0.01, 0.001, 0, 0.001, 0.01, 0, 0, 0, 0.02};
    c.imu.push_back(m);
  }
  for (int i = 0; i < gps; ++i) {
    RosNavSatFix m;
    m.header.stamp_ns = kBagStartNs + i * 100'000'000LL + 7;
    m.header.frame_id = "gps";
    m.status = static_cast<std::int8_t>(i % 4 - 1);  // no fix, fix, SBAS, GBAS
    m.service = 1;
    m.latitude_deg = 51.7590 + 1e-6 * i;
    m.longitude_deg = -1.2580 - 1e-6 * i;
    m.altitude_m = 70.5 + i;
    m.position_covariance_m2 = {0.25, 0, 0, 0, 0.25, 0, 0, 0, 1.0};
    m.position_covariance_type = 2;
    c.gps.push_back(m);
  }
  return c;
}

}  // namespace fleetmap::testing
