// `fleetmap records import-bag` (fleetmap/stereo/ros_bag_import.h) on MCAP files written by
// independent writers (tests/support/mcap_test_files.h: @mcap/core's McapWriter and
// @foxglove/cdr's CdrWriter run by node), from six real EuRoC stereo pairs, CameraInfo, 50 IMU
// samples, 5 GPS fixes and a CompressedImage, chunks uncompressed, lz4 and zstd: the record files
// hold exactly what the file held (stamps, every pixel, every IMU and GPS value), the calibration
// yields the CameraInfo's intrinsics and baseline, the CompressedImage topic beside two Image
// cameras is listed as skipped, and the index points at every record; a file whose right camera
// is a CompressedImage topic (the PNG files) imports every pixel of it; the built `fleetmap` does
// the same end to end. A small
// file cut at every length and with every single byte flipped fails each time with a
// fleetmap::Error and leaves the root and the store exactly as they were (what an earlier import
// put there intact). SQLite only: the import's store code is the ROS 1 import's, which
// ros_bag_import_test.cc runs on both backends.
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/records/record_file.h"
#include "fleetmap/sensors.pb.h"
#include "fleetmap/stereo/ros_bag_import.h"
#include "fleetmap/stereo/stereo_calibration.h"
#include "fleetmap/stereo/stereo_image_log.h"
#include "fleetmap_cli_run.h"
#include "image_files.h"
#include "imported_files.h"
#include "mcap_test_files.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using testing::JsonStampNs;
using testing::WrittenMcapFiles;

// A stereo log's PNG as the packed mono8 pixels it holds.
std::string PngPixels(const std::string& png) {
  const cv::Mat m = DecodeImage(png, ImagePixels::kAsStored, "a stereo log's PNG");
  std::string out;
  for (int r = 0; r < m.rows; ++r) out.append(m.ptr<char>(r), m.cols * m.elemSize());
  return out;
}

// The packed pixels of the EuRoC frame an Image message was written from.
std::string FramePixels(const json& image) {
  const cv::Mat m = testing::ReadImageFile(image.at("png").get<std::string>(), ImagePixels::kGray8);
  std::string out;
  for (int r = 0; r < m.rows; ++r) out.append(m.ptr<char>(r), m.cols);
  return out;
}

// written.json's messages of `file` on `topic`, in file order.
std::vector<json> OnTopic(const std::string& file, const std::string& topic) {
  std::vector<json> out;
  for (const json& m : WrittenMcapFiles().Messages(file)) {
    if (m.at("topic") == topic) out.push_back(m.at("message"));
  }
  return out;
}

std::vector<double> Doubles(const json& j) {
  return j.get<std::vector<double>>();
}
template <typename Field>
std::vector<double> Doubles(const Field& repeated) {
  return std::vector<double>(repeated.begin(), repeated.end());
}

class McapImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    FLEETMAP_REQUIRE_MCAP_FILES();
    store_ = GraphStore::Open(backend_.Uri());
  }

  RosBagImportOptions Options(const std::string& platform) const {
    RosBagImportOptions o;
    o.platform = platform;
    o.stereo_sensor = platform + "-stereo";
    o.imu_sensor = platform + "-imu";
    o.gps_sensor = platform + "-gps";
    return o;
  }

  testing::SqliteBackend backend_;
  ScratchDir dir_{"fleetmap-mcap-import"};
  fs::path root_ = dir_ / "root";
  std::unique_ptr<GraphStore> store_;
};

TEST_F(McapImportTest, RecordFilesAndIndexHoldExactlyWhatTheFileHeld) {
  for (const std::string& name : testing::kEurocMcapFiles) {
    SCOPED_TRACE(name);
    const std::string platform = name.substr(0, name.find('.'));
    const RosBagImportOptions o = Options(platform);
    std::vector<std::uint64_t> progress;
    const RosBagImportResult r = ImportRosBag(WrittenMcapFiles().Path(name), *store_, root_, o,
                                              [&](std::uint64_t done, std::uint64_t total) {
                                                EXPECT_LE(done, total);
                                                progress.push_back(done);
                                              });
    EXPECT_GT(progress.size(), 3u);

    // The summary: every topic, the CompressedImage one skipped.
    EXPECT_EQ(r.pairs, 6);
    EXPECT_EQ(r.unmatched_left, 0);
    EXPECT_EQ(r.unmatched_right, 0);
    EXPECT_EQ(r.imu_samples, 50);
    EXPECT_EQ(r.gps_fixes, 5);
    EXPECT_EQ(r.stamped_by_receive_time, 0);
    std::map<std::string, std::tuple<std::string, std::uint64_t, std::string>> topics;
    for (const RosBagTopicUse& t : r.topics) topics[t.topic] = {t.type, t.messages, t.use};
    using Use = std::tuple<std::string, std::uint64_t, std::string>;
    EXPECT_EQ(topics["/stereo/left/image_raw"], Use("sensor_msgs/msg/Image", 6, "left images"));
    EXPECT_EQ(topics["/stereo/right/image_raw"], Use("sensor_msgs/msg/Image", 6, "right images"));
    EXPECT_EQ(topics["/stereo/left/camera_info"],
              Use("sensor_msgs/msg/CameraInfo", 2, "left camera_info"));
    EXPECT_EQ(topics["/stereo/right/camera_info"],
              Use("sensor_msgs/msg/CameraInfo", 2, "right camera_info"));
    EXPECT_EQ(topics["/imu/data"], Use("sensor_msgs/msg/Imu", 50, "imu"));
    EXPECT_EQ(topics["/gps/fix"], Use("sensor_msgs/msg/NavSatFix", 5, "gps"));
    EXPECT_EQ(topics["/stereo/left/image_raw/compressed"],
              Use("sensor_msgs/msg/CompressedImage", 1, "skipped"));
    ASSERT_EQ(r.record_files.size(), 3u);
    EXPECT_EQ(r.index.records, 61);
    EXPECT_EQ(r.index.inserted, 61);

    // Stereo pairs: the left frames' stamps, every pixel of both (the padding dropped).
    const std::vector<json> left = OnTopic(name, "/stereo/left/image_raw");
    const std::vector<json> right = OnTopic(name, "/stereo/right/image_raw");
    const std::vector<Record> pairs = testing::RecordsOf(r.record_files[0]);
    ASSERT_EQ(pairs.size(), 6u);
    for (std::size_t i = 0; i < pairs.size(); ++i) {
      v1::StereoImagePair pair;
      ASSERT_TRUE(pair.ParseFromString(pairs[i].payload));
      EXPECT_EQ(pairs[i].header.stamp_ns, JsonStampNs(left[i].at("header")));
      EXPECT_EQ(pair.stamp_ns(), JsonStampNs(left[i].at("header")));
      EXPECT_EQ(pair.width_px(), 752u);
      EXPECT_EQ(pair.height_px(), 480u);
      EXPECT_EQ(pair.left_camera(), o.stereo_sensor + "/cam0");
      EXPECT_TRUE(PngPixels(pair.left_image()) == FramePixels(left[i])) << "left pixels " << i;
      EXPECT_TRUE(PngPixels(pair.right_image()) == FramePixels(right[i])) << "right pixels " << i;
    }
    EXPECT_EQ(left[1].at("pad"), 4) << "the writer pads one left image's rows";

    // IMU samples and GPS fixes, value for value.
    const std::vector<json> imu_written = OnTopic(name, "/imu/data");
    const std::vector<Record> imu = testing::RecordsOf(r.record_files[1]);
    ASSERT_EQ(imu.size(), imu_written.size());
    for (std::size_t i = 0; i < imu.size(); ++i) {
      v1::ImuSample s;
      ASSERT_TRUE(s.ParseFromString(imu[i].payload));
      const json& m = imu_written[i];
      const std::vector<double> q = Doubles(m.at("orientation"));
      const std::vector<double> w = Doubles(m.at("angular_velocity"));
      const std::vector<double> a = Doubles(m.at("linear_acceleration"));
      EXPECT_EQ(imu[i].header.stamp_ns, JsonStampNs(m.at("header")));
      EXPECT_EQ(s.stamp_ns(), JsonStampNs(m.at("header")));
      EXPECT_EQ(s.frame(), "imu_link");
      EXPECT_EQ((std::vector<double>{s.orientation_x(), s.orientation_y(), s.orientation_z(),
                                     s.orientation_w()}),
                q);
      EXPECT_EQ((std::vector<double>{s.angular_velocity_x_radps(), s.angular_velocity_y_radps(),
                                     s.angular_velocity_z_radps()}),
                w);
      EXPECT_EQ((std::vector<double>{s.linear_acceleration_x_mps2(), s.linear_acceleration_y_mps2(),
                                     s.linear_acceleration_z_mps2()}),
                a);
      EXPECT_EQ(Doubles(s.orientation_covariance_rad2()), Doubles(m.at("orientation_covariance")));
      EXPECT_EQ(s.angular_velocity_covariance_radps2_size(), 0) << "-1: not given";
      EXPECT_EQ(Doubles(s.linear_acceleration_covariance_mps2_2()),
                Doubles(m.at("linear_acceleration_covariance")));
    }
    const std::vector<json> gps_written = OnTopic(name, "/gps/fix");
    const std::vector<Record> gps = testing::RecordsOf(r.record_files[2]);
    ASSERT_EQ(gps.size(), gps_written.size());
    const v1::GpsFix::Status statuses[] = {v1::GpsFix::STATUS_NO_FIX, v1::GpsFix::STATUS_FIX,
                                           v1::GpsFix::STATUS_SBAS_FIX, v1::GpsFix::STATUS_GBAS_FIX,
                                           v1::GpsFix::STATUS_NO_FIX};
    for (std::size_t i = 0; i < gps.size(); ++i) {
      v1::GpsFix f;
      ASSERT_TRUE(f.ParseFromString(gps[i].payload));
      const json& m = gps_written[i];
      EXPECT_EQ(gps[i].header.stamp_ns, JsonStampNs(m.at("header")));
      EXPECT_EQ(f.stamp_ns(), JsonStampNs(m.at("header")));
      EXPECT_EQ(f.latitude_deg(), m.at("latitude").get<double>());
      EXPECT_EQ(f.longitude_deg(), m.at("longitude").get<double>());
      EXPECT_EQ(f.altitude_m(), m.at("altitude").get<double>());
      EXPECT_EQ(Doubles(f.position_covariance_m2()), Doubles(m.at("position_covariance")));
      EXPECT_EQ(f.status(), statuses[i]);
    }

    // Calibration beside the stereo log: K and D of the first CameraInfo, the baseline from P.
    const json info = OnTopic(name, "/stereo/left/camera_info").at(0);
    const double baseline = -Doubles(OnTopic(name, "/stereo/right/camera_info").at(0).at("p"))[3] /
                            Doubles(info.at("p"))[0];
    ASSERT_TRUE(r.baseline_m);
    EXPECT_NEAR(*r.baseline_m, baseline, 1e-12);
    EXPECT_NEAR(*r.baseline_m, 0.11, 1e-12);
    const PinholeCamera cam0 = LoadEurocCamera(r.left_calibration);
    EXPECT_DOUBLE_EQ(cam0.fx, Doubles(info.at("k"))[0]);
    EXPECT_DOUBLE_EQ(cam0.fy, Doubles(info.at("k"))[4]);
    EXPECT_DOUBLE_EQ(cam0.cx, Doubles(info.at("k"))[2]);
    EXPECT_DOUBLE_EQ(cam0.cy, Doubles(info.at("k"))[5]);
    const std::vector<double> d = Doubles(info.at("d"));
    ASSERT_EQ(d.size(), cam0.distortion.size());
    for (std::size_t i = 0; i < d.size(); ++i) EXPECT_DOUBLE_EQ(cam0.distortion[i], d[i]);
    EXPECT_EQ(cam0.width_px, 752);
    EXPECT_EQ(cam0.height_px, 480);

    // Indexed: every record, on its sensor.
    SensorIndex& index = store_->sensors();
    ASSERT_TRUE(index.FindPlatform(platform));
    for (const auto& [records, file] :
         {std::pair{&pairs, r.record_files[0]}, std::pair{&imu, r.record_files[1]},
          std::pair{&gps, r.record_files[2]}}) {
      const std::vector<Datum> data = index.DataOfFile(fs::relative(file, root_).generic_string());
      ASSERT_EQ(data.size(), records->size());
      for (std::size_t i = 0; i < data.size(); ++i) {
        EXPECT_EQ(data[i].stamp_ns, (*records)[i].header.stamp_ns);
        EXPECT_EQ(data[i].offset, (*records)[i].location.offset);
      }
    }
  }
}

// The right camera as sensor_msgs/msg/CompressedImage PNG files on image_transport's compressed
// topic, beside an Image left camera: the two are the cameras, paired by stamp; every pixel of
// the PNG files is stored (lossless), and the camera_info beside the compressed topic's image
// topic gives the calibration.
TEST_F(McapImportTest, ACompressedImageCameraImportsEveryPixel) {
  const auto start = std::chrono::steady_clock::now();
  const std::string name = testing::kCompressedMcapFile;
  const RosBagImportOptions o = Options("compressed");
  const RosBagImportResult r = ImportRosBag(WrittenMcapFiles().Path(name), *store_, root_, o);
  EXPECT_EQ(r.pairs, 6);
  EXPECT_EQ(r.unmatched_left, 0);
  EXPECT_EQ(r.unmatched_right, 0);
  EXPECT_EQ(r.imu_samples, 50);
  EXPECT_EQ(r.gps_fixes, 5);
  std::map<std::string, std::tuple<std::string, std::uint64_t, std::string>> topics;
  for (const RosBagTopicUse& t : r.topics) topics[t.topic] = {t.type, t.messages, t.use};
  using Use = std::tuple<std::string, std::uint64_t, std::string>;
  EXPECT_EQ(topics["/stereo/left/image_raw"], Use("sensor_msgs/msg/Image", 6, "left images"));
  EXPECT_EQ(topics["/stereo/right/image_raw/compressed"],
            Use("sensor_msgs/msg/CompressedImage", 6, "right images"));
  EXPECT_EQ(topics["/stereo/right/camera_info"],
            Use("sensor_msgs/msg/CameraInfo", 2, "right camera_info"));
  EXPECT_EQ(r.topics.size(), 6u);
  ASSERT_TRUE(r.baseline_m);
  EXPECT_NEAR(*r.baseline_m, 0.11, 1e-12);

  const std::vector<json> left = OnTopic(name, "/stereo/left/image_raw");
  const std::vector<json> right = OnTopic(name, "/stereo/right/image_raw/compressed");
  ASSERT_EQ(right.size(), 6u);
  EXPECT_EQ(right[1].at("format"), "mono8; png compressed mono8");
  const std::vector<Record> pairs = testing::RecordsOf(r.record_files.at(0));
  ASSERT_EQ(pairs.size(), 6u);
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    v1::StereoImagePair pair;
    ASSERT_TRUE(pair.ParseFromString(pairs[i].payload));
    EXPECT_EQ(pairs[i].header.stamp_ns, JsonStampNs(left[i].at("header")));
    EXPECT_EQ(pair.width_px(), 752u);
    EXPECT_EQ(pair.height_px(), 480u);
    EXPECT_TRUE(PngPixels(pair.left_image()) == FramePixels(left[i])) << "left pixels " << i;
    const std::string right_pixels = PngPixels(pair.right_image());
    EXPECT_EQ(right_pixels.size(), 752u * 480u);
    EXPECT_TRUE(right_pixels == FramePixels(right[i])) << "right pixels " << i;
  }
  std::cout << "[ timing ] compressed camera imported: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// A small file cut at every length, and with every single byte flipped, fails each time with a
// fleetmap::Error, writes nothing under the root, indexes nothing, and leaves what an earlier
// import put there as it was.
TEST_F(McapImportTest, EveryCutAndFlippedByteFailsAndChangesNothing) {
  const auto start = std::chrono::steady_clock::now();
  ImportRosBag(WrittenMcapFiles().Path("small-none.mcap"), *store_, root_, Options("before"));
  const auto files = testing::FilesUnder(root_);
  ASSERT_FALSE(files.empty());
  store_.reset();
  const std::string state = backend_.StoredState();
  store_ = GraphStore::Open(backend_.Uri());

  const fs::path bad = dir_ / "bad.mcap";
  const RosBagImportOptions o = Options("hostile");
  int failures = 0;
  const auto expect_fails = [&](const std::string& what) {
    try {
      ImportRosBag(bad, *store_, root_, o);
      ADD_FAILURE() << what << " was imported";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(bad.string()), std::string::npos) << e.what();
    } catch (const std::exception& e) {
      ADD_FAILURE() << what << ": not a fleetmap::Error: " << e.what();
    }
    // What a wrong import would write first; the whole root is compared at the end.
    if (fs::exists(root_ / "hostile") && ++failures < 5) {
      ADD_FAILURE() << what << " wrote under the root";
    }
  };

  const std::string cut = testing::ReadWholeFile(WrittenMcapFiles().Path("small-lz4.mcap"));
  testing::WriteWholeFile(bad, cut);
  for (std::size_t n = cut.size(); n-- > 0;) {
    fs::resize_file(bad, n);  // shorter and shorter in place
    expect_fails("cut to " + std::to_string(n) + " bytes");
  }
  const std::string bytes = testing::ReadWholeFile(WrittenMcapFiles().Path("small-zstd.mcap"));
  testing::WriteWholeFile(bad, bytes);
  std::fstream flip(bad, std::ios::in | std::ios::out | std::ios::binary);
  const auto put = [&](std::size_t at, char byte) {
    flip.seekp(static_cast<std::streamoff>(at));
    flip.put(byte);
    flip.flush();
  };
  for (std::size_t i = 0; i < bytes.size(); ++i) {
    put(i, static_cast<char>(bytes[i] ^ 0xff));
    expect_fails("byte " + std::to_string(i) + " flipped");
    put(i, bytes[i]);
  }
  EXPECT_EQ(testing::FilesUnder(root_), files);
  EXPECT_FALSE(store_->sensors().FindPlatform("hostile"));
  store_.reset();
  EXPECT_EQ(backend_.StoredState(), state);
  std::cout << "[ timing ] " << cut.size() << " cuts and " << bytes.size() << " flips imported: "
            << std::chrono::duration_cast<std::chrono::milliseconds>(
                   std::chrono::steady_clock::now() - start)
                   .count()
            << " ms\n";
}

// The command end to end on an MCAP file: the summary names ROS 2's types and the skipped
// CompressedImage topic; `records info` finds no damage; a foreign file is named.
TEST_F(McapImportTest, CommandImportsAnMcapFile) {
  store_.reset();
  const std::vector<std::string> args{
      "records", "import-bag",   WrittenMcapFiles().Path("euroc-zstd.mcap").string(),
      "--root",  root_.string(), "--platform",
      "drone",   "--store",      backend_.Uri()};
  const testing::CliRun run = testing::RunFleetmapCliExpecting(dir_.path(), args, true);
  for (const std::string& line :
       {std::string("6 stereo pairs written (unmatched: 0 left, 0 right), 50 IMU samples, 5 GPS "
                    "fixes"),
        std::string("sensor_msgs/msg/Image"), std::string("left images"),
        std::string("sensor_msgs/msg/CompressedImage"), std::string("skipped"),
        std::string("baseline 0.1100 m"), std::string("61 new index rows")}) {
    EXPECT_TRUE(testing::Contains(run.out, line)) << line << "\n" << run.out;
  }
  std::vector<std::string> info{"records", "info"};
  for (const auto& e : fs::recursive_directory_iterator(root_)) {
    if (e.path().extension() == ".rec") info.push_back(e.path().string());
  }
  ASSERT_EQ(info.size(), 5u);
  const testing::CliRun summary = testing::RunFleetmapCliExpecting(dir_.path(), info, true);
  EXPECT_TRUE(testing::Contains(summary.out, "fleetmap.v1.StereoImagePair")) << summary.out;
  EXPECT_EQ(summary.err.find("skipped"), std::string::npos) << summary.err;

  std::vector<std::string> foreign = args;
  foreign[2] = (dir_ / "notes.txt").string();
  testing::WriteWholeFile(foreign[2], "not a recording\n");
  const testing::CliRun none = testing::RunFleetmapCliExpecting(dir_.path(), foreign, false);
  EXPECT_TRUE(testing::Contains(none.err, "not a ROS bag or MCAP file")) << none.err;
}

}  // namespace
}  // namespace fleetmap
