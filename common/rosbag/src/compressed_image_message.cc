// sensor_msgs/CompressedImage (sensor_msgs.h):
//   Header header, string format, uint8[] data
#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_header.h"

namespace fleetmap {

RosCompressedImage DecodeRosCompressedImage(std::string_view bytes) {
  internal::ByteCursor cursor(bytes, "sensor_msgs/CompressedImage");
  RosCompressedImage image;
  image.header = internal::ReadRosHeader(cursor);
  image.format = std::string(cursor.LengthPrefixed("format"));
  image.data = cursor.LengthPrefixed("data");
  cursor.ExpectEnd();
  return image;
}

}  // namespace fleetmap
