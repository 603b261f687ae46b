// sensor_msgs/Image (sensor_msgs.h):
//   Header header, uint32 height, uint32 width, string encoding, uint8 is_bigendian,
//   uint32 step, uint8[] data
#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_header.h"

namespace fleetmap {

RosImage DecodeRosImage(std::string_view bytes) {
  internal::ByteCursor cursor(bytes, "sensor_msgs/Image");
  RosImage image;
  image.header = internal::ReadRosHeader(cursor);
  image.height = cursor.Number<std::uint32_t>("height");
  image.width = cursor.Number<std::uint32_t>("width");
  image.encoding = std::string(cursor.LengthPrefixed("encoding"));
  image.is_bigendian = cursor.Number<std::uint8_t>("is_bigendian") != 0;
  image.step = cursor.Number<std::uint32_t>("step");
  image.data = cursor.LengthPrefixed("data");
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

}  // namespace fleetmap
