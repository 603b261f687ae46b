// A ROS recording of either format, told apart by its first bytes, for `fleetmap records
// import-bag`: a ROS 1 bag (format 2.0, bag_reader.h, its messages decoded by sensor_msgs.h) or
// an MCAP file (the rosbag2 default since ROS 2 Iron, mcap_reader.h, its messages CDR decoded
// by ros2_sensor_msgs.h). The importer sees one list of connections and one stream of messages
// and gets the same structs from either, so everything after the decoding is shared.
//
// Which sensor_msgs type a connection carries is decided here: in a ROS 1 bag by its type name
// ("sensor_msgs/Image"), which must come with ROS 1's md5sum of the definition; in an MCAP file
// by its schema's name ("sensor_msgs/msg/Image", schema encoding "ros2msg" or "ros2idl"), whose
// messages must be encoded "cdr". One of these types whose messages cannot be decoded says why
// (`undecodable`). The type's definition in an MCAP schema is not compared with ROS 2's: the
// decoders' exact lengths refuse messages of another layout.
//
// Errors: those of the two readers; and Error(kNotFound) for a file that cannot be opened,
// Error(kInvalidArgument) for a file of neither format, named by its first bytes. Not
// thread-safe; one reader per file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap {

class RosBagReader;
class McapReader;

enum class RecordingFormat { kRosBag, kMcap };

// The sensor_msgs types the import decodes (kOther: any other type, or none).
enum class SensorMsgType { kOther, kImage, kCompressedImage, kCameraInfo, kImu, kNavSatFix };

// One connection (ROS 1) or channel (MCAP): a topic with its type.
struct RecordingConnection {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;  // as recorded: "sensor_msgs/Image" (ROS 1), "sensor_msgs/msg/Image" (MCAP)
  SensorMsgType sensor_type = SensorMsgType::kOther;
  std::string undecodable;  // why messages of its sensor_type cannot be decoded; empty if they can
  std::uint64_t messages = 0;
};

// One message, handed to ReadMessages's callback.
struct RecordingMessage {
  const RecordingConnection* connection = nullptr;
  std::int64_t receive_time_ns = 0;  // when the recorder received it (not the header stamp)
  std::string_view data;             // its serialisation; valid during the callback only
  std::uint64_t chunk_offset = 0;    // of the chunk holding it, for error messages
};

class RecordingReader {
 public:
  // Opens `file` with the reader its first bytes call for. Throws as the file comment says.
  explicit RecordingReader(const std::filesystem::path& file);
  ~RecordingReader();
  RecordingReader(const RecordingReader&) = delete;
  RecordingReader& operator=(const RecordingReader&) = delete;

  RecordingFormat format() const;
  // "ROS bag" or "MCAP file": how messages name the file ("MCAP file x.mcap has no topic ...").
  std::string_view kind() const;
  const std::filesystem::path& file() const;
  std::uint64_t file_bytes() const;
  // Every connection, ordered by id.
  const std::vector<RecordingConnection>& connections() const;
  // The name of `type` in this format: "sensor_msgs/Image" or "sensor_msgs/msg/Image".
  std::string_view TypeName(SensorMsgType type) const;

  // Every message in file order, as the format's reader hands them out (each chunk checked
  // whole before its first message); `progress` gets (bytes read, bytes to read) per chunk.
  void ReadMessages(
      const std::function<void(const RecordingMessage&)>& on_message,
      const std::function<void(std::uint64_t done, std::uint64_t total)>& progress = {});

  // A message of a connection of that sensor_type, decoded as its format serialises it. Throw
  // as the decoders do (sensor_msgs.h, ros2_sensor_msgs.h).
  RosImage DecodeImage(std::string_view data) const;
  RosCompressedImage DecodeCompressedImage(std::string_view data) const;
  RosCameraInfo DecodeCameraInfo(std::string_view data) const;
  RosImu DecodeImu(std::string_view data) const;
  RosNavSatFix DecodeNavSatFix(std::string_view data) const;

 private:
  std::filesystem::path file_;
  std::unique_ptr<RosBagReader> bag_;
  std::unique_ptr<McapReader> mcap_;
  std::vector<RecordingConnection> connections_;
};

}  // namespace fleetmap
