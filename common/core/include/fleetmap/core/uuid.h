// 128-bit identifiers for nodes, edges, paths, robots and outings (libuuid, RFC 4122).
// Stored as 16 raw bytes (SQLite BLOB, PostgreSQL uuid); printed in lower-case canonical
// form "xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx". Ordering is bytewise, so it matches the
// order of both databases' indexes.
#pragma once

#include <array>
#include <compare>
#include <cstdint>
#include <functional>
#include <random>
#include <string>
#include <string_view>

namespace fleetmap {

class Uuid {
 public:
  static constexpr std::size_t kSize = 16;
  using Bytes = std::array<std::uint8_t, kSize>;

  // The nil UUID (all zero bytes); used for "not set".
  constexpr Uuid() : bytes_{} {}
  explicit constexpr Uuid(const Bytes& bytes) : bytes_(bytes) {}

  // A new time-ordered UUID (RFC 9562 version 7): 48 bits of Unix milliseconds, then a
  // counter, then 62 random bits (a per-thread generator seeded from libuuid). Ids made later in a
  // process compare greater, so the B-tree indexes of both databases append instead of splitting
  // pages at random (seed 000 §6: B-tree indexes); with random v4 keys a 10^6-node chain loads ~3x
  // slower. Thread-safe. Within a DeterministicUuids scope on this thread (tests and
  // experiments), the scope's next id instead.
  static Uuid Generate();
  // The version 7 id of these fields: 48 bits of Unix milliseconds, a 12-bit sequence, and 62
  // of the random bits (RFC 9562 §5.7).
  static Uuid Version7(std::uint64_t ms, std::uint32_t sequence, std::uint64_t random_high,
                       std::uint64_t random_low);
  // A new random (version 4) UUID, for ids that must not reveal when they were made.
  static Uuid GenerateRandom();
  // The name-based (version 5, SHA-1) UUID of `name` in `name_space` (RFC 9562 §5.5): the
  // same inputs give the same id on every machine, so an element derived from others (a path
  // edge contracted over the nodes a download leaves out) is recognised wherever it returns.
  static Uuid NameBased(const Uuid& name_space, std::string_view name);
  // Parses canonical text. Throws Error(kInvalidArgument) on anything else.
  static Uuid Parse(std::string_view text);
  // From exactly 16 raw bytes. Throws Error(kInvalidArgument) for any other length.
  static Uuid FromBytes(std::string_view raw);

  std::string ToString() const;
  // The 16 raw bytes as a string (for protobuf bytes fields).
  std::string ToBytesString() const;
  const Bytes& bytes() const { return bytes_; }
  const std::uint8_t* data() const { return bytes_.data(); }

  bool IsNil() const;

  friend auto operator<=>(const Uuid&, const Uuid&) = default;
  friend bool operator==(const Uuid&, const Uuid&) = default;

 private:
  Bytes bytes_;
};

// A scope in which Uuid::Generate on this thread returns a sequence fixed by a seed and a
// stream name instead of time-ordered random ids. Two runs of the same work under the same
// scopes mint the same ids, and ids break ties in MERGE, ranking and downloads: so two arms of
// an experiment (or a change to the code) can be compared decision for decision, node for node.
// For tests and experiments, never for ids a fleet stores: the ids do not reveal time and are
// unique only within one (seed, stream).
//
// Scopes are per thread (a task that runs on a worker thread opens its own) and nest: the
// destructor restores the scope that was open before. Ids within a scope keep version 7's
// layout and increase, so the stores' B-tree indexes still append.
class DeterministicUuids {
 public:
  DeterministicUuids(std::uint64_t seed, std::string_view stream);
  ~DeterministicUuids();
  DeterministicUuids(const DeterministicUuids&) = delete;
  DeterministicUuids& operator=(const DeterministicUuids&) = delete;

  // The scope open on this thread, or nullptr.
  static DeterministicUuids* Current();

  // The next id of this scope's sequence.
  Uuid Next();

 private:
  std::mt19937_64 bits_;
  std::uint64_t count_ = 0;
  DeterministicUuids* previous_;
};

}  // namespace fleetmap

template <>
struct std::hash<fleetmap::Uuid> {
  std::size_t operator()(const fleetmap::Uuid& id) const noexcept {
    // Version-4 UUIDs are random, so any 8 bytes hash well; mix both halves anyway so
    // time-based (v1) UUIDs, whose low bytes repeat, spread too.
    std::uint64_t lo = 0, hi = 0;
    for (int i = 0; i < 8; ++i) lo = (lo << 8) | id.bytes()[i];
    for (int i = 8; i < 16; ++i) hi = (hi << 8) | id.bytes()[i];
    return static_cast<std::size_t>(lo ^ (hi * 0x9E3779B97F4A7C15ULL));
  }
};
