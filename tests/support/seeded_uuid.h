// UUIDs drawn from a seeded generator, for benchmarks and tests whose maps must be the same on
// every run (and so break the same ties): SeededUuid(rng) is the next 128 bits of `rng`.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

inline Uuid SeededUuid(std::mt19937_64& rng) {
  Uuid::Bytes bytes;
  for (std::size_t i = 0; i < bytes.size(); i += 8) {
    const std::uint64_t word = rng();
    for (std::size_t b = 0; b < 8; ++b) bytes[i + b] = static_cast<std::uint8_t>(word >> (8 * b));
  }
  return Uuid(bytes);
}

}  // namespace fleetmap
