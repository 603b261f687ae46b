#include "fleetmap/common/uuid.h"

#include <uuid/uuid.h>

#include <algorithm>
#include <cstring>

#include "fleetmap/common/error.h"

namespace fleetmap {

Uuid Uuid::Generate() {
  Bytes bytes;
  uuid_generate_random(bytes.data());
  return Uuid(bytes);
}

Uuid Uuid::Parse(std::string_view text) {
  // uuid_parse wants a NUL-terminated string of exactly 36 characters.
  constexpr std::size_t kTextSize = 36;
  if (text.size() != kTextSize) {
    throw Error(ErrorCode::kInvalidArgument,
                "not a UUID (want 36 characters): '" + std::string(text) + "'");
  }
  char buffer[kTextSize + 1];
  std::memcpy(buffer, text.data(), kTextSize);
  buffer[kTextSize] = '\0';
  Bytes bytes;
  if (uuid_parse(buffer, bytes.data()) != 0) {
    throw Error(ErrorCode::kInvalidArgument, "not a UUID: '" + std::string(text) + "'");
  }
  return Uuid(bytes);
}

Uuid Uuid::FromBytes(std::string_view raw) {
  if (raw.size() != kSize) {
    throw Error(ErrorCode::kInvalidArgument,
                "a stored UUID must be 16 bytes, got " + std::to_string(raw.size()));
  }
  Bytes bytes;
  std::memcpy(bytes.data(), raw.data(), kSize);
  return Uuid(bytes);
}

std::string Uuid::ToString() const {
  char buffer[37];
  uuid_unparse_lower(bytes_.data(), buffer);
  return std::string(buffer, 36);
}

std::string Uuid::ToBytesString() const {
  return std::string(reinterpret_cast<const char*>(bytes_.data()), kSize);
}

bool Uuid::IsNil() const {
  return std::all_of(bytes_.begin(), bytes_.end(), [](std::uint8_t b) { return b == 0; });
}

}  // namespace fleetmap
