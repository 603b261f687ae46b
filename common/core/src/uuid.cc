#include "fleetmap/core/uuid.h"

#include <unistd.h>
#include <uuid/uuid.h>

#include <algorithm>
#include <chrono>
#include <cstring>
#include <mutex>
#include <random>

#include "fleetmap/core/error.h"

namespace fleetmap {

Uuid Uuid::GenerateRandom() {
  Bytes bytes;
  uuid_generate_random(bytes.data());
  return Uuid(bytes);
}

Uuid Uuid::NameBased(const Uuid& name_space, std::string_view name) {
  Bytes bytes;
  uuid_generate_sha1(bytes.data(), name_space.data(), name.data(), name.size());
  return Uuid(bytes);
}

Uuid Uuid::Generate() {
  if (DeterministicUuids* scope = DeterministicUuids::Current()) return scope->Next();
  // RFC 9562 §6.2 method 1: a 12-bit counter in rand_a keeps ids monotonic within one
  // millisecond; when it overflows, the timestamp moves on by one millisecond (allowed by
  // §6.2; it only happens above 4 million ids a second). This state is process-wide on
  // purpose: monotonicity is a property of the whole process, like libuuid's own clock state.
  static std::mutex mutex;
  static std::uint64_t last_ms = 0;
  static std::uint32_t counter = 0;
  std::uint64_t ms;
  std::uint32_t sequence;
  {
    const std::uint64_t now_ms =
        static_cast<std::uint64_t>(std::chrono::duration_cast<std::chrono::milliseconds>(
                                       std::chrono::system_clock::now().time_since_epoch())
                                       .count());
    std::lock_guard<std::mutex> lock(mutex);
    if (now_ms > last_ms) {
      last_ms = now_ms;
      counter = 0;
    } else if (++counter > 0xfff) {
      ++last_ms;
      counter = 0;
    }
    ms = last_ms;
    sequence = counter;
  }
  // The 62 random bits come from a per-thread generator seeded by libuuid: libuuid's own
  // uuid_generate_random re-seeds libc's PRNG on every call (~9k instructions an id under
  // callgrind), too slow for builders that mint an id per frame. Re-seeding after fork()
  // keeps a parent and its child from minting the same ids in the same millisecond.
  thread_local std::mt19937_64 random_bits;
  thread_local pid_t seeded_for = -1;
  if (seeded_for != getpid()) {
    Bytes seed;
    uuid_generate_random(seed.data());
    std::seed_seq seeds(seed.begin(), seed.end());
    random_bits.seed(seeds);
    seeded_for = getpid();
  }
  const std::uint64_t high = random_bits(), low = random_bits();
  return Version7(ms, sequence, high, low);
}

Uuid Uuid::Version7(std::uint64_t ms, std::uint32_t sequence, std::uint64_t random_high,
                    std::uint64_t random_low) {
  Bytes bytes;
  for (int i = 0; i < 8; ++i) {
    bytes[i] = static_cast<std::uint8_t>(random_high >> (8 * i));
    bytes[8 + i] = static_cast<std::uint8_t>(random_low >> (8 * i));
  }
  for (int i = 0; i < 6; ++i) bytes[i] = static_cast<std::uint8_t>(ms >> (40 - 8 * i));
  bytes[6] = static_cast<std::uint8_t>(0x70 | ((sequence >> 8) & 0x0f));  // version 7
  bytes[7] = static_cast<std::uint8_t>(sequence & 0xff);
  bytes[8] = static_cast<std::uint8_t>(0x80 | (bytes[8] & 0x3f));  // RFC variant
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
