#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {
namespace {

thread_local DeterministicUuids* current_scope = nullptr;

// The timestamp field of every id in a scope starts here (2000-01-01 UTC, in ms): the ids are
// not times, but they stay valid version 7 ids that sort in the order they were minted.
constexpr std::uint64_t kEpochMs = 946'684'800'000ULL;

std::seed_seq SeedOf(std::uint64_t seed, std::string_view stream) {
  std::vector<std::uint32_t> words = {static_cast<std::uint32_t>(seed),
                                      static_cast<std::uint32_t>(seed >> 32),
                                      static_cast<std::uint32_t>(stream.size())};
  for (const char c : stream) words.push_back(static_cast<unsigned char>(c));
  return std::seed_seq(words.begin(), words.end());
}

}  // namespace

DeterministicUuids::DeterministicUuids(std::uint64_t seed, std::string_view stream)
    : previous_(current_scope) {
  std::seed_seq seeds = SeedOf(seed, stream);
  bits_.seed(seeds);
  current_scope = this;
}

DeterministicUuids::~DeterministicUuids() {
  current_scope = previous_;
}

DeterministicUuids* DeterministicUuids::Current() {
  return current_scope;
}

Uuid DeterministicUuids::Next() {
  // As Uuid::Generate lays them out, the "milliseconds" and sequence counting the ids minted.
  const std::uint64_t ms = kEpochMs + (count_ >> 12);
  const std::uint32_t sequence = static_cast<std::uint32_t>(count_ & 0xfff);
  ++count_;
  const std::uint64_t high = bits_(), low = bits_();
  return Uuid::Version7(ms, sequence, high, low);
}

}  // namespace fleetmap
