// The ROS 1 messages `fleetmap records import-bag` reads, decoded from their serialisation in a
// bag (bag_reader.h): sensor_msgs/Image, CompressedImage, CameraInfo, Imu and NavSatFix, field by
// field as their .msg files define them (ROS 1 serialisation: fixed-size fields little-endian in
// declaration order, no padding; `string` and `T[]` behind a uint32 count; `T[N]` without one).
//
// The structs are also what the ROS 2 decoders of the same types give (ros2_sensor_msgs.h, from
// an MCAP file's CDR), so that `records import-bag` converts either into records the same way.
//
// Conventions: stamps are UTC nanoseconds (std_msgs/Header's sec * 1e9 + nsec); matrices are
// row-major as in the messages; a decoded Image's (CompressedImage's) `data` views the bytes
// passed in.
//
// Each Decode* checks every length against the bytes there and that nothing is left over, and
// throws Error(kCorrupt) naming the type and the field that did not fit ("sensor_msgs/Imu: too
// short: linear_acceleration_covariance needs 8 bytes at byte 308 but only 4 remain").
// Thread-safe (pure functions).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace fleetmap {

// The md5sums rosbag records for these types (of their full definitions): a connection of one
// of these type names with another md5sum holds another definition and is not decoded.
inline constexpr std::string_view kRosImageMd5 = "060021388200f6f0f447d0fcd9c64743";
inline constexpr std::string_view kRosCompressedImageMd5 = "8f7a12909da2c9d3332d540a0977563f";
inline constexpr std::string_view kRosCameraInfoMd5 = "c9a58c1b0b154e0e6da7578cb991d214";
inline constexpr std::string_view kRosImuMd5 = "6a62c6daae103f4ff57a132d6f95cec2";
inline constexpr std::string_view kRosNavSatFixMd5 = "2d3a8cd499b9b4a0249fb98fd05cfa48";

// std_msgs/Header.
struct RosHeader {
  std::uint32_t seq = 0;  // ROS 1 only: ROS 2's Header has none (0)
  std::int64_t stamp_ns = 0;
  std::string frame_id;
};

// sensor_msgs/Image. REQUIRES of the message, checked: data holds exactly step * height bytes.
struct RosImage {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string encoding;  // "mono8", "rgb8", ... (sensor_msgs/image_encodings.h)
  bool is_bigendian = false;
  std::uint32_t step = 0;  // bytes per row
  std::string_view data;
};

// sensor_msgs/CompressedImage. The decoders do not look into `data` (the import decodes it).
struct RosCompressedImage {
  RosHeader header;
  std::string format;     // "jpeg", "png", "rgb8; jpeg compressed bgr8", ...
  std::string_view data;  // the compressed image, as `format` says
};

// The most coefficients a CameraInfo's D may have: the most any distortion model of OpenCV's
// has (rational_polynomial with thin prism and tilt: k1-k6, p1, p2, s1-s4, tau_x, tau_y). A D
// with more is refused before it is allocated (a count of 2^25 would be 256 MiB).
inline constexpr std::uint32_t kMaxCameraInfoDistortionCoefficients = 14;

// sensor_msgs/CameraInfo (the plumb_bob model's D is k1, k2, t1, t2, k3). D holds at most
// kMaxCameraInfoDistortionCoefficients, checked; K, R and P have their fixed sizes on the wire.
struct RosCameraInfo {
  RosHeader header;
  std::uint32_t height = 0, width = 0;
  std::string distortion_model;
  std::vector<double> d;
  std::array<double, 9> k{};   // intrinsics of the raw image
  std::array<double, 9> r{};   // rectification: rectified_R_camera
  std::array<double, 12> p{};  // projection of the rectified image; p[3] = -fx' * baseline
  std::uint32_t binning_x = 0, binning_y = 0;
  std::uint32_t roi_x_offset = 0, roi_y_offset = 0, roi_height = 0, roi_width = 0;
  bool roi_do_rectify = false;
};

// sensor_msgs/Imu. A covariance whose first element is -1 means "not given" (orientation:
// the IMU gives none); all zeros means unknown.
struct RosImu {
  RosHeader header;
  std::array<double, 4> orientation_xyzw{};
  std::array<double, 9> orientation_covariance{};
  std::array<double, 3> angular_velocity{};  // rad/s
  std::array<double, 9> angular_velocity_covariance{};
  std::array<double, 3> linear_acceleration{};  // m/s²
  std::array<double, 9> linear_acceleration_covariance{};
};

// sensor_msgs/NavSatFix with its NavSatStatus.
struct RosNavSatFix {
  RosHeader header;
  std::int8_t status = -1;  // -1 no fix, 0 fix, 1 SBAS, 2 GBAS
  std::uint16_t service = 0;
  double latitude_deg = 0, longitude_deg = 0, altitude_m = 0;
  std::array<double, 9> position_covariance_m2{};  // ENU, row-major
  std::uint8_t position_covariance_type = 0;       // 0 unknown, 1 approximated, 2 diagonal, 3 known
};

RosImage DecodeRosImage(std::string_view bytes);
RosCompressedImage DecodeRosCompressedImage(std::string_view bytes);
RosCameraInfo DecodeRosCameraInfo(std::string_view bytes);
RosImu DecodeRosImu(std::string_view bytes);
RosNavSatFix DecodeRosNavSatFix(std::string_view bytes);

}  // namespace fleetmap
