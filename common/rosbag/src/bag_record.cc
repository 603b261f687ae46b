// Record headers of ROS bag format 2.0 (bag_record.h).
#include "bag_record.h"

#include <cstdio>
#include <cstring>

namespace fleetmap::internal {

std::string BagOpName(std::uint8_t op) {
  switch (static_cast<BagOp>(op)) {
    case BagOp::kMessageData:
      return "message data";
    case BagOp::kBagHeader:
      return "bag header";
    case BagOp::kIndexData:
      return "index data";
    case BagOp::kChunk:
      return "chunk";
    case BagOp::kChunkInfo:
      return "chunk info";
    case BagOp::kConnection:
      return "connection";
  }
  char name[16];
  std::snprintf(name, sizeof name, "op 0x%02x", static_cast<unsigned>(op));
  return name;
}

BagFields::BagFields(std::string_view bytes, std::string context) : context_(std::move(context)) {
  ByteCursor cursor(bytes, context_ + ": record header");
  while (cursor.remaining() > 0) {
    const std::string_view field = cursor.LengthPrefixed("a header field");
    const std::size_t equals = field.find('=');
    if (equals == std::string_view::npos || equals == 0) {
      cursor.Fail("a header field without a name= (" + std::to_string(field.size()) + " bytes)");
    }
    const std::string_view name = field.substr(0, equals);
    if (!fields_.emplace(name, field.substr(equals + 1)).second) {
      cursor.Fail("header field '" + std::string(name) + "' given twice");
    }
  }
}

std::string_view BagFields::Value(std::string_view name, std::size_t size) const {
  const auto it = fields_.find(name);
  if (it == fields_.end()) {
    throw Error(ErrorCode::kCorrupt,
                context_ + ": record header lacks the field '" + std::string(name) + "'");
  }
  if (size != 0 && it->second.size() != size) {
    throw Error(ErrorCode::kCorrupt, context_ + ": header field '" + std::string(name) + "' is " +
                                         std::to_string(it->second.size()) + " bytes, not " +
                                         std::to_string(size));
  }
  return it->second;
}

std::uint8_t BagFields::Op() const {
  return static_cast<std::uint8_t>(Value("op", 1)[0]);
}

std::uint32_t BagFields::U32(std::string_view name) const {
  std::uint32_t v;
  std::memcpy(&v, Value(name, sizeof v).data(), sizeof v);
  return v;
}

std::uint64_t BagFields::U64(std::string_view name) const {
  std::uint64_t v;
  std::memcpy(&v, Value(name, sizeof v).data(), sizeof v);
  return v;
}

std::int64_t BagFields::TimeNs(std::string_view name) const {
  ByteCursor cursor(Value(name, 8), context_);
  const auto sec = cursor.Number<std::uint32_t>("seconds");
  const auto nsec = cursor.Number<std::uint32_t>("nanoseconds");
  return std::int64_t{sec} * 1'000'000'000 + nsec;
}

std::string_view BagFields::String(std::string_view name) const {
  return Value(name, 0);
}

BagRecord ReadBagRecord(ByteCursor& cursor, const std::string& context) {
  const std::size_t offset = cursor.offset();
  const std::string where = context + ": record at byte " + std::to_string(offset);
  BagFields fields(cursor.LengthPrefixed("the record header"), where);
  const std::string_view data = cursor.LengthPrefixed("the record data");
  return BagRecord{offset, std::move(fields), data};
}

}  // namespace fleetmap::internal
