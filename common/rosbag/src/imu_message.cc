// sensor_msgs/Imu (sensor_msgs.h):
//   Header header, geometry_msgs/Quaternion orientation (float64 x, y, z, w),
//   float64[9] orientation_covariance, geometry_msgs/Vector3 angular_velocity (x, y, z),
//   float64[9] angular_velocity_covariance, geometry_msgs/Vector3 linear_acceleration,
//   float64[9] linear_acceleration_covariance
#include "byte_cursor.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "ros_header.h"

namespace fleetmap {

RosImu DecodeRosImu(std::string_view bytes) {
  internal::ByteCursor cursor(bytes, "sensor_msgs/Imu");
  RosImu imu;
  imu.header = internal::ReadRosHeader(cursor);
  imu.orientation_xyzw = cursor.Doubles<4>("orientation");
  imu.orientation_covariance = cursor.Doubles<9>("orientation_covariance");
  imu.angular_velocity = cursor.Doubles<3>("angular_velocity");
  imu.angular_velocity_covariance = cursor.Doubles<9>("angular_velocity_covariance");
  imu.linear_acceleration = cursor.Doubles<3>("linear_acceleration");
  imu.linear_acceleration_covariance = cursor.Doubles<9>("linear_acceleration_covariance");
  cursor.ExpectEnd();
  return imu;
}

}  // namespace fleetmap
