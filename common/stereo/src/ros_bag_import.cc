// A ROS 1 bag or an MCAP file into record files and the sensor index (ros_bag_import.h).
#include "fleetmap/stereo/ros_bag_import.h"

#include <algorithm>
#include <cctype>
#include <map>
#include <memory>
#include <optional>
#include <string_view>
#include <utility>
#include <vector>

#include "camera_info_calibration.h"
#include "fleetmap/core/error.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/rosbag/recording_reader.h"
#include "fleetmap/rosbag/sensor_msgs.h"
#include "fleetmap/sensors.pb.h"
#include "fleetmap/stereo/stereo_image_log.h"
#include "ros_image_png.h"
#include "ros_sensor_records.h"
#include "stereo_stamp_pairing.h"
#include "written_paths.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using internal::StagedRecordFile;
using internal::StereoFrame;

// The file being imported: how messages name it ("ROS bag x.bag", "MCAP file x.mcap") and the
// type names of its format ("sensor_msgs/Image", "sensor_msgs/msg/Image").
struct ImportedFile {
  const RecordingReader& reader;
  std::string label;
  std::string Type(SensorMsgType type) const { return std::string(reader.TypeName(type)); }
};

enum class Role { kSkip, kLeft, kRight, kLeftInfo, kRightInfo, kImu, kGps };

std::string RoleName(Role role) {
  switch (role) {
    case Role::kLeft:
      return "left images";
    case Role::kRight:
      return "right images";
    case Role::kLeftInfo:
      return "left camera_info";
    case Role::kRightInfo:
      return "right camera_info";
    case Role::kImu:
      return "imu";
    case Role::kGps:
      return "gps";
    case Role::kSkip:
      break;
  }
  return "skipped";
}

// The bag's topics (a topic recorded from several publishers has several connections).
struct Topic {
  std::string type;  // as recorded
  SensorMsgType sensor_type = SensorMsgType::kOther;
  std::string undecodable;  // why its messages cannot be decoded (recording_reader.h)
  std::uint64_t messages = 0;
  Role role = Role::kSkip;
};
using Topics = std::map<std::string, Topic>;

std::string Lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

std::string List(const std::vector<std::string>& names) {
  std::string out;
  for (const std::string& n : names) out += (out.empty() ? "" : ", ") + n;
  return out.empty() ? "none" : out;
}

std::vector<std::string> TopicsOfType(const Topics& topics, SensorMsgType type) {
  std::vector<std::string> out;
  for (const auto& [name, t] : topics) {
    if (t.sensor_type == type) out.push_back(name);
  }
  return out;
}

// The bag's image topics, Image and CompressedImage, with the types' names ("its
// sensor_msgs/Image topics: a, b; its sensor_msgs/CompressedImage topics: c").
std::string ImageTopicList(const Topics& topics, const ImportedFile& source) {
  std::string out = "its " + source.Type(SensorMsgType::kImage) +
                    " topics: " + List(TopicsOfType(topics, SensorMsgType::kImage));
  const std::vector<std::string> compressed = TopicsOfType(topics, SensorMsgType::kCompressedImage);
  if (!compressed.empty()) {
    out += "; its " + source.Type(SensorMsgType::kCompressedImage) + " topics: " + List(compressed);
  }
  return out;
}

// Gives `topic` its role, checking it is in the bag with one of `types` (a camera: Image or
// CompressedImage; else one type) and a definition the import decodes.
void Assign(Topics& topics, const std::string& topic, const std::vector<SensorMsgType>& types,
            Role role, const std::string& option, const ImportedFile& source) {
  std::string names;
  for (const SensorMsgType type : types) {
    names += (names.empty() ? "" : " or ") + source.Type(type);
  }
  const auto it = topics.find(topic);
  if (it == topics.end()) {
    throw Error(
        ErrorCode::kInvalidArgument,
        source.label + " has no topic " + topic + " (" + option + "); " +
            (types.size() > 1
                 ? ImageTopicList(topics, source)
                 : "its " + names + " topics: " + List(TopicsOfType(topics, types.front()))));
  }
  if (std::find(types.begin(), types.end(), it->second.sensor_type) == types.end()) {
    throw Error(ErrorCode::kInvalidArgument, source.label + ": topic " + topic + " (" + option +
                                                 ") is " + it->second.type + ", not " + names);
  }
  if (!it->second.undecodable.empty()) {
    throw Error(ErrorCode::kInvalidArgument, source.label + ": topic " + topic + " is " +
                                                 it->second.type + " " + it->second.undecodable +
                                                 "; it cannot be decoded");
  }
  it->second.role = role;
}

const std::vector<SensorMsgType> kCameraTypes = {SensorMsgType::kImage,
                                                 SensorMsgType::kCompressedImage};

// Which of two image topic names is the left camera's: +1 the first, -1 the second, 0 unknown.
int LeftOfTwo(const std::string& a, const std::string& b) {
  const auto side = [](const std::string& name) {
    const std::string n = Lower(name);
    const bool left = n.find("left") != std::string::npos || n.find("cam0") != std::string::npos ||
                      n.find("image_0") != std::string::npos;
    const bool right = n.find("right") != std::string::npos ||
                       n.find("cam1") != std::string::npos ||
                       n.find("image_1") != std::string::npos;
    return left == right ? 0 : (left ? 1 : -1);
  };
  const int sa = side(a), sb = side(b);
  if (sa == 1 && sb == -1) return 1;
  if (sa == -1 && sb == 1) return -1;
  return 0;
}

// "/cam/left/image_raw" -> "/cam/left/camera_info"; image_transport's compressed topic beside
// its image topic too: "/cam/left/image_raw/compressed" -> "/cam/left/camera_info".
std::string InfoBeside(const std::string& image_topic, SensorMsgType type) {
  std::string_view topic = image_topic;
  if (type == SensorMsgType::kCompressedImage && topic.ends_with("/compressed")) {
    topic.remove_suffix(std::string_view("/compressed").size());
  }
  const std::size_t slash = topic.rfind('/');
  return std::string(slash == std::string_view::npos ? std::string_view()
                                                     : topic.substr(0, slash)) +
         "/camera_info";
}

// The two topics the stereo pair is found among when not both are named: the bag's two
// sensor_msgs/Image topics; else (it has not two) its Image and CompressedImage topics together,
// when they are two. With `given` a CompressedImage topic of a bag with two of them, those two.
std::vector<std::string> CameraCandidates(const Topics& topics, const std::string& given) {
  const std::vector<std::string> compressed = TopicsOfType(topics, SensorMsgType::kCompressedImage);
  const auto it = topics.find(given);
  if (it != topics.end() && it->second.sensor_type == SensorMsgType::kCompressedImage &&
      compressed.size() == 2) {
    return compressed;
  }
  std::vector<std::string> images = TopicsOfType(topics, SensorMsgType::kImage);
  if (images.size() == 2) return images;
  images.insert(images.end(), compressed.begin(), compressed.end());
  std::sort(images.begin(), images.end());
  return images;
}

// Decides every topic's role from the options, filling in the topics it detects.
void AssignRoles(Topics& topics, RosBagImportOptions& o, const ImportedFile& source) {
  const std::vector<std::string> images =
      CameraCandidates(topics, o.left_topic.empty() ? o.right_topic : o.left_topic);
  if (o.left_topic.empty() != o.right_topic.empty() && images.size() == 2) {
    std::string& missing = o.left_topic.empty() ? o.left_topic : o.right_topic;
    const std::string& given = o.left_topic.empty() ? o.right_topic : o.left_topic;
    missing = images[0] == given ? images[1] : images[0];
  } else if (o.left_topic.empty() && o.right_topic.empty() && images.size() == 2) {
    const int left = LeftOfTwo(images[0], images[1]);
    if (left == 0) {
      throw Error(ErrorCode::kInvalidArgument,
                  source.label + " has two image topics, " + images[0] + " and " + images[1] +
                      ", whose names do not say which is left: give --left-topic and "
                      "--right-topic");
    }
    o.left_topic = images[left == 1 ? 0 : 1];
    o.right_topic = images[left == 1 ? 1 : 0];
  } else if (o.left_topic.empty() != o.right_topic.empty()) {
    throw Error(ErrorCode::kInvalidArgument, source.label +
                                                 ": give both --left-topic and --right-topic (" +
                                                 ImageTopicList(topics, source) + ")");
  }
  if (!o.left_topic.empty()) {
    if (o.left_topic == o.right_topic) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--left-topic and --right-topic are both " + o.left_topic);
    }
    Assign(topics, o.left_topic, kCameraTypes, Role::kLeft, "--left-topic", source);
    Assign(topics, o.right_topic, kCameraTypes, Role::kRight, "--right-topic", source);
    // camera_info beside each image topic when the bag has it; a named one must be there.
    for (auto [info, image, role, option] :
         {std::tuple{&o.left_info_topic, &o.left_topic, Role::kLeftInfo, "--left-info-topic"},
          std::tuple{&o.right_info_topic, &o.right_topic, Role::kRightInfo,
                     "--right-info-topic"}}) {
      const std::string beside = InfoBeside(*image, topics.at(*image).sensor_type);
      if (info->empty() && topics.contains(beside)) *info = beside;
      if (!info->empty()) {
        Assign(topics, *info, {SensorMsgType::kCameraInfo}, role, option, source);
      }
    }
  }
  for (auto [topic, type, role, option] :
       {std::tuple{&o.imu_topic, SensorMsgType::kImu, Role::kImu, "--imu-topic"},
        std::tuple{&o.gps_topic, SensorMsgType::kNavSatFix, Role::kGps, "--gps-topic"}}) {
    const std::vector<std::string> candidates = TopicsOfType(topics, type);
    if (topic->empty() && candidates.size() > 1) {
      throw Error(ErrorCode::kInvalidArgument, source.label + " has " +
                                                   std::to_string(candidates.size()) + " " +
                                                   source.Type(type) + " topics (" +
                                                   List(candidates) + "): name one with " + option);
    }
    if (topic->empty() && candidates.size() == 1) *topic = candidates[0];
    if (!topic->empty()) Assign(topics, *topic, {type}, role, option, source);
  }
}

// A message's record stamp: its header's, else (0: the driver set none) the receive time.
std::int64_t StampOf(const RosHeader& header, const RecordingMessage& m, std::int64_t& fallbacks) {
  if (header.stamp_ns != 0) return header.stamp_ns;
  ++fallbacks;
  return m.receive_time_ns;
}

void CheckImportOptions(const RosBagImportOptions& options) {
  CheckLayoutName(options.platform, "platform");
  for (const std::string* sensor :
       {&options.stereo_sensor, &options.imu_sensor, &options.gps_sensor}) {
    CheckLayoutName(*sensor, "sensor");
  }
  if (options.pair_tolerance_ns < 0) {
    throw Error(ErrorCode::kInvalidArgument, "the pair tolerance must not be negative");
  }
}

// The bag's topics from its connections, which must agree on each topic's type.
Topics ReadTopics(const ImportedFile& source) {
  Topics topics;
  for (const RecordingConnection& c : source.reader.connections()) {
    const std::string type = c.type.empty() ? "(no schema)" : c.type;
    const auto [it, added] = topics.try_emplace(c.topic);
    Topic& t = it->second;
    if (!added && (t.type != type || t.undecodable != c.undecodable)) {
      throw Error(ErrorCode::kInvalidArgument,
                  source.label + ": topic " + c.topic + " carries both " + t.type + " and " + type +
                      (t.type == type ? " of another definition" : ""));
    }
    t.type = type;
    t.sensor_type = c.sensor_type;
    t.undecodable = c.undecodable;
    t.messages += c.messages;
  }
  return topics;
}

// Writes each stereo pair the pairing makes into the stereo log, all of one image size.
class StereoPairWriter {
 public:
  StereoPairWriter(const std::string& bag, const std::string& stereo_sensor, StagedRecordFile& log)
      : bag_(bag), log_(log), type_(v1::StereoImagePair::descriptor()->full_name()) {
    pair_.set_left_camera(stereo_sensor + "/cam0");
    pair_.set_right_camera(stereo_sensor + "/cam1");
    pair_.set_encoding("png");
  }

  void Write(StereoFrame& left, StereoFrame& right) {
    const auto size = std::pair{left.width_px, left.height_px};
    if (std::pair{right.width_px, right.height_px} != size ||
        (image_size_ && *image_size_ != size)) {
      const auto [w, h] = image_size_.value_or(size);
      throw Error(ErrorCode::kInvalidArgument,
                  bag_ + ": the stereo pair stamped " + std::to_string(left.stamp_ns) + " ns" +
                      " has a " + std::to_string(left.width_px) + "x" +
                      std::to_string(left.height_px) + " left and a " +
                      std::to_string(right.width_px) + "x" + std::to_string(right.height_px) +
                      " right image where the pairs before are " + std::to_string(w) + "x" +
                      std::to_string(h) + "; a stereo log holds one image size");
    }
    image_size_ = size;
    pair_.set_stamp_ns(left.stamp_ns);
    pair_.set_width_px(left.width_px);
    pair_.set_height_px(left.height_px);
    pair_.set_left_image(std::move(left.png));
    pair_.set_right_image(std::move(right.png));
    pair_.SerializeToString(&payload_);
    log_.Append(left.stamp_ns, type_, payload_);
  }

  // Width and height of the pairs written; nullopt before the first.
  const std::optional<std::pair<std::uint32_t, std::uint32_t>>& image_size() const {
    return image_size_;
  }

 private:
  const std::string& bag_;
  StagedRecordFile& log_;
  const std::string type_;
  v1::StereoImagePair pair_;
  std::optional<std::pair<std::uint32_t, std::uint32_t>> image_size_;
  std::string payload_;
};

// Refuses a bag that gave no stereo pair, IMU sample or GPS fix, saying why.
void RequireSomethingImported(const RosBagImportResult& result, const Topics& topics,
                              const RosBagImportOptions& o, const ImportedFile& source) {
  if (result.pairs == 0 && result.imu_samples == 0 && result.gps_fixes == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                source.label + " holds nothing to import: no stereo pair" +
                    (o.left_topic.empty()
                         ? " (no two image topics chosen; " + ImageTopicList(topics, source) + ")"
                         : " (" + std::to_string(result.unmatched_left) + " left and " +
                               std::to_string(result.unmatched_right) +
                               " right frames, none within the tolerance)") +
                    ", no " + source.Type(SensorMsgType::kImu) + " and no " +
                    source.Type(SensorMsgType::kNavSatFix) + " messages");
  }
}

// The stereo calibration from the cameras' camera_info, written beside the stereo log; else
// the note of why there is none. REQUIRES: result.pairs > 0 (so the image size is known).
void StoreCalibration(const std::optional<RosCameraInfo>& left_info,
                      const std::optional<RosCameraInfo>& right_info,
                      const std::pair<std::uint32_t, std::uint32_t>& image_size,
                      const RosBagImportOptions& o, const StagedRecordFile& stereo_log,
                      internal::WrittenPaths& written, RosBagImportResult& result) {
  if (!left_info || !right_info) {
    result.calibration_note = "no calibration stored: the bag has no camera_info for the " +
                              std::string(!left_info && !right_info ? "two cameras"
                                          : !left_info              ? "left camera"
                                                                    : "right camera") +
                              " (--left-info-topic, --right-info-topic)";
  } else if (const std::optional<internal::RosStereoCalibration> rig =
                 internal::StereoCalibrationFromCameraInfo(
                     *left_info, *right_info, static_cast<int>(image_size.first),
                     static_cast<int>(image_size.second), o.stereo_sensor,
                     result.calibration_note)) {
    result.left_calibration = StereoCalibrationPath(stereo_log.final_path(), 0);
    result.right_calibration = StereoCalibrationPath(stereo_log.final_path(), 1);
    written.AddFile(result.left_calibration);
    WriteEurocCamera(rig->left, result.left_calibration);
    written.AddFile(result.right_calibration);
    WriteEurocCamera(rig->right, result.right_calibration);
    result.baseline_m = rig->baseline_m;
  } else {
    result.calibration_note = "no calibration stored: " + result.calibration_note;
  }
}

// Publishes the logs that hold records and indexes them in the store, in one transaction.
void PublishAndIndex(const std::vector<StagedRecordFile*>& all_logs, GraphStore& store,
                     const fs::path& root, const std::string& platform,
                     RosBagImportResult& result) {
  std::vector<StagedRecordFile*> logs;
  for (StagedRecordFile* log : all_logs) {
    if (log->records() == 0) continue;
    log->Publish();
    logs.push_back(log);
    result.record_files.push_back(log->final_path());
  }
  GraphStore::Transaction txn = store.Begin();
  for (const StagedRecordFile* log : logs) {
    IngestResult one =
        IngestRecordFile(store.sensors(), root, log->final_path(), platform, log->sensor());
    result.index.files += one.files;
    result.index.records += one.records;
    result.index.inserted += one.inserted;
    for (RecordProblem& p : one.problems) result.index.problems.push_back(std::move(p));
  }
  txn.Commit();
}

// One camera's image message as a frame: a PNG, stamped by its header (or, without one, its
// receive time, counted in `stamped_by_receive_time`); `camera_info` bounds the image.
StereoFrame DecodeStereoFrame(const RecordingReader& reader, const RecordingMessage& m,
                              const RosCameraInfo* camera_info,
                              std::int64_t& stamped_by_receive_time) {
  if (m.connection->sensor_type == SensorMsgType::kCompressedImage) {
    const RosCompressedImage image = reader.DecodeCompressedImage(m.data);
    internal::DecodedRosImage decoded = internal::RosCompressedImageToPng(image, camera_info);
    return StereoFrame{StampOf(image.header, m, stamped_by_receive_time), std::move(decoded.png),
                       decoded.width_px, decoded.height_px};
  }
  const RosImage image = reader.DecodeImage(m.data);
  return StereoFrame{StampOf(image.header, m, stamped_by_receive_time),
                     internal::RosImageToPng(image, camera_info), image.width, image.height};
}

// What the import made: stereo pairs and what stayed unpaired, IMU samples, GPS fixes, and
// each topic's use.
void CountImported(const internal::StereoStampPairing& pairing, const StagedRecordFile& imu_log,
                   const StagedRecordFile& gps_log, const Topics& topics,
                   RosBagImportResult& result) {
  result.pairs = pairing.pairs();
  result.unmatched_left = pairing.unmatched_left();
  result.unmatched_right = pairing.unmatched_right();
  result.imu_samples = imu_log.records();
  result.gps_fixes = gps_log.records();
  for (const auto& [topic, t] : topics) {
    result.topics.push_back(RosBagTopicUse{topic, t.type, t.messages, RoleName(t.role)});
  }
}

}  // namespace

RosBagImportResult ImportRosBag(
    const fs::path& bag, GraphStore& store, const fs::path& root,
    const RosBagImportOptions& options,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress) {
  CheckImportOptions(options);
  RecordingReader reader(bag);
  const ImportedFile source{reader, std::string(reader.kind()) + " " + bag.string()};
  Topics topics = ReadTopics(source);
  RosBagImportOptions o = options;
  AssignRoles(topics, o, source);

  RosBagImportResult result;
  internal::WrittenPaths written;
  StagedRecordFile stereo_log(root, o.platform, o.stereo_sensor, written);
  StagedRecordFile imu_log(root, o.platform, o.imu_sensor, written);
  StagedRecordFile gps_log(root, o.platform, o.gps_sensor, written);

  StereoPairWriter stereo_writer(source.label, o.stereo_sensor, stereo_log);
  internal::StereoStampPairing pairing(o.pair_tolerance_ns,
                                       [&stereo_writer](StereoFrame& left, StereoFrame& right) {
                                         stereo_writer.Write(left, right);
                                       });
  std::optional<RosCameraInfo> left_info, right_info;
  std::string payload;
  const RecordingMessage* message = nullptr;  // the one being imported
  // A decoded message as a record of `log`, converted by `to_record`.
  const auto append = [&](const auto& decoded, auto to_record, StagedRecordFile& log) {
    const std::int64_t stamp = StampOf(decoded.header, *message, result.stamped_by_receive_time);
    const auto record = to_record(decoded, stamp);
    record.SerializeToString(&payload);
    log.Append(stamp, record.GetDescriptor()->full_name(), payload);
  };

  std::map<std::string, std::uint64_t> seen;  // messages per topic, to name the one that fails
  reader.ReadMessages(
      [&](const RecordingMessage& m) {
        const std::string& topic = m.connection->topic;
        const std::uint64_t index = seen[topic]++;
        const Role role = topics.at(topic).role;
        if (role == Role::kSkip) return;
        message = &m;
        try {
          switch (role) {
            case Role::kLeft:
            case Role::kRight: {
              // Its camera's CameraInfo bounds the image when it came first.
              const std::optional<RosCameraInfo>& info =
                  role == Role::kLeft ? left_info : right_info;
              StereoFrame frame = DecodeStereoFrame(reader, m, info ? &*info : nullptr,
                                                    result.stamped_by_receive_time);
              role == Role::kLeft ? pairing.AddLeft(std::move(frame))
                                  : pairing.AddRight(std::move(frame));
              break;
            }
            case Role::kLeftInfo:
            case Role::kRightInfo: {
              std::optional<RosCameraInfo>& info = role == Role::kLeftInfo ? left_info : right_info;
              if (!info) info = reader.DecodeCameraInfo(m.data);
              break;
            }
            case Role::kImu:
              append(reader.DecodeImu(m.data), internal::ImuSampleFromRos, imu_log);
              break;
            case Role::kGps:
              append(reader.DecodeNavSatFix(m.data), internal::GpsFixFromRos, gps_log);
              break;
            case Role::kSkip:
              break;
          }
        } catch (const Error& e) {
          if (e.code() == ErrorCode::kConflict || e.code() == ErrorCode::kBackend) throw;
          throw Error(e.code(), source.label + ": topic " + topic + ", message " +
                                    std::to_string(index + 1) + " (chunk at byte " +
                                    std::to_string(m.chunk_offset) + "): " + e.message());
        }
      },
      progress);
  pairing.Finish();
  CountImported(pairing, imu_log, gps_log, topics, result);
  RequireSomethingImported(result, topics, o, source);
  if (result.pairs > 0) {
    StoreCalibration(left_info, right_info, *stereo_writer.image_size(), o, stereo_log, written,
                     result);
  }
  PublishAndIndex({&stereo_log, &imu_log, &gps_log}, store, root, o.platform, result);
  written.Keep();
  return result;
}

}  // namespace fleetmap
