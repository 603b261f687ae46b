// sensor_msgs/NavSatFix (sensor_msgs.h):
//   Header header, NavSatStatus status (int8 status, uint16 service), float64 latitude,
//   float64 longitude, float64 altitude, float64[9] position_covariance,
//   uint8 position_covariance_type
#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_header.h"

namespace fleetmap {

RosNavSatFix DecodeRosNavSatFix(std::string_view bytes) {
  internal::ByteCursor cursor(bytes, "sensor_msgs/NavSatFix");
  RosNavSatFix fix;
  fix.header = internal::ReadRosHeader(cursor);
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
