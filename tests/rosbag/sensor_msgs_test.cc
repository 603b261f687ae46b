// The sensor_msgs decoders (fleetmap/rosbag/sensor_msgs.h) on messages serialised by ROS's own
// code (ros::serialization of sensor_msgs types, ros_test_bag.h): every field comes back; a message
// cut short at any byte is refused naming the type, and bytes left over are refused too; so are an
// Image whose data is longer than its rows and a CameraInfo whose D has more than 14 coefficients.
#include "fleetmap/rosbag/sensor_msgs.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/images/image_codec.h"
#include "ros_test_bag.h"

namespace fleetmap {
namespace {

using testing::kBagStartNs;

using testing::SerialiseWithRos;

testing::StereoBagContent Content() {
  cv::Mat left(6, 8, CV_8UC1), right(6, 8, CV_8UC1);
  cv::randu(left, 0, 255);
  cv::randu(right, 0, 255);
  return testing::MakeStereoBagContent({left}, {right}, 1, 2, 2);
}

// Every prefix of `bytes` is refused naming `type`, and so is one byte more.
template <typename Decode>
void ExpectEveryCutRefused(const std::string& bytes, const std::string& type, Decode decode) {
  for (std::size_t n = 0; n < bytes.size(); ++n) {
    SCOPED_TRACE("cut to " + std::to_string(n) + " of " + std::to_string(bytes.size()));
    ExpectError(
        ErrorCode::kCorrupt, [&] { decode(std::string_view(bytes).substr(0, n)); }, type);
  }
  ExpectError(
      ErrorCode::kCorrupt, [&] { decode(bytes + "x"); }, "left over");
}

TEST(RosSensorMsgs, ImageComesBackFieldByField) {
  const testing::TestImage m = Content().left[0];
  const std::string bytes = SerialiseWithRos(m);
  const RosImage image = DecodeRosImage(bytes);
  EXPECT_EQ(image.header.stamp_ns, kBagStartNs);
  EXPECT_EQ(image.header.frame_id, "camera");
  EXPECT_EQ(image.width, 8u);
  EXPECT_EQ(image.height, 6u);
  EXPECT_EQ(image.encoding, "mono8");
  EXPECT_FALSE(image.is_bigendian);
  EXPECT_EQ(image.step, 8u);
  EXPECT_EQ(image.data, m.data);
  ExpectEveryCutRefused(bytes, "sensor_msgs/Image", DecodeRosImage);
}

TEST(RosSensorMsgs, ImageWhoseDataIsShorterThanItsRowsIsRefused) {
  testing::TestImage m = Content().left[0];
  m.data.resize(m.data.size() - 1);
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeRosImage(SerialiseWithRos(m)); }, "fewer than step");
}

// Rows are `step` apart and there are `height` of them: bytes beyond are no image of this size.
TEST(RosSensorMsgs, ImageWhoseDataIsLongerThanItsRowsIsRefused) {
  testing::TestImage m = Content().left[0];
  m.data += "x";
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeRosImage(SerialiseWithRos(m)); },
      "sensor_msgs/Image: data holds 49 bytes, more than step 8 x height 6");
}

TEST(RosSensorMsgs, CompressedImageComesBackFieldByField) {
  testing::TestCompressedImage m;
  m.stamp_ns = kBagStartNs + 42;
  m.frame_id = "left_camera";
  m.format = "mono8; png compressed mono8";
  cv::Mat pixels(6, 8, CV_8UC1);
  cv::randu(pixels, 0, 255);
  const std::string png = EncodePng(pixels);
  m.data.assign(png.begin(), png.end());
  const std::string bytes = SerialiseWithRos(m);
  const RosCompressedImage image = DecodeRosCompressedImage(bytes);
  EXPECT_EQ(image.header.stamp_ns, kBagStartNs + 42);
  EXPECT_EQ(image.header.frame_id, "left_camera");
  EXPECT_EQ(image.format, m.format);
  EXPECT_EQ(image.data, m.data);
  ExpectEveryCutRefused(bytes, "sensor_msgs/CompressedImage", DecodeRosCompressedImage);
}

TEST(RosSensorMsgs, CameraInfoComesBackFieldByField) {
  RosCameraInfo m = Content().right_info[1];
  m.binning_x = 2;
  m.roi_x_offset = 3;
  m.roi_width = 4;
  m.roi_do_rectify = true;
  const std::string bytes = SerialiseWithRos(m);
  const RosCameraInfo info = DecodeRosCameraInfo(bytes);
  EXPECT_EQ(info.header.stamp_ns, kBagStartNs + 500'000'000);
  EXPECT_EQ(info.width, 8u);
  EXPECT_EQ(info.height, 6u);
  EXPECT_EQ(info.distortion_model, "plumb_bob");
  EXPECT_EQ(info.header.frame_id, "right_camera");
  EXPECT_EQ(info.d, m.d);
  EXPECT_EQ(info.k, m.k);
  EXPECT_EQ(info.r, m.r);
  EXPECT_EQ(info.p, m.p);
  EXPECT_EQ(info.binning_x, 2u);
  EXPECT_EQ(info.roi_x_offset, 3u);
  EXPECT_EQ(info.roi_width, 4u);
  EXPECT_TRUE(info.roi_do_rectify);
  ExpectEveryCutRefused(bytes, "sensor_msgs/CameraInfo", DecodeRosCameraInfo);
}

// D holds at most the 14 coefficients of OpenCV's largest distortion model; more is refused by
// the count, before anything is allocated for them.
TEST(RosSensorMsgs, CameraInfoWithMoreCoefficientsThanAnyDistortionModelIsRefused) {
  RosCameraInfo m = Content().left_info[0];
  m.distortion_model = "rational_polynomial";
  m.d.assign(kMaxCameraInfoDistortionCoefficients, 0.125);
  EXPECT_EQ(DecodeRosCameraInfo(SerialiseWithRos(m)).d, m.d);
  for (const std::size_t n : {std::size_t{15}, std::size_t{1000}}) {
    m.d.assign(n, 0.125);
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeRosCameraInfo(SerialiseWithRos(m)); },
        "sensor_msgs/CameraInfo: D has " + std::to_string(n) +
            " elements, more than the 14 it may have");
  }
}

TEST(RosSensorMsgs, ImuComesBackFieldByField) {
  const RosImu m = Content().imu[1];
  const std::string bytes = SerialiseWithRos(m);
  const RosImu imu = DecodeRosImu(bytes);
  EXPECT_EQ(imu.header.stamp_ns, kBagStartNs + 10'000'123);
  EXPECT_EQ(imu.header.frame_id, "imu_link");
  EXPECT_EQ(imu.orientation_xyzw, m.orientation_xyzw);
  EXPECT_EQ(imu.orientation_covariance, m.orientation_covariance);
  EXPECT_EQ(imu.angular_velocity, m.angular_velocity);
  EXPECT_EQ(imu.angular_velocity_covariance, m.angular_velocity_covariance);
  EXPECT_EQ(imu.linear_acceleration, m.linear_acceleration);
  EXPECT_EQ(imu.linear_acceleration_covariance, m.linear_acceleration_covariance);
  ExpectEveryCutRefused(bytes, "sensor_msgs/Imu", DecodeRosImu);
}

TEST(RosSensorMsgs, NavSatFixComesBackFieldByField) {
  const RosNavSatFix m = Content().gps[1];
  const std::string bytes = SerialiseWithRos(m);
  const RosNavSatFix fix = DecodeRosNavSatFix(bytes);
  EXPECT_EQ(fix.header.stamp_ns, kBagStartNs + 100'000'007);
  EXPECT_EQ(fix.status, 0);
  EXPECT_EQ(fix.service, 1);
  EXPECT_EQ(fix.header.frame_id, "gps");
  EXPECT_EQ(fix.latitude_deg, m.latitude_deg);
  EXPECT_EQ(fix.longitude_deg, m.longitude_deg);
  EXPECT_EQ(fix.altitude_m, m.altitude_m);
  EXPECT_EQ(fix.position_covariance_m2, m.position_covariance_m2);
  EXPECT_EQ(fix.position_covariance_type, 2);
  ExpectEveryCutRefused(bytes, "sensor_msgs/NavSatFix", DecodeRosNavSatFix);
}

// The md5sums fleetmap checks connections against are the ones ROS's generated types carry.
TEST(RosSensorMsgs, Md5sumsAreRosOwn) {
  EXPECT_EQ(kRosImageMd5, testing::RosMd5Sum("sensor_msgs/Image"));
  EXPECT_EQ(kRosCompressedImageMd5, testing::RosMd5Sum("sensor_msgs/CompressedImage"));
  EXPECT_EQ(kRosCameraInfoMd5, testing::RosMd5Sum("sensor_msgs/CameraInfo"));
  EXPECT_EQ(kRosImuMd5, testing::RosMd5Sum("sensor_msgs/Imu"));
  EXPECT_EQ(kRosNavSatFixMd5, testing::RosMd5Sum("sensor_msgs/NavSatFix"));
}

}  // namespace
}  // namespace fleetmap
