// sensor_msgs/Imu and sensor_msgs/NavSatFix (fleetmap/rosbag/sensor_msgs.h) as the record
// payloads of proto/fleetmap/sensors.proto, whose fields follow ROS's (units and frames alike).
// What ROS marks "not given" becomes what sensors.proto calls unknown: a covariance whose
// first element is -1, or that is all zeros, or a fix whose covariance type is 0, is left
// empty; an IMU without orientation (orientation covariance -1) gets the all-zero quaternion.
// Private to the library.
#pragma once

#include <cstdint>

#include "fleetmap/rosbag/sensor_msgs.h"
#include "fleetmap/sensors.pb.h"

namespace fleetmap::internal {

v1::ImuSample ImuSampleFromRos(const RosImu& imu, std::int64_t stamp_ns);
v1::GpsFix GpsFixFromRos(const RosNavSatFix& fix, std::int64_t stamp_ns);

}  // namespace fleetmap::internal
