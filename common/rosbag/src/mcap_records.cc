// The records of the MCAP format (mcap_records.h), field by field as the specification's tables
// give them.
#include "mcap_records.h"

#include <cstdio>

namespace fleetmap::internal {
namespace {

std::string McapString(ByteCursor& cursor, std::string_view what) {
  return std::string(cursor.LengthPrefixed(what));
}

// A Map<uint16, uint64>: a uint32 byte length, then (key, value) entries of 10 bytes.
std::map<std::uint16_t, std::uint64_t> McapIdCountMap(ByteCursor& cursor, std::string_view what) {
  ByteCursor entries(cursor.LengthPrefixed(what), cursor.context() + ": " + std::string(what));
  std::map<std::uint16_t, std::uint64_t> out;
  while (entries.remaining() > 0) {
    const auto key = entries.Number<std::uint16_t>("a key");
    const auto value = entries.Number<std::uint64_t>("a value");
    if (!out.emplace(key, value).second) entries.Fail("key " + std::to_string(key) + " twice");
  }
  return out;
}

}  // namespace

std::string McapOpName(std::uint8_t op) {
  switch (static_cast<McapOp>(op)) {
    case McapOp::kHeader:
      return "header";
    case McapOp::kFooter:
      return "footer";
    case McapOp::kSchema:
      return "schema";
    case McapOp::kChannel:
      return "channel";
    case McapOp::kMessage:
      return "message";
    case McapOp::kChunk:
      return "chunk";
    case McapOp::kMessageIndex:
      return "message index";
    case McapOp::kChunkIndex:
      return "chunk index";
    case McapOp::kAttachment:
      return "attachment";
    case McapOp::kAttachmentIndex:
      return "attachment index";
    case McapOp::kStatistics:
      return "statistics";
    case McapOp::kMetadata:
      return "metadata";
    case McapOp::kMetadataIndex:
      return "metadata index";
    case McapOp::kSummaryOffset:
      return "summary offset";
    case McapOp::kDataEnd:
      return "data end";
  }
  char name[24];
  std::snprintf(name, sizeof name, "opcode 0x%02x", static_cast<unsigned>(op));
  return name;
}

McapSchemaRecord ParseMcapSchema(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapSchemaRecord r;
  r.id = cursor.Number<std::uint16_t>("id");
  r.name = McapString(cursor, "name");
  r.encoding = McapString(cursor, "encoding");
  r.data = McapString(cursor, "data");
  return r;
}

McapChannelRecord ParseMcapChannel(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapChannelRecord r;
  r.id = cursor.Number<std::uint16_t>("id");
  r.schema_id = cursor.Number<std::uint16_t>("schema_id");
  r.topic = McapString(cursor, "topic");
  r.message_encoding = McapString(cursor, "message_encoding");
  ByteCursor metadata(cursor.LengthPrefixed("metadata"), context + ": metadata");
  while (metadata.remaining() > 0) {
    std::string key = McapString(metadata, "a key");
    r.metadata.emplace_back(std::move(key), McapString(metadata, "a value"));
  }
  return r;
}

McapMessageRecord ParseMcapMessage(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapMessageRecord r;
  r.channel_id = cursor.Number<std::uint16_t>("channel_id");
  r.sequence = cursor.Number<std::uint32_t>("sequence");
  r.log_time = cursor.Number<std::uint64_t>("log_time");
  r.publish_time = cursor.Number<std::uint64_t>("publish_time");
  r.data = content.substr(kMcapMessageFieldBytes);  // the rest: a Message does not grow
  return r;
}

McapChunkRecord ParseMcapChunk(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapChunkRecord r;
  r.message_start_time = cursor.Number<std::uint64_t>("message_start_time");
  r.message_end_time = cursor.Number<std::uint64_t>("message_end_time");
  r.uncompressed_size = cursor.Number<std::uint64_t>("uncompressed_size");
  r.uncompressed_crc = cursor.Number<std::uint32_t>("uncompressed_crc");
  r.compression = cursor.LengthPrefixed("compression");
  const auto n = cursor.Number<std::uint64_t>("records");
  r.records = cursor.Bytes(n, "records");
  return r;
}

McapMessageIndexRecord ParseMcapMessageIndex(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapMessageIndexRecord r;
  r.channel_id = cursor.Number<std::uint16_t>("channel_id");
  ByteCursor entries(cursor.LengthPrefixed("records"), context + ": records");
  if (entries.remaining() % 16 != 0) {
    entries.Fail("records of " + std::to_string(entries.remaining()) +
                 " bytes, not a whole number of 16-byte (log_time, offset) entries");
  }
  r.entries.reserve(entries.remaining() / 16);
  while (entries.remaining() > 0) {
    const auto log_time = entries.Number<std::uint64_t>("a log_time");
    r.entries.emplace_back(log_time, entries.Number<std::uint64_t>("an offset"));
  }
  return r;
}

McapChunkIndexRecord ParseMcapChunkIndex(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapChunkIndexRecord r;
  r.message_start_time = cursor.Number<std::uint64_t>("message_start_time");
  r.message_end_time = cursor.Number<std::uint64_t>("message_end_time");
  r.chunk_start_offset = cursor.Number<std::uint64_t>("chunk_start_offset");
  r.chunk_length = cursor.Number<std::uint64_t>("chunk_length");
  r.message_index_offsets = McapIdCountMap(cursor, "message_index_offsets");
  r.message_index_length = cursor.Number<std::uint64_t>("message_index_length");
  r.compression = McapString(cursor, "compression");
  r.compressed_size = cursor.Number<std::uint64_t>("compressed_size");
  r.uncompressed_size = cursor.Number<std::uint64_t>("uncompressed_size");
  return r;
}

McapStatisticsRecord ParseMcapStatistics(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapStatisticsRecord r;
  r.message_count = cursor.Number<std::uint64_t>("message_count");
  r.schema_count = cursor.Number<std::uint16_t>("schema_count");
  r.channel_count = cursor.Number<std::uint32_t>("channel_count");
  r.attachment_count = cursor.Number<std::uint32_t>("attachment_count");
  r.metadata_count = cursor.Number<std::uint32_t>("metadata_count");
  r.chunk_count = cursor.Number<std::uint32_t>("chunk_count");
  r.message_start_time = cursor.Number<std::uint64_t>("message_start_time");
  r.message_end_time = cursor.Number<std::uint64_t>("message_end_time");
  r.channel_message_counts = McapIdCountMap(cursor, "channel_message_counts");
  return r;
}

McapSummaryOffsetRecord ParseMcapSummaryOffset(std::string_view content,
                                               const std::string& context) {
  ByteCursor cursor(content, context);
  McapSummaryOffsetRecord r;
  r.group_opcode = cursor.Number<std::uint8_t>("group_opcode");
  r.group_start = cursor.Number<std::uint64_t>("group_start");
  r.group_length = cursor.Number<std::uint64_t>("group_length");
  return r;
}

McapFooterRecord ParseMcapFooter(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  McapFooterRecord r;
  r.summary_start = cursor.Number<std::uint64_t>("summary_start");
  r.summary_offset_start = cursor.Number<std::uint64_t>("summary_offset_start");
  r.summary_crc = cursor.Number<std::uint32_t>("summary_crc");
  cursor.ExpectEnd();
  return r;
}

std::uint32_t ParseMcapDataEnd(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  return cursor.Number<std::uint32_t>("data_section_crc");
}

void ParseMcapHeader(std::string_view content, const std::string& context) {
  ByteCursor cursor(content, context);
  cursor.LengthPrefixed("profile");
  cursor.LengthPrefixed("library");
}

McapRecordView ReadMcapRecord(ByteCursor& cursor) {
  McapRecordView r;
  r.offset = cursor.offset();
  r.op = cursor.Number<std::uint8_t>("a record's opcode");
  const auto n = cursor.Number<std::uint64_t>("a record's length");
  r.content = cursor.Bytes(n, "the content of a " + McapOpName(r.op) + " record");
  return r;
}

}  // namespace fleetmap::internal
