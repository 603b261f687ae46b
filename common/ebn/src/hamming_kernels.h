// Private: the popcount kernels behind FindHammingNeighbours, and the one ranking step both
// share so that they cannot disagree.
#pragma once

#include <span>

#include "fleetmap/ebn/hamming.h"

#if defined(__x86_64__) && (defined(__GNUC__) || defined(__clang__))
#define FLEETMAP_HAVE_AVX2_KERNEL 1
#else
#define FLEETMAP_HAVE_AVX2_KERNEL 0
#endif

namespace fleetmap::internal {

// Ranks candidate `index` at `distance` into `nearest`. Candidates must arrive in increasing
// index order: the strict comparisons then keep the lowest index among equal distances.
inline void OfferCandidate(NearestTwo& nearest, int distance, int index) {
  if (distance < nearest.best.distance) {
    nearest.second = nearest.best;
    nearest.best = {index, distance};
  } else if (distance < nearest.second.distance) {
    nearest.second = {index, distance};
  }
}

// REQUIRES: out.per_query.size() == queries.size(), out.per_train.size() == train.size(),
// all entries default-constructed.
void FindHammingNeighboursScalar(std::span<const Descriptor256> queries,
                                 std::span<const Descriptor256> train, HammingNeighbours& out);

#if FLEETMAP_HAVE_AVX2_KERNEL
// True when the CPU runs AVX2 (checked with __builtin_cpu_supports).
bool CpuHasAvx2();

// Same contract as the scalar kernel. REQUIRES: CpuHasAvx2().
void FindHammingNeighboursAvx2(std::span<const Descriptor256> queries,
                               std::span<const Descriptor256> train, HammingNeighbours& out);
#endif

}  // namespace fleetmap::internal
