// `fleetmap records import-bag FILE`: a ROS 1 bag's or an MCAP file's (rosbag2) stereo images,
// camera calibration, IMU and GNSS messages into record files under a root and the sensor index
// (fleetmap/stereo/ros_bag_import.h). Prints what became of every topic of the file.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <iostream>
#include <memory>
#include <string>

#include "commands.h"
#include "fleetmap/stereo/ros_bag_import.h"
#include "fleetmap/store/graph_store.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct ImportBagArgs {
  std::string bag;
  std::string root;
  RosBagImportOptions options;
  double pair_tolerance_ms = 1.0;
  std::string store;
};

void PrintSummary(const RosBagImportResult& r, const std::string& uri) {
  std::printf("%-40s %-32s %9s  %s\n", "topic", "type", "messages", "imported as");
  for (const RosBagTopicUse& t : r.topics) {
    std::printf("%-40s %-32s %9llu  %s\n", t.topic.c_str(), t.type.c_str(),
                static_cast<unsigned long long>(t.messages), t.use.c_str());
  }
  std::printf("%s written", Count(r.pairs, "stereo pair").c_str());
  if (r.pairs > 0 || r.unmatched_left > 0 || r.unmatched_right > 0) {
    std::printf(" (unmatched: %lld left, %lld right)", static_cast<long long>(r.unmatched_left),
                static_cast<long long>(r.unmatched_right));
  }
  std::printf(", %s, %s\n", Count(r.imu_samples, "IMU sample").c_str(),
              Count(r.gps_fixes, "GPS fix", "GPS fixes").c_str());
  if (r.stamped_by_receive_time > 0) {
    std::printf("%s without a header stamp, stamped with the bag's receive time\n",
                Count(r.stamped_by_receive_time, "message").c_str());
  }
  if (r.baseline_m) {
    std::printf("calibration: %s, %s (baseline %.4f m)\n", r.left_calibration.c_str(),
                r.right_calibration.c_str(), *r.baseline_m);
  } else if (!r.calibration_note.empty()) {
    std::printf("%s\n", r.calibration_note.c_str());
  }
  for (const auto& file : r.record_files) std::printf("wrote %s\n", file.c_str());
  std::printf("%s in %s\n", Count(r.index.inserted, "new index row").c_str(), uri.c_str());
}

void RunImportBag(ImportBagArgs& args) {
  if (!(args.pair_tolerance_ms >= 0)) {
    throw Error(ErrorCode::kInvalidArgument, "--pair-tolerance-ms must not be negative");
  }
  args.options.pair_tolerance_ns = static_cast<std::int64_t>(args.pair_tolerance_ms * 1e6);
  auto store = GraphStore::Open(args.store);
  ProgressBar bar("import-bag", std::cerr);
  const RosBagImportResult r = ImportRosBag(
      args.bag, *store, args.root, args.options, [&](std::uint64_t done, std::uint64_t total) {
        bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(total));
      });
  bar.Finish();
  PrintSummary(r, store->uri());
}

}  // namespace

void AddRecordsImportBagCommand(CLI::App& records) {
  auto args = std::make_shared<ImportBagArgs>();
  CLI::App* cmd = records.add_subcommand(
      "import-bag",
      "Import a ROS 1 bag's or an MCAP file's stereo images, calibration, IMU and GPS into "
      "record files");
  cmd->footer(
      "Reads a ROS 1 bag (format 2.0; chunks uncompressed, bz2 or lz4) or an MCAP file (rosbag2's "
      "format since ROS 2 Iron; chunks uncompressed, lz4 or zstd; ROS 2 messages in CDR), told "
      "apart by their first bytes, and writes, under --root in the layout "
      "PLATFORM/SENSOR/YYYY-MM-DD/..., one record file per sensor, indexed in --store (the types "
      "below are ROS 2's sensor_msgs/msg/... in an MCAP file):\n"
      "  stereo pairs: two camera topics, each sensor_msgs/Image or sensor_msgs/CompressedImage "
      "(--left-topic, --right-topic; by default the bag's two Image topics, else its Image and "
      "CompressedImage topics if they are two, when their names say left and right), frames "
      "paired by header stamp within --pair-tolerance-ms, as fleetmap.v1.StereoImagePair "
      "records holding PNG images (lossless; encodings mono8, mono16, rgb8, bgr8; compressed "
      "formats png, jpeg and image_transport's \"ENC; png compressed ENC\", \"ENC; jpeg "
      "compressed ENC\", decoded by OpenCV); unpaired frames are counted;\n"
      "  calibration: the first sensor_msgs/CameraInfo of each camera (by default the "
      "camera_info topic beside each image topic, or beside IMAGE of IMAGE/compressed) as "
      "EuRoC sensor.yaml files beside the stereo "
      "log (K and D; the right camera's pose from R and the baseline in P);\n"
      "  IMU and GPS: the bag's sensor_msgs/Imu and sensor_msgs/NavSatFix topic (--imu-topic, "
      "--gps-topic when it has several) as fleetmap.v1.ImuSample and fleetmap.v1.GpsFix.\n"
      "Records carry the header stamp (the receive time when it is 0). Other topics are skipped; "
      "the summary lists every topic with its messages and what it became. A missing, torn or "
      "corrupt bag, an unsupported compression, image encoding or compressed format, a "
      "compressed image that does not decode, or a topic that is missing or "
      "of another type is named in the error; on any error nothing is written under the root "
      "and nothing is indexed. Importing a bag twice is refused (conflict).");
  // The bounds an image bomb meets, from the constants that enforce them.
  const std::string side = std::to_string(kMaxRosImageSidePx);
  cmd->footer(cmd->get_footer() + "\nImages are at most " + side + "x" + side +
              " pixels (the largest camera a robot carries) and no larger than their camera's "
              "CameraInfo when it comes first: each image's size is read from its message or its "
              "file's header (PNG IHDR, JPEG SOFn) before it is decoded, so one image takes at "
              "most " +
              std::to_string((std::uint64_t{kMaxRosImageSidePx} * kMaxRosImageSidePx * 4) >> 20) +
              " MiB of pixels whatever the file declares. A CameraInfo's D has at most 14 "
              "coefficients. An image or CameraInfo beyond these bounds is refused by name.");
  cmd->add_option("bag", args->bag, "The ROS 1 bag (.bag) or MCAP file (.mcap)")->required();
  cmd->add_option("--root", args->root, "The repository root of record files")->required();
  cmd->add_option("--platform", args->options.platform, "The platform that recorded the bag")
      ->required();
  cmd->add_option("--left-topic", args->options.left_topic,
                  "The left camera's Image or CompressedImage topic");
  cmd->add_option("--right-topic", args->options.right_topic,
                  "The right camera's Image or CompressedImage topic");
  cmd->add_option("--left-info-topic", args->options.left_info_topic,
                  "The left camera's CameraInfo topic [default: camera_info beside its images]");
  cmd->add_option("--right-info-topic", args->options.right_info_topic,
                  "The right camera's CameraInfo topic [default: camera_info beside its images]");
  cmd->add_option("--imu-topic", args->options.imu_topic,
                  "The Imu topic [default: the bag's only one]");
  cmd->add_option("--gps-topic", args->options.gps_topic,
                  "The NavSatFix topic [default: the bag's only one]");
  cmd->add_option("--pair-tolerance-ms", args->pair_tolerance_ms,
                  "Largest stamp difference of a left and a right frame that pair")
      ->capture_default_str();
  cmd->add_option("--stereo-sensor", args->options.stereo_sensor, "Sensor name of the pairs")
      ->capture_default_str();
  cmd->add_option("--imu-sensor", args->options.imu_sensor, "Sensor name of the IMU")
      ->capture_default_str();
  cmd->add_option("--gps-sensor", args->options.gps_sensor, "Sensor name of the GPS")
      ->capture_default_str();
  AddStoreOption(*cmd, args->store);
  cmd->callback([args] { RunImportBag(*args); });
}

}  // namespace fleetmap::cli
