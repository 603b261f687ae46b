// ROS IMU and GNSS messages as fleetmap records (ros_sensor_records.h).
#include "ros_sensor_records.h"

#include <algorithm>
#include <array>

namespace fleetmap::internal {
namespace {

bool Given(const std::array<double, 9>& covariance) {
  return covariance[0] != -1 &&
         std::any_of(covariance.begin(), covariance.end(), [](double v) { return v != 0; });
}

template <typename Field>
void SetCovariance(const std::array<double, 9>& covariance, Field* field) {
  if (!Given(covariance)) return;
  field->Assign(covariance.begin(), covariance.end());
}

v1::GpsFix::Status StatusFromRos(std::int8_t status) {
  switch (status) {
    case -1:
      return v1::GpsFix::STATUS_NO_FIX;
    case 0:
      return v1::GpsFix::STATUS_FIX;
    case 1:
      return v1::GpsFix::STATUS_SBAS_FIX;
    case 2:
      return v1::GpsFix::STATUS_GBAS_FIX;
    default:
      return v1::GpsFix::STATUS_UNKNOWN;
  }
}

}  // namespace

v1::ImuSample ImuSampleFromRos(const RosImu& imu, std::int64_t stamp_ns) {
  v1::ImuSample out;
  out.set_stamp_ns(stamp_ns);
  out.set_frame(imu.header.frame_id);
  if (imu.orientation_covariance[0] != -1) {
    out.set_orientation_x(imu.orientation_xyzw[0]);
    out.set_orientation_y(imu.orientation_xyzw[1]);
    out.set_orientation_z(imu.orientation_xyzw[2]);
    out.set_orientation_w(imu.orientation_xyzw[3]);
  }
  SetCovariance(imu.orientation_covariance, out.mutable_orientation_covariance_rad2());
  out.set_angular_velocity_x_radps(imu.angular_velocity[0]);
  out.set_angular_velocity_y_radps(imu.angular_velocity[1]);
  out.set_angular_velocity_z_radps(imu.angular_velocity[2]);
  SetCovariance(imu.angular_velocity_covariance, out.mutable_angular_velocity_covariance_radps2());
  out.set_linear_acceleration_x_mps2(imu.linear_acceleration[0]);
  out.set_linear_acceleration_y_mps2(imu.linear_acceleration[1]);
  out.set_linear_acceleration_z_mps2(imu.linear_acceleration[2]);
  SetCovariance(imu.linear_acceleration_covariance,
                out.mutable_linear_acceleration_covariance_mps2_2());
  return out;
}

v1::GpsFix GpsFixFromRos(const RosNavSatFix& fix, std::int64_t stamp_ns) {
  v1::GpsFix out;
  out.set_stamp_ns(stamp_ns);
  out.set_latitude_deg(fix.latitude_deg);
  out.set_longitude_deg(fix.longitude_deg);
  out.set_altitude_m(fix.altitude_m);
  if (fix.position_covariance_type != 0) {
    SetCovariance(fix.position_covariance_m2, out.mutable_position_covariance_m2());
  }
  out.set_status(StatusFromRos(fix.status));
  return out;  // NavSatFix does not say how many satellites: 0, "unknown"
}

}  // namespace fleetmap::internal
