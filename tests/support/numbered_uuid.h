// Readable, fixed UUIDs for tests: NumberedUuid(n) is never nil and differs for every n in
// [0, 65535], so expectations can name nodes and paths by number.
#pragma once

#include <cstdint>
#include <initializer_list>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

inline Uuid NumberedUuid(int n) {
  Uuid::Bytes bytes{};
  bytes[0] = 1;  // never nil
  bytes[14] = static_cast<std::uint8_t>(n >> 8);
  bytes[15] = static_cast<std::uint8_t>(n);
  return Uuid(bytes);
}

inline std::vector<Uuid> NumberedUuids(std::initializer_list<int> numbers) {
  std::vector<Uuid> ids;
  for (const int n : numbers) ids.push_back(NumberedUuid(n));
  return ids;
}

}  // namespace fleetmap
