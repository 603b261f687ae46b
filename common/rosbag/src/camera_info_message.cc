// sensor_msgs/CameraInfo (sensor_msgs.h):
//   Header header, uint32 height, uint32 width, string distortion_model, float64[] D,
//   float64[9] K, float64[9] R, float64[12] P, uint32 binning_x, uint32 binning_y,
//   RegionOfInterest roi (uint32 x_offset, y_offset, height, width; bool do_rectify)
#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_header.h"

namespace fleetmap {

RosCameraInfo DecodeRosCameraInfo(std::string_view bytes) {
  internal::ByteCursor cursor(bytes, "sensor_msgs/CameraInfo");
  RosCameraInfo info;
  info.header = internal::ReadRosHeader(cursor);
  info.height = cursor.Number<std::uint32_t>("height");
  info.width = cursor.Number<std::uint32_t>("width");
  info.distortion_model = std::string(cursor.LengthPrefixed("distortion_model"));
  info.d = cursor.DoubleVector("D", kMaxCameraInfoDistortionCoefficients);
  info.k = cursor.Doubles<9>("K");
  info.r = cursor.Doubles<9>("R");
  info.p = cursor.Doubles<12>("P");
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

}  // namespace fleetmap
