// The records of the MCAP format (mcap_reader.h): their opcodes, their fields, and how each is
// parsed from its content. A parser reads the fields the specification defines and ignores
// bytes after them (records may grow fields at their end); every field is checked against the
// content's length by the cursor, which throws Error(kCorrupt) prefixed by `context`. Private to
// the library.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "byte_cursor.h"

namespace fleetmap::internal {

enum class McapOp : std::uint8_t {
  kHeader = 0x01,
  kFooter = 0x02,
  kSchema = 0x03,
  kChannel = 0x04,
  kMessage = 0x05,
  kChunk = 0x06,
  kMessageIndex = 0x07,
  kChunkIndex = 0x08,
  kAttachment = 0x09,
  kAttachmentIndex = 0x0A,
  kStatistics = 0x0B,
  kMetadata = 0x0C,
  kMetadataIndex = 0x0D,
  kSummaryOffset = 0x0E,
  kDataEnd = 0x0F,
};

// "chunk", "message index", ... for messages; "opcode 0x42" for an unknown one.
std::string McapOpName(std::uint8_t op);

// Bytes of a record before its content: the opcode and the uint64 content length.
inline constexpr std::size_t kMcapRecordPrefixBytes = 9;
// The Footer's content: summary_start u64, summary_offset_start u64, summary_crc u32. The Footer
// will not grow (the specification says so), so its size is exact.
inline constexpr std::size_t kMcapFooterContentBytes = 20;
// A Message's fields before its data.
inline constexpr std::size_t kMcapMessageFieldBytes = 2 + 4 + 8 + 8;

struct McapSchemaRecord {
  std::uint16_t id = 0;
  std::string name, encoding, data;
  bool operator==(const McapSchemaRecord&) const = default;
};

struct McapChannelRecord {
  std::uint16_t id = 0;
  std::uint16_t schema_id = 0;
  std::string topic, message_encoding;
  std::vector<std::pair<std::string, std::string>> metadata;  // as recorded
  bool operator==(const McapChannelRecord&) const = default;
};

// Views into the content parsed.
struct McapMessageRecord {
  std::uint16_t channel_id = 0;
  std::uint32_t sequence = 0;
  std::uint64_t log_time = 0, publish_time = 0;
  std::string_view data;
};

struct McapChunkRecord {
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::uint64_t uncompressed_size = 0;
  std::uint32_t uncompressed_crc = 0;  // 0: not computed
  std::string_view compression;
  std::string_view records;  // compressed
};

struct McapMessageIndexRecord {
  std::uint16_t channel_id = 0;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> entries;  // (log_time, offset in chunk)
};

struct McapChunkIndexRecord {
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::uint64_t chunk_start_offset = 0, chunk_length = 0;
  std::map<std::uint16_t, std::uint64_t> message_index_offsets;
  std::uint64_t message_index_length = 0;
  std::string compression;
  std::uint64_t compressed_size = 0, uncompressed_size = 0;
};

struct McapStatisticsRecord {
  std::uint64_t message_count = 0;
  std::uint16_t schema_count = 0;
  std::uint32_t channel_count = 0, attachment_count = 0, metadata_count = 0, chunk_count = 0;
  std::uint64_t message_start_time = 0, message_end_time = 0;
  std::map<std::uint16_t, std::uint64_t> channel_message_counts;
};

struct McapSummaryOffsetRecord {
  std::uint8_t group_opcode = 0;
  std::uint64_t group_start = 0, group_length = 0;
};

struct McapFooterRecord {
  std::uint64_t summary_start = 0, summary_offset_start = 0;
  std::uint32_t summary_crc = 0;  // 0: not computed
};

McapSchemaRecord ParseMcapSchema(std::string_view content, const std::string& context);
McapChannelRecord ParseMcapChannel(std::string_view content, const std::string& context);
McapMessageRecord ParseMcapMessage(std::string_view content, const std::string& context);
McapChunkRecord ParseMcapChunk(std::string_view content, const std::string& context);
McapMessageIndexRecord ParseMcapMessageIndex(std::string_view content, const std::string& context);
McapChunkIndexRecord ParseMcapChunkIndex(std::string_view content, const std::string& context);
McapStatisticsRecord ParseMcapStatistics(std::string_view content, const std::string& context);
McapSummaryOffsetRecord ParseMcapSummaryOffset(std::string_view content,
                                               const std::string& context);
McapFooterRecord ParseMcapFooter(std::string_view content, const std::string& context);
// The Data End's data_section_crc (0: not computed).
std::uint32_t ParseMcapDataEnd(std::string_view content, const std::string& context);
// The Header's profile and library strings, checked to be there.
void ParseMcapHeader(std::string_view content, const std::string& context);

// One record read from a buffer (a chunk's records): where it starts, its opcode and content.
struct McapRecordView {
  std::size_t offset = 0;
  std::uint8_t op = 0;
  std::string_view content;
};

// Reads the record at the cursor; its length is checked against what the buffer holds.
McapRecordView ReadMcapRecord(ByteCursor& cursor);

}  // namespace fleetmap::internal
