// `fleetmap records import-bag` (fleetmap/stereo/ros_bag_import.h) on bags written by ROS's own
// writer (ros_test_bag.h) from ten real EuRoC stereo frames (cropped), CameraInfo, 50 IMU
// samples and 5 GPS fixes, uncompressed, bz2 and lz4, into SQLite and PostgreSQL indexes: the
// record files hold exactly what the bag held (stamps, every pixel, IMU and GPS values), the
// calibration yields the bag's baseline, and the index points at every record; `fleetmap records
// info` finds no damage. Frames without a partner are counted; every encoding round-trips.
// sensor_msgs/CompressedImage cameras (PNG files of the same frames, image_transport's format
// strings; JPEG beside a raw camera) import pixel for pixel like Image ones. Torn, flipped and
// foreign bags, an unsupported encoding or compressed format, an undecodable compressed image, a
// missing topic and a second import each fail by name and leave the root and the store exactly
// as they were; every flipped byte of a compressed image's PNG fails or imports, never crashes.
// Image bombs (a JPEG or PNG header declaring 32768x32768 or 30000x30000 pixels, a raw image wider
// than any camera, an image larger than its CameraInfo, a CameraInfo with 1000 coefficients) are
// refused by name before anything is decoded, the peak memory barely growing.
#include "fleetmap/stereo/ros_bag_import.h"

#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "euroc_test_data.h"
#include "expect_error.h"
#include "fleetmap/records/record_file.h"
#include "fleetmap/sensors.pb.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_image_log.h"
#include "fleetmap_cli_run.h"
#include "image_files.h"
#include "imported_files.h"
#include "jpeg_test_file.h"
#include "peak_memory.h"
#include "ros_test_bag.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using testing::BagCompression;
using testing::kBagStartNs;

// Ten real frames per camera: EuRoC V1_01 pairs cropped to 96x64 around the image centre.
std::vector<cv::Mat> EurocFrames(int camera) {
  std::vector<cv::Mat> frames;
  std::vector<fs::path> files;
  for (const auto& e : fs::directory_iterator(testing::EurocSequenceDir() /
                                              ("cam" + std::to_string(camera)) / "data")) {
    files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  for (std::size_t i = 0; i < 10 && i < files.size(); ++i) {
    const cv::Mat full = testing::ReadImageFile(files[i * 5], ImagePixels::kGray8);
    frames.push_back(full(cv::Rect(full.cols / 2 - 48, full.rows / 2 - 32, 96, 64)).clone());
  }
  return frames;
}

// The PNG's pixels as the bag's bytes: rows packed, in the message's channel order.
std::string PixelBytes(const std::string& png, const std::string& encoding) {
  cv::Mat m = DecodeImage(png, ImagePixels::kAsStored, "an imported PNG");
  if (encoding == "rgb8") cv::cvtColor(m, m, cv::COLOR_BGR2RGB);
  std::string out;
  for (int r = 0; r < m.rows; ++r) {
    out.append(m.ptr<char>(r), m.cols * m.elemSize());
  }
  return out;
}

std::string Packed(const testing::TestImage& m, std::size_t bytes_per_pixel) {
  std::string out;
  for (std::uint32_t r = 0; r < m.height; ++r) {
    out.append(m.data, std::size_t{r} * m.step, m.width * bytes_per_pixel);
  }
  return out;
}

// A sensor_msgs/CompressedImage as image_transport's compressed plugin makes one: `pixels` as
// a PNG file (EncodePng) or a JPEG file (libjpeg's encoder), as `ext` says (".png", ".jpg").
testing::TestCompressedImage CompressedImageMessage(const cv::Mat& pixels,
                                                    const std::string& format,
                                                    const std::string& ext, std::int64_t stamp_ns) {
  testing::TestCompressedImage m;
  m.stamp_ns = stamp_ns;
  m.format = format;
  const std::string file = ext == ".jpg" ? testing::EncodeJpegForTest(pixels) : EncodePng(pixels);
  m.data.assign(file.begin(), file.end());
  return m;
}

std::string MatBytes(const cv::Mat& m) {
  std::string out;
  for (int r = 0; r < m.rows; ++r) out.append(m.ptr<char>(r), m.cols * m.elemSize());
  return out;
}

template <typename Backend>
class RosBagImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    FLEETMAP_REQUIRE_EUROC_SEQUENCE();
    store_ = GraphStore::Open(backend_.Uri());
  }

  testing::StereoBagContent Content(int pairs = 10) const {
    return testing::MakeStereoBagContent(EurocFrames(0), EurocFrames(1), pairs, 50, 5);
  }
  // Content() with both cameras' images as CompressedImage PNG files of the same frames on
  // image_transport's compressed topics, the left one's format "png", the right one's as the
  // plugin writes it.
  testing::StereoBagContent CompressedContent(int pairs = 10) const {
    testing::StereoBagContent c = Content(pairs);
    const std::vector<cv::Mat> left = EurocFrames(0), right = EurocFrames(1);
    for (std::size_t i = 0; i < c.left.size(); ++i) {
      c.left_compressed.push_back(
          CompressedImageMessage(left[i % left.size()], "png", ".png", c.left[i].stamp_ns));
      c.right_compressed.push_back(CompressedImageMessage(
          right[i % right.size()], "mono8; png compressed mono8", ".png", c.right[i].stamp_ns));
    }
    c.left.clear();
    c.right.clear();
    return c;
  }
  RosBagImportOptions Options() const {
    RosBagImportOptions o;
    o.platform = "husky";
    return o;
  }
  RosBagImportResult Import(const fs::path& bag, const RosBagImportOptions& o) {
    return ImportRosBag(bag, *store_, root_, o);
  }

  // The import of `bag` fails with `code` naming `mention` and changes nothing.
  void ExpectFailsCleanly(const fs::path& bag, ErrorCode code, const std::string& mention,
                          RosBagImportOptions o = {}) {
    if (o.platform.empty()) o.platform = "husky";
    const auto files = testing::FilesUnder(root_);
    store_.reset();  // StoredState reads the store from outside; nothing may be held open
    const std::string state = backend_.StoredState();
    store_ = GraphStore::Open(backend_.Uri());
    ExpectError(
        code, [&] { Import(bag, o); }, mention);
    EXPECT_EQ(testing::FilesUnder(root_), files);
    store_.reset();
    EXPECT_EQ(backend_.StoredState(), state);
    store_ = GraphStore::Open(backend_.Uri());
  }

  Backend backend_;
  ScratchDir dir_{"fleetmap-bag-import"};
  fs::path root_ = dir_ / "root";
  std::unique_ptr<GraphStore> store_;
};

TYPED_TEST_SUITE(RosBagImportTest, testing::StoreBackends, testing::BackendNames);

TYPED_TEST(RosBagImportTest, RecordFilesAndIndexHoldExactlyWhatTheBagHeld) {
  for (const BagCompression compression :
       {BagCompression::kNone, BagCompression::kBz2, BagCompression::kLz4}) {
    const std::string platform = compression == BagCompression::kNone  ? "husky"
                                 : compression == BagCompression::kBz2 ? "husky-bz2"
                                                                       : "husky-lz4";
    SCOPED_TRACE(platform);
    const testing::StereoBagContent c = this->Content();
    const fs::path bag = this->dir_ / (platform + ".bag");
    testing::WriteRosBag(bag, c, compression);
    RosBagImportOptions o = this->Options();
    o.platform = platform;
    o.stereo_sensor = platform + "-stereo";
    o.imu_sensor = platform + "-imu";
    o.gps_sensor = platform + "-gps";
    std::vector<std::uint64_t> progress;
    const RosBagImportResult r = ImportRosBag(bag, *this->store_, this->root_, o,
                                              [&](std::uint64_t done, std::uint64_t total) {
                                                progress.push_back(done);
                                                EXPECT_LE(done, total);
                                              });
    EXPECT_GT(progress.size(), 3u);

    // The summary.
    EXPECT_EQ(r.pairs, 10);
    EXPECT_EQ(r.unmatched_left, 0);
    EXPECT_EQ(r.unmatched_right, 0);
    EXPECT_EQ(r.imu_samples, 50);
    EXPECT_EQ(r.gps_fixes, 5);
    EXPECT_EQ(r.stamped_by_receive_time, 0);
    std::map<std::string, std::pair<std::uint64_t, std::string>> topics;
    for (const RosBagTopicUse& t : r.topics) topics[t.topic] = {t.messages, t.use};
    EXPECT_EQ(topics[c.left_topic], std::make_pair(std::uint64_t{10}, std::string("left images")));
    EXPECT_EQ(topics[c.right_topic],
              std::make_pair(std::uint64_t{10}, std::string("right images")));
    EXPECT_EQ(topics[c.left_info_topic],
              std::make_pair(std::uint64_t{2}, std::string("left camera_info")));
    EXPECT_EQ(topics[c.imu_topic], std::make_pair(std::uint64_t{50}, std::string("imu")));
    EXPECT_EQ(topics[c.gps_topic], std::make_pair(std::uint64_t{5}, std::string("gps")));
    ASSERT_EQ(r.record_files.size(), 3u);
    EXPECT_EQ(r.record_files[0].filename(),
              platform + "-" + platform + "-stereo-20240501-083000.rec");
    EXPECT_EQ(r.index.records, 65);
    EXPECT_EQ(r.index.inserted, 65);

    // Stereo pairs: stamps of the left frames, every pixel of both (padding dropped).
    const std::vector<Record> pairs = testing::RecordsOf(r.record_files[0]);
    ASSERT_EQ(pairs.size(), 10u);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      v1::StereoImagePair pair;
      ASSERT_TRUE(pair.ParseFromString(pairs[i].payload));
      EXPECT_EQ(pairs[i].header.type, "fleetmap.v1.StereoImagePair");
      EXPECT_EQ(pairs[i].header.stamp_ns, c.left[i].stamp_ns);
      EXPECT_EQ(pair.stamp_ns(), c.left[i].stamp_ns);
      EXPECT_EQ(pair.encoding(), "png");
      EXPECT_EQ(pair.width_px(), 96u);
      EXPECT_EQ(pair.height_px(), 64u);
      EXPECT_EQ(pair.left_camera(), o.stereo_sensor + "/cam0");
      EXPECT_EQ(PixelBytes(pair.left_image(), "mono8"), Packed(c.left[i], 1)) << i;
      EXPECT_EQ(PixelBytes(pair.right_image(), "mono8"), Packed(c.right[i], 1)) << i;
    }
    // IMU samples and GPS fixes, value for value.
    const std::vector<Record> imu = testing::RecordsOf(r.record_files[1]);
    ASSERT_EQ(imu.size(), 50u);
    for (std::size_t i = 0; i < imu.size(); ++i) {
      v1::ImuSample s;
      ASSERT_TRUE(s.ParseFromString(imu[i].payload));
      const RosImu& m = c.imu[i];
      EXPECT_EQ(imu[i].header.stamp_ns, m.header.stamp_ns);
      EXPECT_EQ(s.stamp_ns(), m.header.stamp_ns);
      EXPECT_EQ(s.frame(), "imu_link");
      EXPECT_EQ(s.orientation_x(), m.orientation_xyzw[0]);
      EXPECT_EQ(s.orientation_w(), m.orientation_xyzw[3]);
      EXPECT_EQ(s.angular_velocity_z_radps(), m.angular_velocity[2]);
      EXPECT_EQ(s.linear_acceleration_y_mps2(), m.linear_acceleration[1]);
      EXPECT_EQ(s.linear_acceleration_z_mps2(), m.linear_acceleration[2]);
      EXPECT_EQ(
          std::vector<double>(s.orientation_covariance_rad2().begin(),
                              s.orientation_covariance_rad2().end()),
          std::vector<double>(m.orientation_covariance.begin(), m.orientation_covariance.end()));
      EXPECT_EQ(s.angular_velocity_covariance_radps2_size(), 0) << "-1: not given";
      EXPECT_EQ(s.linear_acceleration_covariance_mps2_2_size(), 9);
    }
    const std::vector<Record> gps = testing::RecordsOf(r.record_files[2]);
    ASSERT_EQ(gps.size(), 5u);
    const v1::GpsFix::Status statuses[] = {v1::GpsFix::STATUS_NO_FIX, v1::GpsFix::STATUS_FIX,
                                           v1::GpsFix::STATUS_SBAS_FIX, v1::GpsFix::STATUS_GBAS_FIX,
                                           v1::GpsFix::STATUS_NO_FIX};
    for (std::size_t i = 0; i < gps.size(); ++i) {
      v1::GpsFix f;
      ASSERT_TRUE(f.ParseFromString(gps[i].payload));
      EXPECT_EQ(f.stamp_ns(), c.gps[i].header.stamp_ns);
      EXPECT_EQ(f.latitude_deg(), c.gps[i].latitude_deg);
      EXPECT_EQ(f.longitude_deg(), c.gps[i].longitude_deg);
      EXPECT_EQ(f.altitude_m(), c.gps[i].altitude_m);
      EXPECT_EQ(f.position_covariance_m2_size(), 9);
      EXPECT_EQ(f.status(), statuses[i]);
    }

    // Calibration beside the stereo log: K and D as sent, the baseline from P.
    ASSERT_TRUE(r.baseline_m);
    EXPECT_NEAR(*r.baseline_m, c.baseline_m, 1e-12);
    EXPECT_EQ(r.left_calibration, StereoCalibrationPath(r.record_files[0], 0));
    const PinholeCamera left = LoadEurocCamera(r.left_calibration);
    const PinholeCamera right = LoadEurocCamera(r.right_calibration);
    EXPECT_DOUBLE_EQ(left.fx, c.left_info[0].k[0]);
    EXPECT_DOUBLE_EQ(left.cy, c.left_info[0].k[5]);
    EXPECT_DOUBLE_EQ(left.distortion[0], c.left_info[0].d[0]);
    EXPECT_EQ(left.width_px, 96);
    EXPECT_NEAR((right.body_T_sensor.translation() - left.body_T_sensor.translation()).norm(),
                c.baseline_m, 1e-9);
    EXPECT_NEAR(StereoRectifier(left, right).geometry().baseline_m, c.baseline_m, 1e-6);

    // Indexed: every record, found by time on its sensor.
    SensorIndex& index = this->store_->sensors();
    const std::optional<Platform> p = index.FindPlatform(platform);
    ASSERT_TRUE(p);
    for (const auto& [sensor, records, file] :
         {std::tuple{o.stereo_sensor, &pairs, r.record_files[0]},
          std::tuple{o.imu_sensor, &imu, r.record_files[1]},
          std::tuple{o.gps_sensor, &gps, r.record_files[2]}}) {
      const std::optional<Sensor> s = index.FindSensor(sensor);
      ASSERT_TRUE(s) << sensor;
      const std::vector<Datum> data =
          index.DataOfFile(fs::relative(file, this->root_).generic_string());
      ASSERT_EQ(data.size(), records->size()) << sensor;
      for (std::size_t i = 0; i < data.size(); ++i) {
        EXPECT_EQ(data[i].stamp_ns, (*records)[i].header.stamp_ns);
        EXPECT_EQ(data[i].offset, (*records)[i].location.offset);
      }
      const std::optional<Datum> near =
          index.Nearest(p->id, s->id, (*records)[2].header.stamp_ns + 1);
      ASSERT_TRUE(near);
      EXPECT_EQ(near->stamp_ns, (*records)[2].header.stamp_ns);
    }
  }
}

// Frames whose partner lies beyond the tolerance are counted, not paired, and the ones within
// it still pair; the stamp tolerance is an option.
TYPED_TEST(RosBagImportTest, FramesWithoutAPartnerAreCounted) {
  testing::StereoBagContent c = this->Content(6);
  c.right.erase(c.right.begin() + 2);  // left frame 2 has no partner
  c.right[3].stamp_ns += 5'000'000;    // right frame of pair 4 is 5 ms late
  c.left.erase(c.left.begin() + 5);    // right frame 5 has no partner
  const fs::path bag = this->dir_ / "gaps.bag";
  testing::WriteRosBag(bag, c, BagCompression::kLz4);
  const RosBagImportResult r = this->Import(bag, this->Options());
  EXPECT_EQ(r.pairs, 3);
  EXPECT_EQ(r.unmatched_left, 2);
  EXPECT_EQ(r.unmatched_right, 2);
  std::vector<std::int64_t> stamps;
  for (const Record& rec : testing::RecordsOf(r.record_files[0]))
    stamps.push_back(rec.header.stamp_ns);
  EXPECT_EQ(stamps, (std::vector<std::int64_t>{kBagStartNs, kBagStartNs + 100'000'000,
                                               kBagStartNs + 300'000'000}));

  RosBagImportOptions wide = this->Options();
  wide.platform = "husky-wide";
  wide.stereo_sensor = "wide-stereo";
  wide.imu_sensor = "wide-imu";
  wide.gps_sensor = "wide-gps";
  wide.pair_tolerance_ns = 6'000'000;
  EXPECT_EQ(this->Import(bag, wide).pairs, 4);
}

TYPED_TEST(RosBagImportTest, EveryEncodingRoundTrips) {
  cv::Mat mono16(6, 8, CV_16UC1), colour(6, 8, CV_8UC3);
  cv::randu(mono16, 0, 65535);
  cv::randu(colour, 0, 255);
  int n = 0;
  for (const auto& [encoding, pixels, bpp] :
       {std::tuple{std::string("mono16"), mono16, 2}, std::tuple{std::string("rgb8"), colour, 3},
        std::tuple{std::string("bgr8"), colour, 3}}) {
    SCOPED_TRACE(encoding);
    testing::StereoBagContent c =
        testing::MakeStereoBagContent({pixels}, {pixels}, 2, 0, 0, encoding);
    const fs::path bag = this->dir_ / (encoding + ".bag");
    testing::WriteRosBag(bag, c, BagCompression::kNone);
    RosBagImportOptions o = this->Options();
    o.platform = "p" + std::to_string(n++);
    o.stereo_sensor = o.platform + "-stereo";
    const RosBagImportResult r = this->Import(bag, o);
    ASSERT_EQ(r.pairs, 2);
    const std::vector<Record> records = testing::RecordsOf(r.record_files.at(0));
    for (std::size_t i = 0; i < 2; ++i) {
      v1::StereoImagePair pair;
      ASSERT_TRUE(pair.ParseFromString(records[i].payload));
      EXPECT_EQ(PixelBytes(pair.left_image(), encoding), Packed(c.left[i], bpp));
      EXPECT_EQ(PixelBytes(pair.right_image(), encoding), Packed(c.right[i], bpp));
    }
  }
}

TYPED_TEST(RosBagImportTest, BadBagsFailByNameAndChangeNothing) {
  // Something stored before: an earlier import.
  const testing::StereoBagContent c = this->Content(4);
  const fs::path good = this->dir_ / "good.bag";
  testing::WriteRosBag(good, c, BagCompression::kLz4, 4096);
  this->Import(good, this->Options());
  const std::string bytes = testing::ReadWholeFile(good);

  const fs::path bad = this->dir_ / "bad.bag";
  const auto write = [&](const std::string& b) { std::ofstream(bad, std::ios::binary) << b; };
  this->ExpectFailsCleanly(this->dir_ / "absent.bag", ErrorCode::kNotFound, "absent.bag");
  write("not a bag at all\n");
  this->ExpectFailsCleanly(bad, ErrorCode::kInvalidArgument, "not a ROS bag");
  write(bytes.substr(0, bytes.size() / 2));
  this->ExpectFailsCleanly(bad, ErrorCode::kCorrupt, "truncated");
  std::string flipped = bytes;
  const std::size_t size_field = flipped.find("size=") + 5;
  flipped[size_field] = static_cast<char>(flipped[size_field] ^ 0x01);
  write(flipped);
  this->ExpectFailsCleanly(bad, ErrorCode::kCorrupt, "lz4 data decompress to");
  std::string zst = bytes;
  zst.replace(zst.find("compression=lz4") + 12, 3, "zst");
  write(zst);
  this->ExpectFailsCleanly(bad, ErrorCode::kInvalidArgument, "supported: none, bz2, lz4");

  // A whole bag whose third image is of an encoding fleetmap does not read: named, and nothing
  // of the first two pairs (or of the IMU) is left.
  testing::StereoBagContent bayer = this->Content(4);
  bayer.left[2].encoding = "bayer_rggb8";
  testing::WriteRosBag(bad, bayer, BagCompression::kNone);
  RosBagImportOptions other = this->Options();
  other.platform = "other";
  other.stereo_sensor = "other-stereo";
  other.imu_sensor = "other-imu";
  other.gps_sensor = "other-gps";
  this->ExpectFailsCleanly(bad, ErrorCode::kInvalidArgument,
                           "topic /stereo/left/image_raw, message 3 (chunk at byte", other);
  this->ExpectFailsCleanly(bad, ErrorCode::kInvalidArgument,
                           "image encoding 'bayer_rggb8' is not supported (supported: mono8, "
                           "mono16, rgb8, bgr8)",
                           other);
  // A named topic that is not there, and one of another type.
  RosBagImportOptions missing = other;
  missing.left_topic = "/cam/left";
  missing.right_topic = c.right_topic;
  this->ExpectFailsCleanly(good, ErrorCode::kInvalidArgument,
                           "has no topic /cam/left (--left-topic); its sensor_msgs/Image topics: "
                           "/stereo/left/image_raw, /stereo/right/image_raw",
                           missing);
  missing.left_topic = c.imu_topic;
  this->ExpectFailsCleanly(good, ErrorCode::kInvalidArgument,
                           "topic /imu/data (--left-topic) is sensor_msgs/Imu", missing);
  // The same bag again: its record files exist.
  this->ExpectFailsCleanly(good, ErrorCode::kConflict, "already exists");
}

// CompressedImage cameras import like Image ones: paired by stamp, every pixel of the PNG files
// stored, camera_info found beside image_transport's compressed topics. A JPEG camera beside a
// raw one: its pixels as OpenCV decodes the file.
TYPED_TEST(RosBagImportTest, CompressedImagesImportPixelForPixel) {
  const auto start = std::chrono::steady_clock::now();
  const testing::StereoBagContent c = this->CompressedContent();
  const fs::path bag = this->dir_ / "compressed.bag";
  testing::WriteRosBag(bag, c, BagCompression::kLz4);
  const RosBagImportResult r = this->Import(bag, this->Options());
  EXPECT_EQ(r.pairs, 10);
  EXPECT_EQ(r.unmatched_left, 0);
  EXPECT_EQ(r.unmatched_right, 0);
  EXPECT_EQ(r.imu_samples, 50);
  std::map<std::string, std::tuple<std::string, std::uint64_t, std::string>> topics;
  for (const RosBagTopicUse& t : r.topics) topics[t.topic] = {t.type, t.messages, t.use};
  using Use = std::tuple<std::string, std::uint64_t, std::string>;
  EXPECT_EQ(topics[c.left_compressed_topic], Use("sensor_msgs/CompressedImage", 10, "left images"));
  EXPECT_EQ(topics[c.right_compressed_topic],
            Use("sensor_msgs/CompressedImage", 10, "right images"));
  EXPECT_EQ(topics[c.right_info_topic], Use("sensor_msgs/CameraInfo", 2, "right camera_info"));
  EXPECT_FALSE(topics.contains(c.left_topic));
  ASSERT_TRUE(r.baseline_m);
  EXPECT_NEAR(*r.baseline_m, c.baseline_m, 1e-12);
  const std::vector<cv::Mat> left = EurocFrames(0), right = EurocFrames(1);
  const std::vector<Record> pairs = testing::RecordsOf(r.record_files.at(0));
  ASSERT_EQ(pairs.size(), 10u);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    v1::StereoImagePair pair;
    ASSERT_TRUE(pair.ParseFromString(pairs[i].payload));
    EXPECT_EQ(pairs[i].header.stamp_ns, c.left_compressed[i].stamp_ns);
    EXPECT_EQ(pair.stamp_ns(), c.left_compressed[i].stamp_ns);
    EXPECT_EQ(pair.width_px(), 96u);
    EXPECT_EQ(pair.height_px(), 64u);
    const std::string left_pixels = PixelBytes(pair.left_image(), "mono8");
    EXPECT_EQ(left_pixels, PixelBytes(c.left_compressed[i].data, "mono8")) << i;
    EXPECT_EQ(left_pixels, MatBytes(left[i])) << i;
    const std::string right_pixels = PixelBytes(pair.right_image(), "mono8");
    EXPECT_EQ(right_pixels, PixelBytes(c.right_compressed[i].data, "mono8")) << i;
    EXPECT_EQ(right_pixels, MatBytes(right[i])) << i;
  }

  testing::StereoBagContent mixed = this->Content(4);
  for (std::size_t i = 0; i < mixed.right.size(); ++i) {
    mixed.right_compressed.push_back(CompressedImageMessage(
        right[i], "mono8; jpeg compressed mono8", ".jpg", mixed.right[i].stamp_ns));
  }
  mixed.right.clear();
  const fs::path jpeg_bag = this->dir_ / "jpeg.bag";
  testing::WriteRosBag(jpeg_bag, mixed, BagCompression::kNone);
  RosBagImportOptions o = this->Options();
  o.platform = "husky-jpeg";
  o.stereo_sensor = "jpeg-stereo";
  o.imu_sensor = "jpeg-imu";
  o.gps_sensor = "jpeg-gps";
  const RosBagImportResult j = this->Import(jpeg_bag, o);
  EXPECT_EQ(j.pairs, 4);
  EXPECT_TRUE(j.baseline_m);
  const std::vector<Record> jpeg_pairs = testing::RecordsOf(j.record_files.at(0));
  ASSERT_EQ(jpeg_pairs.size(), 4u);
  for (std::size_t i = 0; i < jpeg_pairs.size(); ++i) {
    v1::StereoImagePair pair;
    ASSERT_TRUE(pair.ParseFromString(jpeg_pairs[i].payload));
    EXPECT_EQ(PixelBytes(pair.left_image(), "mono8"), Packed(mixed.left[i], 1)) << i;
    EXPECT_EQ(PixelBytes(pair.right_image(), "mono8"),
              PixelBytes(mixed.right_compressed[i].data, "mono8"))
        << i;
  }
  std::cout << "[ timing ] compressed imports: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

TYPED_TEST(RosBagImportTest, BadCompressedImagesFailByNameAndChangeNothing) {
  this->Import(
      [&] {
        const fs::path good = this->dir_ / "good.bag";
        testing::WriteRosBag(good, this->CompressedContent(2), BagCompression::kNone);
        return good;
      }(),
      this->Options());
  RosBagImportOptions o = this->Options();
  o.platform = "other";
  o.stereo_sensor = "other-stereo";
  o.imu_sensor = "other-imu";
  o.gps_sensor = "other-gps";
  const fs::path bad = this->dir_ / "bad.bag";
  const auto expect_fails = [&](const auto& change, ErrorCode code,
                                const std::vector<std::string>& mentions) {
    testing::StereoBagContent c = this->CompressedContent(4);
    change(c);
    testing::WriteRosBag(bad, c, BagCompression::kNone);
    for (const std::string& mention : mentions) this->ExpectFailsCleanly(bad, code, mention, o);
  };
  // PNG's signature, then not PNG.
  expect_fails([](auto& c) { c.left_compressed[2].data.resize(20); }, ErrorCode::kCorrupt,
               {"topic /stereo/left/image_raw/compressed, message 3 (chunk at byte",
                "its 20 bytes do not decode as png"});
  expect_fails([](auto& c) { c.right_compressed[1].data = "GIF89a..."; }, ErrorCode::kCorrupt,
               {"topic /stereo/right/image_raw/compressed, message 2",
                "its 9 bytes do not begin as a png file does"});
  expect_fails([](auto& c) { c.left_compressed[0].format = "rgb8; compressedDepth png"; },
               ErrorCode::kInvalidArgument,
               {"sensor_msgs/CompressedImage format 'rgb8; compressedDepth png' is not supported"});
  // A right frame of another size than the left one.
  expect_fails(
      [](auto& c) {
        c.right_compressed[3] =
            CompressedImageMessage(EurocFrames(1)[3](cv::Rect(0, 0, 48, 32)), "png", ".png",
                                   c.right_compressed[3].stamp_ns);
      },
      ErrorCode::kInvalidArgument, {"has a 96x64 left and a 48x32 right image"});
  // A named camera topic of another type.
  RosBagImportOptions wrong = o;
  wrong.left_topic = "/imu/data";
  wrong.right_topic = "/stereo/right/image_raw/compressed";
  testing::WriteRosBag(bad, this->CompressedContent(2), BagCompression::kNone);
  this->ExpectFailsCleanly(
      bad, ErrorCode::kInvalidArgument,
      "is sensor_msgs/Imu, not sensor_msgs/Image or sensor_msgs/CompressedImage", wrong);
}

// CRC-32 of PNG (ISO 3309), computed here so that a file made to declare a size passes it, as an
// attacker's would.
std::uint32_t PngCrc(std::string_view bytes) {
  std::uint32_t c = 0xFFFFFFFFu;
  for (const char b : bytes) {
    c ^= static_cast<unsigned char>(b);
    for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
  }
  return c ^ 0xFFFFFFFFu;
}

std::string BigEndian32(std::uint32_t v) {
  return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
          static_cast<char>(v)};
}

std::string PngChunk(const std::string& type, const std::string& data) {
  return BigEndian32(static_cast<std::uint32_t>(data.size())) + type + data +
         BigEndian32(PngCrc(type + data));
}

// A PNG whose IHDR declares `width` x `height` grey 8-bit pixels, every CRC right, and whose
// IDAT holds a valid zlib stream (RFC 1950/1951: one stored block, its Adler-32) of one row of
// the image: a file of width + 70 bytes.
std::string PngDeclaring(std::uint32_t width, std::uint32_t height) {
  const std::string row(width + 1, '\0');  // filter byte 0, then black pixels
  std::uint32_t a = 1, b = 0;
  for (const char c : row) {
    a = (a + static_cast<unsigned char>(c)) % 65521;
    b = (b + a) % 65521;
  }
  const auto n = static_cast<std::uint16_t>(row.size());
  const std::string zlib = std::string("\x78\x01\x01", 3) +
                           std::string{static_cast<char>(n), static_cast<char>(n >> 8),
                                       static_cast<char>(~n), static_cast<char>(~n >> 8)} +
                           row + BigEndian32(b << 16 | a);
  return std::string("\x89PNG\r\n\x1a\n", 8) +
         PngChunk("IHDR",
                  BigEndian32(width) + BigEndian32(height) + std::string("\x08\0\0\0\0", 5)) +
         PngChunk("IDAT", zlib) + PngChunk("IEND", "");
}

// A real 8x8 grey JPEG (libjpeg's encoder) whose baseline frame header (SOF0) is made to declare
// `width` x `height`: a few hundred bytes that libjpeg would decode into width x height pixels.
std::string JpegDeclaring(std::uint16_t width, std::uint16_t height) {
  std::string jpeg = testing::EncodeJpegForTest(cv::Mat(8, 8, CV_8UC1, cv::Scalar(128)));
  const std::size_t sof = jpeg.find("\xff\xc0");
  EXPECT_NE(sof, std::string::npos);
  EXPECT_EQ(jpeg.substr(sof + 4, 5), std::string("\x08\0\x08\0\x08", 5));  // 8 bits, 8x8
  jpeg[sof + 5] = static_cast<char>(height >> 8);
  jpeg[sof + 6] = static_cast<char>(height);
  jpeg[sof + 7] = static_cast<char>(width >> 8);
  jpeg[sof + 8] = static_cast<char>(width);
  return jpeg;
}

// Image bombs: a bag of a few hundred bytes whose compressed images declare 32768x32768 (JPEG)
// or 30000x30000 (PNG, with a valid zlib stream and every CRC right) is refused from the file's
// header, before a decoder allocates the image: the error names the topic, the message and both
// sizes, the peak memory barely grows, and what an earlier import stored stays. So are a raw
// Image wider than any camera, a PNG larger than its camera's CameraInfo (which came first), and
// a CameraInfo whose D has 1000 coefficients.
TYPED_TEST(RosBagImportTest, ImageBombsAreRefusedBeforeDecoding) {
  const auto start = std::chrono::steady_clock::now();
  const fs::path good = this->dir_ / "good.bag";
  testing::WriteRosBag(good, this->Content(2), BagCompression::kNone);
  this->Import(good, this->Options());  // something stored before
  RosBagImportOptions o = this->Options();
  o.platform = "other";
  o.stereo_sensor = "other-stereo";
  o.imu_sensor = "other-imu";
  o.gps_sensor = "other-gps";

  // One stereo pair of 8x6 frames with their CameraInfo, changed by `change`.
  const fs::path bad = this->dir_ / "bomb.bag";
  const auto write = [&](const auto& change) {
    cv::Mat pixels(6, 8, CV_8UC1, cv::Scalar(7));
    testing::StereoBagContent c = testing::MakeStereoBagContent({pixels}, {pixels}, 1, 0, 0);
    change(c);
    testing::WriteRosBag(bad, c, BagCompression::kNone);
  };
  const auto compressed = [](testing::StereoBagContent& c, const std::string& format,
                             const std::string& data) {
    for (auto [raw, out] :
         {std::pair{&c.left, &c.left_compressed}, std::pair{&c.right, &c.right_compressed}}) {
      out->push_back({raw->front().stamp_ns, "camera", format, data});
      raw->clear();
    }
  };
  // The root and the store are compared with these at the end: no refused import changes them.
  const auto files = testing::FilesUnder(this->root_);
  this->store_.reset();  // StoredState reads the store from outside; nothing may be held open
  const std::string state = this->backend_.StoredState();
  this->store_ = GraphStore::Open(this->backend_.Uri());
  const auto expect_refused_small = [&](ErrorCode code, const std::vector<std::string>& mentions) {
    EXPECT_LT(fs::file_size(bad), 128u << 10);
    testing::ResetPeakMemory();
    const std::int64_t before = testing::PeakMemoryBytes("VmRSS:");
    try {
      this->Import(bad, o);
      ADD_FAILURE() << "the bag was imported";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), code) << e.what();
      for (const std::string& mention : mentions) {
        EXPECT_TRUE(testing::Contains(e.what(), mention))
            << e.what() << "\nshould mention " << mention;
      }
    }
    const std::int64_t grown = testing::PeakMemoryBytes() - before;
    EXPECT_LT(grown, 64 << 20) << "refusing a " << fs::file_size(bad) << "-byte bag took " << grown
                               << " bytes more at its peak";
  };

  write([&](auto& c) { compressed(c, "jpeg", JpegDeclaring(32768, 32768)); });
  expect_refused_small(ErrorCode::kInvalidArgument,
                       {"topic /stereo/left/image_raw/compressed, message 1 (chunk at byte",
                        "sensor_msgs/CompressedImage of format 'jpeg': the jpeg file declares "
                        "32768x32768 pixels, more than the largest camera fleetmap imports "
                        "(8192x8192); refused before decoding"});
  write([&](auto& c) { compressed(c, "png", PngDeclaring(30000, 30000)); });
  expect_refused_small(ErrorCode::kInvalidArgument,
                       {"topic /stereo/left/image_raw/compressed, message 1",
                        "the png file declares 30000x30000 pixels, more than the largest camera "
                        "fleetmap imports (8192x8192)"});
  // A raw image one pixel wider than the limit (its data exactly step x height).
  write([&](auto& c) {
    for (auto* images : {&c.left, &c.right}) {
      images->front() =
          testing::ImageMessage(cv::Mat(1, kMaxRosImageSidePx + 1, CV_8UC1, cv::Scalar(3)), "mono8",
                                images->front().stamp_ns);
    }
  });
  expect_refused_small(ErrorCode::kInvalidArgument,
                       {"topic /stereo/left/image_raw, message 1",
                        "sensor_msgs/Image mono8 declares 8193x1 pixels, more than the largest "
                        "camera fleetmap imports (8192x8192)"});
  // A real PNG of 16x12 where the camera's CameraInfo, recorded before it, says 8x6.
  write([&](auto& c) {
    for (auto* infos : {&c.left_info, &c.right_info}) infos->front().header.stamp_ns -= 1'000'000;
    compressed(c, "png", EncodePng(cv::Mat(12, 16, CV_8UC1, cv::Scalar(9))));
  });
  expect_refused_small(ErrorCode::kCorrupt,
                       {"topic /stereo/left/image_raw/compressed, message 1",
                        "the png file declares 16x12 pixels, more than its camera's CameraInfo "
                        "(8x6); refused before decoding"});
  write([&](auto& c) { c.left_info.front().d.assign(1000, 0.5); });
  expect_refused_small(ErrorCode::kCorrupt,
                       {"topic /stereo/left/camera_info, message 1",
                        "sensor_msgs/CameraInfo: D has 1000 elements, more than the 14 it may "
                        "have"});
  EXPECT_EQ(testing::FilesUnder(this->root_), files);
  this->store_.reset();
  EXPECT_EQ(this->backend_.StoredState(), state);
  std::cout << "[ timing ] image bombs refused: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// Every single byte of one compressed image's PNG flipped in an uncompressed bag (a ROS 1 bag
// has no checksum: the bytes reach OpenCV's decoder, after the signature check): PNG's CRC-32s
// and zlib's Adler-32 cover every byte, so each import fails with Error(kCorrupt) and changes
// nothing; none crashes. SQLite only (the store code is the same on either backend).
TEST(RosBagImportFlips, EveryFlippedByteOfACompressedImageFailsAndChangesNothing) {
  const auto start = std::chrono::steady_clock::now();
  testing::SqliteBackend backend;
  ScratchDir dir("fleetmap-bag-flips");
  const fs::path root = dir / "root";
  std::unique_ptr<GraphStore> store = GraphStore::Open(backend.Uri());
  cv::Mat pixels(6, 8, CV_8UC1);
  cv::randu(pixels, 0, 255);
  testing::StereoBagContent c = testing::MakeStereoBagContent({pixels}, {pixels}, 1, 0, 0);
  c.left_compressed.push_back(CompressedImageMessage(pixels, "png", ".png", c.left[0].stamp_ns));
  c.right_compressed.push_back(CompressedImageMessage(pixels, "png", ".png", c.right[0].stamp_ns));
  c.left.clear();
  c.right.clear();
  const fs::path bag = dir / "flip.bag";
  testing::WriteRosBag(bag, c, BagCompression::kNone);
  RosBagImportOptions o;
  o.platform = "before";
  ImportRosBag(bag, *store, root, o);  // something stored before
  const auto files = testing::FilesUnder(root);
  store.reset();
  const std::string state = backend.StoredState();
  store = GraphStore::Open(backend.Uri());

  const std::string bytes = testing::ReadWholeFile(bag);
  const std::string& png = c.left_compressed[0].data;
  const std::size_t at = bytes.find(png);
  ASSERT_NE(at, std::string::npos);
  o.platform = "hostile";
  for (std::size_t i = at; i < at + png.size(); ++i) {
    std::string flipped = bytes;
    flipped[i] = static_cast<char>(flipped[i] ^ 0xff);
    testing::WriteWholeFile(bag, flipped);
    try {
      ImportRosBag(bag, *store, root, o);
      ADD_FAILURE() << "byte " << i - at << " of the PNG flipped was imported";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kCorrupt) << e.what();
      EXPECT_TRUE(testing::Contains(e.what(), "topic /stereo/left/image_raw/compressed, message 1"))
          << e.what();
    }
  }
  EXPECT_EQ(testing::FilesUnder(root), files);
  store.reset();
  EXPECT_EQ(backend.StoredState(), state);
  std::cout << "[ timing ] " << png.size() << " flips of a compressed image imported: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// The command end to end: the summary, `records info` on what it wrote, and named errors.
TYPED_TEST(RosBagImportTest, CommandImportsAndRecordsInfoFindsNoDamage) {
  const testing::StereoBagContent c = this->Content();
  const fs::path bag = this->dir_ / "drive.bag";
  testing::WriteRosBag(bag, c, BagCompression::kBz2);
  this->store_.reset();
  const std::vector<std::string> args{
      "records", "import-bag", bag.string(),        "--root", this->root_.string(), "--platform",
      "husky",   "--store",    this->backend_.Uri()};
  const testing::CliRun run = testing::RunFleetmapCliExpecting(this->dir_.path(), args, true);
  for (const std::string& line :
       {std::string("10 stereo pairs written (unmatched: 0 left, 0 right), 50 IMU samples, 5 "
                    "GPS fixes"),
        std::string("/stereo/left/image_raw"), std::string("left images"),
        std::string("baseline 0.1100 m"), std::string("65 new index rows")}) {
    EXPECT_TRUE(testing::Contains(run.out, line)) << line << "\n" << run.out;
  }
  std::vector<std::string> info{"records", "info"};
  for (const auto& e : fs::recursive_directory_iterator(this->root_)) {
    if (e.path().extension() == ".rec") info.push_back(e.path().string());
  }
  ASSERT_EQ(info.size(), 5u);
  const testing::CliRun summary = testing::RunFleetmapCliExpecting(this->dir_.path(), info, true);
  EXPECT_TRUE(testing::Contains(summary.out, "10 records")) << summary.out;
  EXPECT_TRUE(testing::Contains(summary.out, "50 records")) << summary.out;
  EXPECT_TRUE(testing::Contains(summary.out, "fleetmap.v1.GpsFix")) << summary.out;
  EXPECT_EQ(summary.err.find("skipped"), std::string::npos) << summary.err;

  const testing::CliRun again = testing::RunFleetmapCliExpecting(this->dir_.path(), args, false);
  EXPECT_TRUE(testing::Contains(again.err, "already exists")) << again.err;
  std::vector<std::string> absent = args;
  absent[2] = (this->dir_ / "absent.bag").string();
  const testing::CliRun none = testing::RunFleetmapCliExpecting(this->dir_.path(), absent, false);
  EXPECT_TRUE(testing::Contains(none.err, "absent.bag: cannot open")) << none.err;
}

}  // namespace
}  // namespace fleetmap
