// The ROS 2 messages `fleetmap records import-bag` reads from an MCAP file (mcap_reader.h),
// decoded from their CDR serialisation (message encoding "cdr"): sensor_msgs/msg/Image,
// CompressedImage, CameraInfo, Imu and NavSatFix, field by field as their .msg files define
// them, into the same structs as the ROS 1 decoders (sensor_msgs.h).
//
// ROS 2's messages differ from ROS 1's in std_msgs/Header, which has no seq and whose stamp is
// builtin_interfaces/Time {int32 sec, uint32 nanosec}, and in CameraInfo's lower-case d, k, r,
// p (the same fields). The serialisation is CDR: a 4-byte encapsulation header, then fields
// aligned to their size (the private cdr_cursor.h says how); little- and big-endian CDR are read.
//
// Each Decode* checks every length against the bytes there and that nothing but padding is
// left over, and throws Error(kCorrupt) naming the type and the field that did not fit
// ("sensor_msgs/msg/Imu: too short: linear_acceleration_covariance needs 8 bytes at byte 308
// but only 4 remain"), Error(kInvalidArgument) for an encapsulation other than plain CDR. A
// stamp before 1970 (negative sec) or with nanosec of a second or more is refused as corrupt.
// Thread-safe (pure functions).
#pragma once

#include <string_view>

#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap {

// The ROS 2 type names, as a ros2msg schema of an MCAP file names them.
inline constexpr std::string_view kRos2ImageType = "sensor_msgs/msg/Image";
inline constexpr std::string_view kRos2CompressedImageType = "sensor_msgs/msg/CompressedImage";
inline constexpr std::string_view kRos2CameraInfoType = "sensor_msgs/msg/CameraInfo";
inline constexpr std::string_view kRos2ImuType = "sensor_msgs/msg/Imu";
inline constexpr std::string_view kRos2NavSatFixType = "sensor_msgs/msg/NavSatFix";

RosImage DecodeRos2Image(std::string_view cdr);
RosCompressedImage DecodeRos2CompressedImage(std::string_view cdr);
RosCameraInfo DecodeRos2CameraInfo(std::string_view cdr);
RosImu DecodeRos2Imu(std::string_view cdr);
RosNavSatFix DecodeRos2NavSatFix(std::string_view cdr);

}  // namespace fleetmap
