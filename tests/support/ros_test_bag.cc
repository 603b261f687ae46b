// ROS's own writer and serialisation for the ROS bag tests (ros_test_bag.h). Built as C++17:
// ROS's generated message headers do not compile as C++20.
#include "ros_test_bag.h"

#include <ros/serialization.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/NavSatFix.h>

#include <functional>
#include <tuple>

namespace fleetmap::testing {
namespace {

ros::Time RosTime(std::int64_t ns) {
  ros::Time t;
  t.fromNSec(static_cast<std::uint64_t>(ns));
  return t;
}

std_msgs::Header ToRos(const RosHeader& h) {
  std_msgs::Header out;
  out.seq = h.seq;
  out.stamp = RosTime(h.stamp_ns);
  out.frame_id = h.frame_id;
  return out;
}

sensor_msgs::Image ToRos(const TestImage& m) {
  sensor_msgs::Image out;
  out.header = ToRos(RosHeader{0, m.stamp_ns, m.frame_id});
  out.height = m.height;
  out.width = m.width;
  out.encoding = m.encoding;
  out.is_bigendian = m.is_bigendian ? 1 : 0;
  out.step = m.step;
  out.data.assign(m.data.begin(), m.data.end());
  return out;
}

sensor_msgs::CompressedImage ToRos(const TestCompressedImage& m) {
  sensor_msgs::CompressedImage out;
  out.header = ToRos(RosHeader{0, m.stamp_ns, m.frame_id});
  out.format = m.format;
  out.data.assign(m.data.begin(), m.data.end());
  return out;
}

sensor_msgs::CameraInfo ToRos(const RosCameraInfo& m) {
  sensor_msgs::CameraInfo out;
  out.header = ToRos(m.header);
  out.height = m.height;
  out.width = m.width;
  out.distortion_model = m.distortion_model;
  out.D = m.d;
  std::copy(m.k.begin(), m.k.end(), out.K.begin());
  std::copy(m.r.begin(), m.r.end(), out.R.begin());
  std::copy(m.p.begin(), m.p.end(), out.P.begin());
  out.binning_x = m.binning_x;
  out.binning_y = m.binning_y;
  out.roi.x_offset = m.roi_x_offset;
  out.roi.y_offset = m.roi_y_offset;
  out.roi.height = m.roi_height;
  out.roi.width = m.roi_width;
  out.roi.do_rectify = m.roi_do_rectify;
  return out;
}

sensor_msgs::Imu ToRos(const RosImu& m) {
  sensor_msgs::Imu out;
  out.header = ToRos(m.header);
  out.orientation.x = m.orientation_xyzw[0];
  out.orientation.y = m.orientation_xyzw[1];
  out.orientation.z = m.orientation_xyzw[2];
  out.orientation.w = m.orientation_xyzw[3];
  std::copy(m.orientation_covariance.begin(), m.orientation_covariance.end(),
            out.orientation_covariance.begin());
  out.angular_velocity.x = m.angular_velocity[0];
  out.angular_velocity.y = m.angular_velocity[1];
  out.angular_velocity.z = m.angular_velocity[2];
  std::copy(m.angular_velocity_covariance.begin(), m.angular_velocity_covariance.end(),
            out.angular_velocity_covariance.begin());
  out.linear_acceleration.x = m.linear_acceleration[0];
  out.linear_acceleration.y = m.linear_acceleration[1];
  out.linear_acceleration.z = m.linear_acceleration[2];
  std::copy(m.linear_acceleration_covariance.begin(), m.linear_acceleration_covariance.end(),
            out.linear_acceleration_covariance.begin());
  return out;
}

sensor_msgs::NavSatFix ToRos(const RosNavSatFix& m) {
  sensor_msgs::NavSatFix out;
  out.header = ToRos(m.header);
  out.status.status = m.status;
  out.status.service = m.service;
  out.latitude = m.latitude_deg;
  out.longitude = m.longitude_deg;
  out.altitude = m.altitude_m;
  std::copy(m.position_covariance_m2.begin(), m.position_covariance_m2.end(),
            out.position_covariance.begin());
  out.position_covariance_type = m.position_covariance_type;
  return out;
}

template <typename M>
std::string Serialise(const M& m) {
  std::string bytes(ros::serialization::serializationLength(m), '\0');
  ros::serialization::OStream out(reinterpret_cast<std::uint8_t*>(&bytes[0]),
                                  static_cast<std::uint32_t>(bytes.size()));
  ros::serialization::serialize(out, m);
  return bytes;
}

std::int64_t StampOf(const TestImage& m) {
  return m.stamp_ns;
}
std::int64_t StampOf(const TestCompressedImage& m) {
  return m.stamp_ns;
}
template <typename M>
std::int64_t StampOf(const M& m) {
  return m.header.stamp_ns;
}

}  // namespace

void WriteRosBag(const std::filesystem::path& file, const StereoBagContent& c,
                 BagCompression compression, std::uint32_t chunk_bytes) {
  rosbag::Bag bag(file.string(), rosbag::bagmode::Write);
  bag.setCompression(compression == BagCompression::kBz2   ? rosbag::compression::BZ2
                     : compression == BagCompression::kLz4 ? rosbag::compression::LZ4
                                                           : rosbag::compression::Uncompressed);
  bag.setChunkThreshold(chunk_bytes);
  // (receive time, order given, writer)
  std::vector<std::tuple<std::int64_t, std::size_t, std::function<void()>>> writes;
  const auto add = [&](const std::string& topic, const auto& messages) {
    for (const auto& m : messages) {
      const std::int64_t received = StampOf(m) + 1'000'000;
      writes.emplace_back(received, writes.size(), [&bag, &topic, &m, received] {
        bag.write(topic, RosTime(received), ToRos(m));
      });
    }
  };
  add(c.left_topic, c.left);
  add(c.right_topic, c.right);
  add(c.left_compressed_topic, c.left_compressed);
  add(c.right_compressed_topic, c.right_compressed);
  add(c.left_info_topic, c.left_info);
  add(c.right_info_topic, c.right_info);
  add(c.imu_topic, c.imu);
  add(c.gps_topic, c.gps);
  std::sort(writes.begin(), writes.end(), [](const auto& a, const auto& b) {
    return std::tie(std::get<0>(a), std::get<1>(a)) < std::tie(std::get<0>(b), std::get<1>(b));
  });
  for (const auto& w : writes) std::get<2>(w)();
  bag.close();
}

std::string SerialiseWithRos(const TestImage& m) {
  return Serialise(ToRos(m));
}
std::string SerialiseWithRos(const TestCompressedImage& m) {
  return Serialise(ToRos(m));
}
std::string SerialiseWithRos(const RosCameraInfo& m) {
  return Serialise(ToRos(m));
}
std::string SerialiseWithRos(const RosImu& m) {
  return Serialise(ToRos(m));
}
std::string SerialiseWithRos(const RosNavSatFix& m) {
  return Serialise(ToRos(m));
}

std::string RosMd5Sum(std::string_view type) {
  if (type == "sensor_msgs/Image") return ros::message_traits::md5sum<sensor_msgs::Image>();
  if (type == "sensor_msgs/CompressedImage") {
    return ros::message_traits::md5sum<sensor_msgs::CompressedImage>();
  }
  if (type == "sensor_msgs/CameraInfo") {
    return ros::message_traits::md5sum<sensor_msgs::CameraInfo>();
  }
  if (type == "sensor_msgs/Imu") return ros::message_traits::md5sum<sensor_msgs::Imu>();
  if (type == "sensor_msgs/NavSatFix") return ros::message_traits::md5sum<sensor_msgs::NavSatFix>();
  return "";
}

}  // namespace fleetmap::testing
