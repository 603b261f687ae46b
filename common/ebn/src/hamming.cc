// Portable Hamming distance, the scalar kernel, and the choice of kernel at run time.
#include "fleetmap/ebn/hamming.h"

#include <bit>
#include <cstdint>
#include <cstring>

#include "fleetmap/core/error.h"
#include "hamming_kernels.h"

namespace fleetmap {

// Built for baseline x86-64, std::popcount is a call into libgcc (__popcountdi2) per word:
// a profile of MERGE found it under the vocabulary training and tree descent that the
// repository runs for every merge. A clone with the POPCNT instruction, chosen when the program
// loads on CPUs that have it, counts the same bits.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__POPCNT__)
__attribute__((target_clones("popcnt", "default")))
#endif
int HammingDistance(const Descriptor256& a, const Descriptor256& b) {
  // memcpy into words: the descriptor is a byte array with no alignment promise.
  std::uint64_t wa[4];
  std::uint64_t wb[4];
  std::memcpy(wa, a.data(), sizeof wa);
  std::memcpy(wb, b.data(), sizeof wb);
  return std::popcount(wa[0] ^ wb[0]) + std::popcount(wa[1] ^ wb[1]) +
         std::popcount(wa[2] ^ wb[2]) + std::popcount(wa[3] ^ wb[3]);
}

namespace internal {

void FindHammingNeighboursScalar(std::span<const Descriptor256> queries,
                                 std::span<const Descriptor256> train, HammingNeighbours& out) {
  for (std::size_t i = 0; i < queries.size(); ++i) {
    NearestTwo nearest;
    for (std::size_t j = 0; j < train.size(); ++j) {
      const int distance = HammingDistance(queries[i], train[j]);
      OfferCandidate(nearest, distance, static_cast<int>(j));
      // Queries arrive in increasing index order: strict < keeps the lowest on ties.
      HammingNeighbour& column = out.per_train[j];
      if (distance < column.distance) column = {static_cast<int>(i), distance};
    }
    out.per_query[i] = nearest;
  }
}

}  // namespace internal

bool HammingKernelAvailable(HammingKernel kernel) {
  switch (kernel) {
    case HammingKernel::kAuto:
    case HammingKernel::kScalar:
      return true;
    case HammingKernel::kAvx2:
#if FLEETMAP_HAVE_AVX2_KERNEL
      return internal::CpuHasAvx2();
#else
      return false;
#endif
  }
  return false;
}

HammingKernel SelectedHammingKernel() {
  return HammingKernelAvailable(HammingKernel::kAvx2) ? HammingKernel::kAvx2
                                                      : HammingKernel::kScalar;
}

HammingNeighbours FindHammingNeighbours(std::span<const Descriptor256> queries,
                                        std::span<const Descriptor256> train,
                                        HammingKernel kernel) {
  if (!HammingKernelAvailable(kernel)) {
    throw Error(ErrorCode::kInvalidArgument, "Hamming kernel AVX2 is not available on this CPU");
  }
  if (kernel == HammingKernel::kAuto) kernel = SelectedHammingKernel();

  HammingNeighbours out;
  out.per_query.resize(queries.size());
  out.per_train.resize(train.size());
  if (queries.empty() || train.empty()) return out;
#if FLEETMAP_HAVE_AVX2_KERNEL
  if (kernel == HammingKernel::kAvx2) {
    internal::FindHammingNeighboursAvx2(queries, train, out);
    return out;
  }
#endif
  internal::FindHammingNeighboursScalar(queries, train, out);
  return out;
}

}  // namespace fleetmap
