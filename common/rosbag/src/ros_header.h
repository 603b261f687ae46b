// std_msgs/Header, the first field of every stamped sensor_msgs message (sensor_msgs.h).
// Private to the library.
#pragma once

#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap::internal {

inline RosHeader ReadRosHeader(ByteCursor& cursor) {
  RosHeader header;
  header.seq = cursor.Number<std::uint32_t>("header.seq");
  const auto sec = cursor.Number<std::uint32_t>("header.stamp.sec");
  const auto nsec = cursor.Number<std::uint32_t>("header.stamp.nsec");
  header.stamp_ns = std::int64_t{sec} * 1'000'000'000 + nsec;
  header.frame_id = std::string(cursor.LengthPrefixed("header.frame_id"));
  return header;
}

}  // namespace fleetmap::internal
