// The record framing of ROS bag format 2.0 (bag_reader.h): a record's header fields and the
// ops the reader knows. Private to the library.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>

#include "byte_cursor.h"

namespace fleetmap::internal {

enum class BagOp : std::uint8_t {
  kMessageData = 0x02,
  kBagHeader = 0x03,
  kIndexData = 0x04,
  kChunk = 0x05,
  kChunkInfo = 0x06,
  kConnection = 0x07,
};

// "chunk", "connection", ... for messages; "op 0x09" for an unknown one.
std::string BagOpName(std::uint8_t op);

// The name=value fields of a record header (or of a connection record's data, which has the
// same form). Values are views into the parsed bytes. Typed getters throw Error(kCorrupt)
// prefixed by `context` when a required field is missing or has the wrong size.
class BagFields {
 public:
  // Parses <len u32>name=value ... filling exactly `bytes`.
  BagFields(std::string_view bytes, std::string context);

  bool Has(std::string_view name) const { return fields_.contains(name); }
  std::uint8_t Op() const;
  std::uint32_t U32(std::string_view name) const;
  std::uint64_t U64(std::string_view name) const;
  // A ROS time field (u32 seconds, u32 nanoseconds) in nanoseconds.
  std::int64_t TimeNs(std::string_view name) const;
  std::string_view String(std::string_view name) const;
  const std::string& context() const { return context_; }

 private:
  std::string_view Value(std::string_view name, std::size_t size) const;

  std::map<std::string_view, std::string_view, std::less<>> fields_;
  std::string context_;
};

// One record read from a buffer: its header fields and data.
struct BagRecord {
  std::size_t offset = 0;  // of the record in the buffer
  BagFields fields;
  std::string_view data;
};

// Reads the record at the cursor; the lengths are checked against what the buffer holds.
BagRecord ReadBagRecord(ByteCursor& cursor, const std::string& context);

}  // namespace fleetmap::internal
