// The ROS 2 sensor_msgs decoders (ros2_sensor_msgs.h), each field as the type's .msg declares it:
//   std_msgs/Header: builtin_interfaces/Time stamp (int32 sec, uint32 nanosec), string frame_id
//   Image: Header header, uint32 height, uint32 width, string encoding, uint8 is_bigendian,
//     uint32 step, uint8[] data
//   CompressedImage: Header header, string format, uint8[] data
//   CameraInfo: Header header, uint32 height, uint32 width, string distortion_model,
//     float64[] d, float64[9] k, float64[9] r, float64[12] p, uint32 binning_x,
//     uint32 binning_y, RegionOfInterest roi (uint32 x_offset, y_offset, height, width;
//     bool do_rectify)
//   Imu: Header header, geometry_msgs/Quaternion orientation (float64 x, y, z, w),
//     float64[9] orientation_covariance, geometry_msgs/Vector3 angular_velocity (x, y, z),
//     float64[9] angular_velocity_covariance, Vector3 linear_acceleration,
//     float64[9] linear_acceleration_covariance
//   NavSatFix: Header header, NavSatStatus status (int8 status, uint16 service),
//     float64 latitude, float64 longitude, float64 altitude, float64[9] position_covariance,
//     uint8 position_covariance_type
#include "fleetmap/rosbag/ros2_sensor_msgs.h"

#include "cdr_cursor.h"

namespace fleetmap {
namespace {

using internal::CdrCursor;

RosHeader ReadRos2Header(CdrCursor& cursor) {
  RosHeader header;
  const auto sec = cursor.Number<std::int32_t>("header.stamp.sec");
  const auto nanosec = cursor.Number<std::uint32_t>("header.stamp.nanosec");
  if (sec < 0) cursor.Fail("header.stamp.sec is negative (" + std::to_string(sec) + ")");
  if (nanosec >= 1'000'000'000) {
    cursor.Fail("header.stamp.nanosec is a second or more (" + std::to_string(nanosec) + ")");
  }
  header.stamp_ns = std::int64_t{sec} * 1'000'000'000 + nanosec;
  header.frame_id = cursor.String("header.frame_id");
  return header;
}

}  // namespace

RosImage DecodeRos2Image(std::string_view cdr) {
  CdrCursor cursor(cdr, std::string(kRos2ImageType));
  RosImage image;
  image.header = ReadRos2Header(cursor);
  image.height = cursor.Number<std::uint32_t>("height");
  image.width = cursor.Number<std::uint32_t>("width");
  image.encoding = cursor.String("encoding");
  image.is_bigendian = cursor.Number<std::uint8_t>("is_bigendian") != 0;
  image.step = cursor.Number<std::uint32_t>("step");
  image.data = cursor.ByteSequence("data");
  cursor.ExpectEnd();
  // Exactly: rows are `step` apart and there are `height` of them. Fewer would be read past;
  // more is no image of this size.
  if (const std::uint64_t rows = std::uint64_t{image.step} * image.height;
      image.data.size() != rows) {
    cursor.Fail("data holds " + std::to_string(image.data.size()) + " bytes, " +
                (image.data.size() < rows ? "fewer" : "more") + " than step " +
                std::to_string(image.step) + " x height " + std::to_string(image.height));
  }
  return image;
}

RosCompressedImage DecodeRos2CompressedImage(std::string_view cdr) {
  CdrCursor cursor(cdr, std::string(kRos2CompressedImageType));
  RosCompressedImage image;
  image.header = ReadRos2Header(cursor);
  image.format = cursor.String("format");
  image.data = cursor.ByteSequence("data");
  cursor.ExpectEnd();
  return image;
}

RosCameraInfo DecodeRos2CameraInfo(std::string_view cdr) {
  CdrCursor cursor(cdr, std::string(kRos2CameraInfoType));
  RosCameraInfo info;
  info.header = ReadRos2Header(cursor);
  info.height = cursor.Number<std::uint32_t>("height");
  info.width = cursor.Number<std::uint32_t>("width");
  info.distortion_model = cursor.String("distortion_model");
  info.d = cursor.DoubleSequence("d", kMaxCameraInfoDistortionCoefficients);
  info.k = cursor.Doubles<9>("k");
  info.r = cursor.Doubles<9>("r");
  info.p = cursor.Doubles<12>("p");
  info.binning_x = cursor.Number<std::uint32_t>("binning_x");
  info.binning_y = cursor.Number<std::uint32_t>("binning_y");
  info.roi_x_offset = cursor.Number<std::uint32_t>("roi.x_offset");
  info.roi_y_offset = cursor.Number<std::uint32_t>("roi.y_offset");
  info.roi_height = cursor.Number<std::uint32_t>("roi.height");
  info.roi_width = cursor.Number<std::uint32_t>("roi.width");
  info.roi_do_rectify = cursor.Number<std::uint8_t>("roi.do_rectify") != 0;
  cursor.ExpectEnd();
  return info;
}

RosImu DecodeRos2Imu(std::string_view cdr) {
  CdrCursor cursor(cdr, std::string(kRos2ImuType));
  RosImu imu;
  imu.header = ReadRos2Header(cursor);
  imu.orientation_xyzw = cursor.Doubles<4>("orientation");
  imu.orientation_covariance = cursor.Doubles<9>("orientation_covariance");
  imu.angular_velocity = cursor.Doubles<3>("angular_velocity");
  imu.angular_velocity_covariance = cursor.Doubles<9>("angular_velocity_covariance");
  imu.linear_acceleration = cursor.Doubles<3>("linear_acceleration");
  imu.linear_acceleration_covariance = cursor.Doubles<9>("linear_acceleration_covariance");
  cursor.ExpectEnd();
  return imu;
}

RosNavSatFix DecodeRos2NavSatFix(std::string_view cdr) {
  CdrCursor cursor(cdr, std::string(kRos2NavSatFixType));
  RosNavSatFix fix;
  fix.header = ReadRos2Header(cursor);
  fix.status = cursor.Number<std::int8_t>("status.status");
  fix.service = cursor.Number<std::uint16_t>("status.service");
  fix.latitude_deg = cursor.Number<double>("latitude");
  fix.longitude_deg = cursor.Number<double>("longitude");
  fix.altitude_m = cursor.Number<double>("altitude");
  fix.position_covariance_m2 = cursor.Doubles<9>("position_covariance");
  fix.position_covariance_type = cursor.Number<std::uint8_t>("position_covariance_type");
  cursor.ExpectEnd();
  return fix;
}

}  // namespace fleetmap
