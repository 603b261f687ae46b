// ROS recordings as raw sensor data (seed 000 §5.1): `fleetmap records import-bag FILE` reads a
// ROS 1 bag or an MCAP file (rosbag2's format), told apart by their first bytes
// (fleetmap/rosbag/recording_reader.h), and writes what fleetmap keeps of it into record files
// under a root, in the platform/sensor/date layout (record_layout.h), indexed in the store's
// sensor index (sensor_ingest.h), as `images ingest` does for stereo folders
// (stereo_image_log.h). The same types are read from either format (ROS 2's sensor_msgs/msg/...
// in an MCAP file) and converted the same way; below, "bag" means either:
//
//   stereo pairs   two camera topics, each sensor_msgs/Image or sensor_msgs/CompressedImage,
//                  frames paired by header stamp within a tolerance (unpaired frames
//                  counted), one fleetmap.v1.StereoImagePair per pair holding both images as
//                  PNG (lossless; mono8, mono16, rgb8, bgr8; a CompressedImage's PNG or JPEG
//                  decoded by OpenCV, its pixels stored as decoded: grey 8 or 16 bit, or
//                  colour), cameras named SENSOR/cam0 (left) and SENSOR/cam1 (right);
//   calibration    the two topics' sensor_msgs/CameraInfo (the first of each) as EuRoC
//                  sensor.yaml files beside the stereo log (StereoCalibrationPath), with the
//                  right camera's pose from R and P (camera_info_calibration.h);
//   IMU, GNSS      a sensor_msgs/Imu topic as fleetmap.v1.ImuSample records, a
//                  sensor_msgs/NavSatFix topic as fleetmap.v1.GpsFix records.
//
// Records are stamped with the message's header stamp (capture time); a message whose header
// stamp is 0 gets the bag's receive time (an MCAP message's log time) instead, and is counted.
// Every other topic (a CompressedImage topic beside two Image cameras among them) is skipped and
// listed.
//
// Image bombs: a file of a few hundred bytes can declare an image of 32768 x 32768 pixels, which
// a decoder would allocate (and fill with what the data do not give). Every image's size is
// checked before anything is decoded or allocated for it, from the message (sensor_msgs/Image:
// width and height, data exactly step x height bytes) or from the compressed file's header (PNG's
// IHDR, JPEG's SOFn): no side over kMaxRosImageSidePx, and none larger than its camera's
// CameraInfo when that came first. So one image's pixels take at most kMaxRosImageSidePx^2 x 4
// bytes (256 MiB) while it is converted, whatever the file declares. A CameraInfo's D has at most
// kMaxCameraInfoDistortionCoefficients (fleetmap/rosbag/sensor_msgs.h; K, R and P have their
// fixed sizes on the wire).
//
// All or nothing: the bag is read once, start to end, each chunk checked before its messages
// are used; record files are written as hidden partial files and renamed into place only when
// the whole bag has been read, and all of them are indexed in one transaction. On any error
// nothing is left under the root and nothing is indexed. Importing the same bag twice is
// refused (Error(kConflict): its record files exist).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/records/sensor_ingest.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap {

// The largest image the import takes, each side in pixels: the largest camera a robot carries.
// An image declaring more is refused (Error(kInvalidArgument) naming the topic, the message and
// both sizes) before it is decoded.
inline constexpr std::uint32_t kMaxRosImageSidePx = 8192;

struct RosBagImportOptions {
  std::string platform;
  // The stereo pair's camera topics (sensor_msgs/Image or CompressedImage). Both empty: the
  // bag's two Image topics, or, when it has not two, its Image and CompressedImage topics when
  // they are two (image_transport's ".../image_raw/compressed" recorded instead of the raw
  // ones), provided their names tell left from right ("left"/"right", "cam0"/"cam1",
  // "image_0"/"image_1"); with one given, the other of those two (of the bag's two
  // CompressedImage topics when the given one is one of them).
  std::string left_topic, right_topic;
  // Empty: the "camera_info" topic beside each image topic ("/cam/left/image_raw" ->
  // "/cam/left/camera_info"; "/cam/left/image_raw/compressed" -> "/cam/left/camera_info"), when
  // the bag holds it.
  std::string left_info_topic, right_info_topic;
  // Empty: the bag's only sensor_msgs/Imu (NavSatFix) topic, if it holds one.
  std::string imu_topic, gps_topic;
  std::int64_t pair_tolerance_ns = 1'000'000;
  std::string stereo_sensor = "stereo", imu_sensor = "imu", gps_sensor = "gps";
};

// What became of one topic of the bag.
struct RosBagTopicUse {
  std::string topic;
  std::string type;
  std::uint64_t messages = 0;
  std::string use;  // "left images", "right images", "left camera_info", ..., "imu", "gps",
                    // or "skipped"
};

struct RosBagImportResult {
  std::vector<RosBagTopicUse> topics;  // every topic of the bag, by name
  std::int64_t pairs = 0;
  std::int64_t unmatched_left = 0, unmatched_right = 0;  // frames without a partner
  std::int64_t imu_samples = 0, gps_fixes = 0;
  std::int64_t stamped_by_receive_time = 0;         // messages whose header stamp was 0
  std::vector<std::filesystem::path> record_files;  // written, absolute
  // The calibration files beside the stereo log; empty when none was stored, and then
  // `calibration_note` says why.
  std::filesystem::path left_calibration, right_calibration;
  std::optional<double> baseline_m;
  std::string calibration_note;
  IngestResult index;  // over all record files
};

// Imports `bag` as the file comment says. REQUIRES: no Transaction open on `store`. `progress`
// gets (bag bytes read, bag bytes) per chunk. Throws the readers' errors (kNotFound,
// kInvalidArgument, kCorrupt, naming the file and the offset), Error(kInvalidArgument) naming a
// topic that is missing or of another type, ambiguous topics (with the candidates), an
// unsupported image encoding or CompressedImage format (with the supported ones), images of two
// sizes in one stereo log, an image larger than kMaxRosImageSidePx, or a bag with nothing to
// import, and Error(kCorrupt) naming the topic, message and chunk offset for a message that does
// not decode (a CompressedImage whose bytes are not a PNG or JPEG OpenCV decodes among them, an
// image larger than its camera's CameraInfo, a CameraInfo with too many coefficients in D).
RosBagImportResult ImportRosBag(
    const std::filesystem::path& bag, GraphStore& store, const std::filesystem::path& root,
    const RosBagImportOptions& options,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress = {});

}  // namespace fleetmap
