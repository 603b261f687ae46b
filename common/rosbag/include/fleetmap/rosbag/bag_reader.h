// Reading ROS 1 bag files (format 2.0, http://wiki.ros.org/Bags/Format/2.0), for
// `fleetmap records import-bag`.
//
// The format: the line "#ROSBAG V2.0\n", then records, each <header_len u32><header>
// <data_len u32><data>, the header a sequence of <len u32>name=value fields with an `op` byte
// saying what the record is. A bag header record (op 3, padded to 4 KiB) gives index_pos,
// conn_count and chunk_count. Chunks (op 5; compression "none", "bz2" or "lz4" and the
// uncompressed size) hold connection records (op 7: id, topic, and a connection header with the
// message type, its md5sum and definition) and message data records (op 2: connection id,
// receive time, the message's ROS serialisation); index data records (op 4) follow each chunk.
// At index_pos the summary repeats every connection and a chunk info record (op 6) per chunk
// (where it is, its time span, messages per connection). Integers are little-endian; a time is
// u32 seconds then u32 nanoseconds.
//
// Why not Debian's librosbag-storage-dev (ros_comm 1.15.15): on corrupt input it is not safe.
// Flipping single bytes of a 4.8 KB bag it wrote crashed it (SIGSEGV) 6 to 11 times per
// compression (none, bz2, lz4), hung it once, and AddressSanitizer found a heap overflow in
// ros::Header::parse when the bag header's first field length is flipped; a robot's torn bag
// must give a named error, not take the importer down. It also needs 57 packages (ROS 2's
// pluginlib, ament with Python), and neither its pkg-config file (which requires a pluginlib.pc
// no package ships) nor its CMake config (which runs ament's Python) works outside a ROS
// workspace. The tests write their bags with it, so this reader is checked against the
// reference writer.
//
// What this reader checks, so a bad bag is refused by name before anything is imported: the
// magic; every record's lengths against the bytes there (a length past the end of the file or
// of its chunk is "truncated"); the fields each op requires; a chunk's compression (unsupported
// ones are named, with the supported list) and that it decompresses to exactly its stated size;
// that every message's connection is known and the messages per chunk and connection agree
// with the chunk's index records and the summary's chunk info; and that the summary holds
// conn_count connections and chunk_count chunks at the positions the chunks lie. A bag without
// a summary (index_pos 0: the recorder was killed) is refused with the advice to reindex it.
//
// Errors: Error(kNotFound) for a file that cannot be read; Error(kInvalidArgument) for a file
// that is not a ROS 2.0 bag (named by its first bytes) or uses an unsupported compression;
// Error(kCorrupt) for anything torn or inconsistent, naming the file and the record's offset.
// Not thread-safe; one reader per file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace fleetmap {

// One connection: a topic with its message type, as recorded.
struct RosConnection {
  std::uint32_t id = 0;
  std::string topic;
  std::string type;    // e.g. "sensor_msgs/Image"
  std::string md5sum;  // of the message definition, as rosbag records it
  std::string message_definition;
  std::uint64_t messages = 0;  // in the bag, from the summary's chunk infos
};

// One message, handed to ReadMessages's callback.
struct RosBagMessage {
  const RosConnection* connection = nullptr;
  std::int64_t receive_time_ns = 0;  // when the recorder received it (not the header stamp)
  std::string_view data;             // its ROS serialisation; valid during the callback only
  std::uint64_t chunk_offset = 0;    // of the chunk record holding it, for error messages
};

class RosBagReader {
 public:
  // Opens `file` and reads its bag header and summary (connections, chunk infos). Throws as the
  // file comment says.
  explicit RosBagReader(const std::filesystem::path& file);
  ~RosBagReader();
  RosBagReader(const RosBagReader&) = delete;
  RosBagReader& operator=(const RosBagReader&) = delete;

  const std::filesystem::path& file() const;
  std::uint64_t file_bytes() const;
  // Every connection, ordered by id.
  const std::vector<RosConnection>& connections() const;
  std::uint64_t chunk_count() const;

  // Calls `on_message` for every message in file order (chunk by chunk; within a chunk as
  // recorded), checking each chunk whole before its first message is handed out. `progress`
  // gets (bytes of the file read, bytes to read) after each chunk. An exception thrown by a
  // callback passes through.
  void ReadMessages(
      const std::function<void(const RosBagMessage&)>& on_message,
      const std::function<void(std::uint64_t done, std::uint64_t total)>& progress = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetmap
