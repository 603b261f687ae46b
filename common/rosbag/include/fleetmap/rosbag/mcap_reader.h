// Reading MCAP files (https://mcap.dev/spec, major version 0), the storage format of rosbag2
// since ROS 2 Iron, for `fleetmap records import-bag`; written from the specification, without
// an MCAP or ROS library.
//
// The format: the magic 0x89 "MCAP0\r\n", then records, each <opcode u8><content length u64>
// <content>: a Header; the data section (Schema, Channel and Message records, Chunks holding such
// records compressed "" (none), "lz4" (LZ4 frame) or "zstd" with their uncompressed size and
// CRC-32, the Message Index records after each chunk, Attachments, Metadata) closed by a Data
// End record with the CRC-32 of every byte before it; an optional summary section (copies of
// the Schema and Channel records, a Chunk Index per chunk, Statistics, ...) and summary offset
// section; a Footer (where the summary starts, its CRC-32); the magic again. Integers are
// little-endian, strings and maps behind a uint32 byte length, times uint64 nanoseconds.
//
// How it is read: the data section in file order, record by record, the only way that works
// for every file (the summary is optional; a chunk's channels are known only inside it). The
// constructor walks it whole once, so the channels and their message counts are known and every
// chunk has been checked before ReadMessages hands out a message; ReadMessages walks it again
// (each chunk decompressed twice: the price of refusing a bad file before importing any of it).
//
// What it checks, so a bad file is refused by name: both magics and the footer (a file cut
// short or never closed has no trailing magic: it is refused as truncated); every record's
// length against the bytes there (of the file, of its chunk, of its data section) and its
// fields against its length; a chunk's compression (unsupported ones named, with the supported
// list), that it decompresses to exactly its uncompressed size, and its CRC-32 unless it is 0
// ("not computed", as the specification allows); the Data End's CRC-32 of the data section
// unless 0 (it covers the leading magic and the Header too, as the reference writers compute
// it); that a message's channel, and a channel's schema, were defined before it, and that a
// schema or channel defined twice is defined the same; that the Message Index records after a
// chunk, when there are any, list exactly its messages (channel, offset and log time); and the
// summary, when there is one: its CRC-32 unless 0, that it lies where the footer says right
// after the Data End, that its Schema and Channel records repeat those of the data section (one
// the data section lacks, which a writer may list for a channel that got no message, is taken as
// such a channel), that
// its Chunk Indexes (if any) name every chunk where it lies with its sizes and compression, that
// its Statistics (if any) count the file's messages, chunks, schemas and channels, and that its
// Summary Offsets point at groups of records of their opcode. Unknown opcodes are skipped, as
// the specification asks. Records beyond 1 GiB (a chunk's compressed or uncompressed size) are
// refused rather than allocated; memory follows what a chunk really decompresses to.
//
// Errors: Error(kNotFound) for a file that cannot be read; Error(kInvalidArgument) for a file
// that is not MCAP (named by its first bytes), of another major version, or with a chunk of an
// unsupported compression; Error(kCorrupt) for anything torn or inconsistent, naming the file
// and the record's offset ("MCAP file x.mcap: at byte 4117: chunk: ..."). Not thread-safe; one
// reader per file.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace fleetmap {

// The MCAP magic, which begins and ends every MCAP file: 0x89 "MCAP" '0' "\r\n".
inline constexpr std::string_view kMcapMagic{"\x89MCAP0\r\n", 8};

// One channel: a topic with its message encoding and schema, as recorded.
struct McapChannel {
  std::uint16_t id = 0;
  std::string topic;
  std::string message_encoding;  // "cdr" for ROS 2
  std::uint16_t schema_id = 0;   // 0: no schema
  std::string schema_name;       // e.g. "sensor_msgs/msg/Image"; empty without a schema
  std::string schema_encoding;   // "ros2msg" for ROS 2
  std::string schema_data;       // the message definition
  std::uint64_t messages = 0;    // in the file
};

// One message, handed to ReadMessages's callback.
struct McapMessage {
  const McapChannel* channel = nullptr;
  std::uint32_t sequence = 0;
  std::int64_t log_time_ns = 0;      // when the recorder received it (not the header stamp)
  std::int64_t publish_time_ns = 0;  // when it was published
  std::string_view data;             // its serialisation; valid during the callback only
  std::uint64_t chunk_offset = 0;    // of the chunk record holding it (or of the message record
                                     // itself, outside chunks), for error messages
};

class McapReader {
 public:
  // Opens `file` and reads it through once (the file comment says what is checked). Throws as
  // the file comment says.
  explicit McapReader(const std::filesystem::path& file);
  ~McapReader();
  McapReader(const McapReader&) = delete;
  McapReader& operator=(const McapReader&) = delete;

  const std::filesystem::path& file() const;
  std::uint64_t file_bytes() const;
  // Every channel, ordered by id.
  const std::vector<McapChannel>& channels() const;
  std::uint64_t chunk_count() const;
  std::uint64_t message_count() const;

  // Calls `on_message` for every message in file order (chunk by chunk; within a chunk as
  // recorded), each chunk checked whole before its first message is handed out. `progress`
  // gets (bytes of the file read, bytes of the data section) after each chunk. An exception
  // thrown by a callback passes through.
  void ReadMessages(
      const std::function<void(const McapMessage&)>& on_message,
      const std::function<void(std::uint64_t done, std::uint64_t total)>& progress = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetmap
