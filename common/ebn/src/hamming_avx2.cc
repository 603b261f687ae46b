// The AVX2 kernel of FindHammingNeighbours: nibble-lookup popcount (vpshufb), eight train
// descriptors per step.
//
// Only the functions marked FLEETMAP_AVX2 may use AVX2; the file is compiled for the baseline
// ISA. (Compiling the whole file with -mavx2 would let inline functions from headers, say
// std::vector's, be emitted with AVX2 instructions and chosen by the linker for callers on
// CPUs without it.)
#include "hamming_kernels.h"

#if FLEETMAP_HAVE_AVX2_KERNEL

#include <immintrin.h>

#include <cstdint>
#include <vector>

#define FLEETMAP_AVX2 __attribute__((target("avx2")))

namespace fleetmap::internal {
namespace {

constexpr std::size_t kLanes = 8;  // train descriptors per step, one int32 distance each

// A descriptor split into its low and high nibbles, one per byte. (q ^ t) & 0x0f equals
// (q & 0x0f) ^ (t & 0x0f), so splitting each train descriptor once saves the mask and shift
// of every pair.
struct alignas(64) SplitDescriptor {
  std::uint8_t low[32];
  std::uint8_t high[32];
};

SplitDescriptor Split(const Descriptor256& d) {
  SplitDescriptor s{};
  for (std::size_t b = 0; b < d.size(); ++b) {
    s.low[b] = d[b] & 0x0f;
    s.high[b] = static_cast<std::uint8_t>(d[b] >> 4);
  }
  return s;
}

FLEETMAP_AVX2 __m256i Load(const std::uint8_t* p) {
  return _mm256_load_si256(reinterpret_cast<const __m256i*>(p));
}

// Popcount of q ^ t as four partial sums, one per 64-bit lane.
FLEETMAP_AVX2 inline __m256i PartialCounts(__m256i q_low, __m256i q_high, const SplitDescriptor& t,
                                           __m256i table) {
  const __m256i low = _mm256_shuffle_epi8(table, _mm256_xor_si256(q_low, Load(t.low)));
  const __m256i high = _mm256_shuffle_epi8(table, _mm256_xor_si256(q_high, Load(t.high)));
  // Each byte holds at most 8, so the byte sum cannot overflow before the sum of absolute
  // differences against zero folds eight bytes into each 64-bit lane.
  return _mm256_sad_epu8(_mm256_add_epi8(low, high), _mm256_setzero_si256());
}

// Interleaves the partial sums of two descriptors as 32-bit fields: [a0 b0 a1 b1 | a2 b2 a3 b3].
FLEETMAP_AVX2 inline __m256i Interleave(__m256i a, __m256i b) {
  return _mm256_or_si256(a, _mm256_slli_epi64(b, 32));
}

// Folds four descriptors' partial sums to [d0 d1 d2 d3 | d0' d1' d2' d3'], two halves each.
FLEETMAP_AVX2 inline __m256i FoldFour(__m256i s0, __m256i s1, __m256i s2, __m256i s3) {
  const __m256i s01 = Interleave(s0, s1);
  const __m256i s23 = Interleave(s2, s3);
  return _mm256_add_epi32(_mm256_unpacklo_epi64(s01, s23), _mm256_unpackhi_epi64(s01, s23));
}

// Distances of the query to t[0..8), as eight int32 in lane order.
FLEETMAP_AVX2 inline __m256i Distances(__m256i q_low, __m256i q_high, const SplitDescriptor* t,
                                       __m256i table) {
  const __m256i d0123 = FoldFour(
      PartialCounts(q_low, q_high, t[0], table), PartialCounts(q_low, q_high, t[1], table),
      PartialCounts(q_low, q_high, t[2], table), PartialCounts(q_low, q_high, t[3], table));
  const __m256i d4567 = FoldFour(
      PartialCounts(q_low, q_high, t[4], table), PartialCounts(q_low, q_high, t[5], table),
      PartialCounts(q_low, q_high, t[6], table), PartialCounts(q_low, q_high, t[7], table));
  return _mm256_add_epi32(_mm256_permute2x128_si256(d0123, d4567, 0x20),
                          _mm256_permute2x128_si256(d0123, d4567, 0x31));
}

FLEETMAP_AVX2 __m256i LoadUnaligned(const void* p) {
  return _mm256_loadu_si256(static_cast<const __m256i*>(p));
}

FLEETMAP_AVX2 void StoreUnaligned(void* p, __m256i v) {
  _mm256_storeu_si256(static_cast<__m256i*>(p), v);
}

}  // namespace

bool CpuHasAvx2() {
  return __builtin_cpu_supports("avx2");
}

FLEETMAP_AVX2 void FindHammingNeighboursAvx2(std::span<const Descriptor256> queries,
                                             std::span<const Descriptor256> train,
                                             HammingNeighbours& out) {
  const std::size_t m = train.size();
  const std::size_t steps = (m + kLanes - 1) / kLanes;
  // Padding lanes hold zero descriptors; they are masked out of the query ranking and their
  // column entries are never copied out.
  std::vector<SplitDescriptor> split(steps * kLanes, SplitDescriptor{});
  for (std::size_t j = 0; j < m; ++j) split[j] = Split(train[j]);
  std::vector<std::int32_t> column_distance(steps * kLanes, kNoHammingDistance);
  std::vector<std::int32_t> column_index(steps * kLanes, -1);
  const std::size_t tail = m - (steps - 1) * kLanes;  // valid lanes of the last step, 1..8
  const int last_step_mask = (1 << tail) - 1;

  const __m256i table = _mm256_setr_epi8(0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4,  //
                                         0, 1, 1, 2, 1, 2, 2, 3, 1, 2, 2, 3, 2, 3, 3, 4);
  const __m256i nibble = _mm256_set1_epi8(0x0f);
  alignas(32) std::int32_t lane_distance[kLanes];

  for (std::size_t i = 0; i < queries.size(); ++i) {
    const __m256i q = LoadUnaligned(queries[i].data());
    const __m256i q_low = _mm256_and_si256(q, nibble);
    const __m256i q_high = _mm256_and_si256(_mm256_srli_epi16(q, 4), nibble);
    const __m256i query_index = _mm256_set1_epi32(static_cast<int>(i));
    NearestTwo nearest;
    __m256i runner_up = _mm256_set1_epi32(nearest.second.distance);

    for (std::size_t step = 0; step < steps; ++step) {
      const std::size_t j0 = step * kLanes;
      const __m256i d = Distances(q_low, q_high, &split[j0], table);

      // Each train descriptor's nearest query; strict > keeps the lowest query index on ties.
      const __m256i column_d = LoadUnaligned(&column_distance[j0]);
      const __m256i closer = _mm256_cmpgt_epi32(column_d, d);
      StoreUnaligned(&column_distance[j0], _mm256_blendv_epi8(column_d, d, closer));
      StoreUnaligned(&column_index[j0],
                     _mm256_blendv_epi8(LoadUnaligned(&column_index[j0]), query_index, closer));

      // The query's two nearest: only a lane below the current runner-up can change them, and
      // once the first few steps are done almost no lane is, so the ranking step is skipped.
      int candidates = _mm256_movemask_ps(_mm256_castsi256_ps(_mm256_cmpgt_epi32(runner_up, d)));
      if (step + 1 == steps) candidates &= last_step_mask;
      if (candidates == 0) continue;
      _mm256_store_si256(reinterpret_cast<__m256i*>(lane_distance), d);
      for (std::size_t lane = 0; lane < kLanes; ++lane) {
        if ((candidates >> lane) & 1) {
          OfferCandidate(nearest, lane_distance[lane], static_cast<int>(j0 + lane));
        }
      }
      runner_up = _mm256_set1_epi32(nearest.second.distance);
    }
    out.per_query[i] = nearest;
  }
  for (std::size_t j = 0; j < m; ++j) out.per_train[j] = {column_index[j], column_distance[j]};
}

}  // namespace fleetmap::internal

#endif  // FLEETMAP_HAVE_AVX2_KERNEL
