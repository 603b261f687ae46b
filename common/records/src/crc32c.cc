// CRC32C (Castagnoli, reflected polynomial 0x82F63B78), the checksum of record files
// (record_file.h). The SSE4.2 crc32 instruction does eight bytes a cycle or so; the portable
// fallback is slicing-by-8 over tables built at compile time (no global state to initialise).
//
// Only the function marked FLEETMAP_SSE42 uses SSE4.2; the file is compiled for the baseline
// ISA and the instruction is chosen at run time (see hamming_avx2.cc for why not -msse4.2).
#include <array>
#include <cstdint>
#include <cstring>
#include <string_view>

#include "fleetmap/records/record_file.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define FLEETMAP_HAVE_SSE42_CRC 1
#include <nmmintrin.h>
#define FLEETMAP_SSE42 __attribute__((target("sse4.2")))
#else
#define FLEETMAP_HAVE_SSE42_CRC 0
#endif

namespace fleetmap {
namespace {

constexpr std::uint32_t kPolynomial = 0x82F63B78u;

using SliceTables = std::array<std::array<std::uint32_t, 256>, 8>;

constexpr SliceTables MakeTables() {
  SliceTables t{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? (c >> 1) ^ kPolynomial : c >> 1;
    t[0][i] = c;
  }
  for (std::size_t s = 1; s < 8; ++s) {
    for (std::uint32_t i = 0; i < 256; ++i)
      t[s][i] = (t[s - 1][i] >> 8) ^ t[0][t[s - 1][i] & 0xffu];
  }
  return t;
}

constexpr SliceTables kTables = MakeTables();

// `crc` is the running register (already inverted).
std::uint32_t UpdatePortable(std::uint32_t crc, const unsigned char* p, std::size_t n) {
  while (n >= 8) {
    std::uint32_t lo = 0;
    std::uint32_t hi = 0;
    std::memcpy(&lo, p, 4);  // little-endian hosts only, like the record header itself
    std::memcpy(&hi, p + 4, 4);
    lo ^= crc;
    crc = kTables[7][lo & 0xffu] ^ kTables[6][(lo >> 8) & 0xffu] ^ kTables[5][(lo >> 16) & 0xffu] ^
          kTables[4][lo >> 24] ^ kTables[3][hi & 0xffu] ^ kTables[2][(hi >> 8) & 0xffu] ^
          kTables[1][(hi >> 16) & 0xffu] ^ kTables[0][hi >> 24];
    p += 8;
    n -= 8;
  }
  while (n-- > 0) crc = (crc >> 8) ^ kTables[0][(crc ^ *p++) & 0xffu];
  return crc;
}

#if FLEETMAP_HAVE_SSE42_CRC
FLEETMAP_SSE42 std::uint32_t UpdateSse42(std::uint32_t crc, const unsigned char* p, std::size_t n) {
  std::uint64_t c = crc;
  while (n >= 8) {
    std::uint64_t word = 0;
    std::memcpy(&word, p, 8);
    c = _mm_crc32_u64(c, word);
    p += 8;
    n -= 8;
  }
  auto c32 = static_cast<std::uint32_t>(c);
  while (n-- > 0) c32 = _mm_crc32_u8(c32, *p++);
  return c32;
}

bool HaveSse42() {
  // __builtin_cpu_supports reads a table libgcc fills before main; cheap enough per call.
  return __builtin_cpu_supports("sse4.2");
}
#endif

}  // namespace

std::uint32_t Crc32c(std::string_view bytes, std::uint32_t crc) {
  const auto* p = reinterpret_cast<const unsigned char*>(bytes.data());
  std::uint32_t reg = ~crc;
#if FLEETMAP_HAVE_SSE42_CRC
  if (HaveSse42()) return ~UpdateSse42(reg, p, bytes.size());
#endif
  return ~UpdatePortable(reg, p, bytes.size());
}

namespace internal {
// For the test that the two implementations agree.
std::uint32_t Crc32cPortable(std::string_view bytes, std::uint32_t crc) {
  return ~UpdatePortable(~crc, reinterpret_cast<const unsigned char*>(bytes.data()), bytes.size());
}
}  // namespace internal

}  // namespace fleetmap
