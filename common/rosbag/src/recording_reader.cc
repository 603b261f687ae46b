// A ROS 1 bag or an MCAP file behind one reader (recording_reader.h).
#include "fleetmap/rosbag/recording_reader.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <map>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/rosbag/bag_reader.h"
#include "fleetmap/rosbag/mcap_reader.h"
#include "fleetmap/rosbag/ros2_sensor_msgs.h"
#include "printable_bytes.h"

namespace fleetmap {
namespace {

struct SensorTypeNames {
  SensorMsgType type;
  std::string_view ros1, ros2;
  std::string_view ros1_md5;  // of ROS 1's definition, which the decoder reads
};

constexpr SensorTypeNames kSensorTypeNames[] = {
    {SensorMsgType::kImage, "sensor_msgs/Image", kRos2ImageType, kRosImageMd5},
    {SensorMsgType::kCompressedImage, "sensor_msgs/CompressedImage", kRos2CompressedImageType,
     kRosCompressedImageMd5},
    {SensorMsgType::kCameraInfo, "sensor_msgs/CameraInfo", kRos2CameraInfoType, kRosCameraInfoMd5},
    {SensorMsgType::kImu, "sensor_msgs/Imu", kRos2ImuType, kRosImuMd5},
    {SensorMsgType::kNavSatFix, "sensor_msgs/NavSatFix", kRos2NavSatFixType, kRosNavSatFixMd5},
};

// The first bytes of `file` (up to 16), to tell the formats apart.
std::string FirstBytes(const std::filesystem::path& file) {
  const int fd = ::open(file.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    throw Error(ErrorCode::kNotFound,
                "ROS bag or MCAP file " + file.string() + ": cannot open: " + std::strerror(errno));
  }
  std::string head(16, '\0');
  ssize_t got;
  do {
    got = ::read(fd, head.data(), head.size());
  } while (got < 0 && errno == EINTR);
  const int error = errno;
  ::close(fd);
  if (got < 0) {
    throw Error(ErrorCode::kNotFound,
                "ROS bag or MCAP file " + file.string() + ": cannot read: " + std::strerror(error));
  }
  head.resize(static_cast<std::size_t>(got));
  return head;
}

RecordingConnection FromRosConnection(const RosConnection& c) {
  RecordingConnection out{c.id, c.topic, c.type, SensorMsgType::kOther, "", c.messages};
  for (const SensorTypeNames& t : kSensorTypeNames) {
    if (c.type != t.ros1) continue;
    out.sensor_type = t.type;
    if (c.md5sum != t.ros1_md5) {
      out.undecodable =
          "with md5sum " + c.md5sum + ", not ROS 1's definition (" + std::string(t.ros1_md5) + ")";
    }
  }
  return out;
}

RecordingConnection FromMcapChannel(const McapChannel& c) {
  RecordingConnection out{c.id, c.topic, c.schema_name, SensorMsgType::kOther, "", c.messages};
  if (c.schema_encoding != "ros2msg" && c.schema_encoding != "ros2idl") return out;
  for (const SensorTypeNames& t : kSensorTypeNames) {
    if (c.schema_name != t.ros2) continue;
    out.sensor_type = t.type;
    if (c.message_encoding != "cdr") {
      out.undecodable = "with message encoding '" + c.message_encoding + "', not cdr";
    }
  }
  return out;
}

}  // namespace

RecordingReader::RecordingReader(const std::filesystem::path& file) : file_(file) {
  const std::string head = FirstBytes(file);
  if (head.starts_with(kMcapMagic.substr(0, 5))) {
    mcap_ = std::make_unique<McapReader>(file);
    for (const McapChannel& c : mcap_->channels()) connections_.push_back(FromMcapChannel(c));
  } else if (head.starts_with("#ROS")) {
    bag_ = std::make_unique<RosBagReader>(file);
    for (const RosConnection& c : bag_->connections()) connections_.push_back(FromRosConnection(c));
  } else {
    throw Error(
        ErrorCode::kInvalidArgument,
        file.string() + ": not a ROS bag or MCAP file: it begins \"" +
            internal::PrintableBytes(head) +
            "\" where a ROS bag 2.0 begins \"#ROSBAG V2.0\" and MCAP \"" +
            internal::PrintableBytes(kMcapMagic) + "\"" +
            (head.size() < 8 ? " (the file has " + std::to_string(head.size()) + " bytes)" : ""));
  }
}

RecordingReader::~RecordingReader() = default;

RecordingFormat RecordingReader::format() const {
  return mcap_ ? RecordingFormat::kMcap : RecordingFormat::kRosBag;
}

std::string_view RecordingReader::kind() const {
  return mcap_ ? "MCAP file" : "ROS bag";
}

const std::filesystem::path& RecordingReader::file() const {
  return file_;
}

std::uint64_t RecordingReader::file_bytes() const {
  return mcap_ ? mcap_->file_bytes() : bag_->file_bytes();
}

const std::vector<RecordingConnection>& RecordingReader::connections() const {
  return connections_;
}

std::string_view RecordingReader::TypeName(SensorMsgType type) const {
  for (const SensorTypeNames& t : kSensorTypeNames) {
    if (t.type == type) return mcap_ ? t.ros2 : t.ros1;
  }
  return "another type";
}

void RecordingReader::ReadMessages(
    const std::function<void(const RecordingMessage&)>& on_message,
    const std::function<void(std::uint64_t done, std::uint64_t total)>& progress) {
  std::map<std::uint32_t, const RecordingConnection*> by_id;
  for (const RecordingConnection& c : connections_) by_id[c.id] = &c;
  if (mcap_) {
    mcap_->ReadMessages(
        [&](const McapMessage& m) {
          on_message(
              RecordingMessage{by_id.at(m.channel->id), m.log_time_ns, m.data, m.chunk_offset});
        },
        progress);
  } else {
    bag_->ReadMessages(
        [&](const RosBagMessage& m) {
          on_message(RecordingMessage{by_id.at(m.connection->id), m.receive_time_ns, m.data,
                                      m.chunk_offset});
        },
        progress);
  }
}

RosImage RecordingReader::DecodeImage(std::string_view data) const {
  return mcap_ ? DecodeRos2Image(data) : DecodeRosImage(data);
}
RosCompressedImage RecordingReader::DecodeCompressedImage(std::string_view data) const {
  return mcap_ ? DecodeRos2CompressedImage(data) : DecodeRosCompressedImage(data);
}
RosCameraInfo RecordingReader::DecodeCameraInfo(std::string_view data) const {
  return mcap_ ? DecodeRos2CameraInfo(data) : DecodeRosCameraInfo(data);
}
RosImu RecordingReader::DecodeImu(std::string_view data) const {
  return mcap_ ? DecodeRos2Imu(data) : DecodeRosImu(data);
}
RosNavSatFix RecordingReader::DecodeNavSatFix(std::string_view data) const {
  return mcap_ ? DecodeRos2NavSatFix(data) : DecodeRosNavSatFix(data);
}

}  // namespace fleetmap
