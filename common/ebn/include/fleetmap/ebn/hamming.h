// Hamming distance of 256-bit binary descriptors, and the brute-force nearest-neighbour pass
// that is the inner loop of descriptor matching (docs/ebn-core.md: the localiser matches
// a frame's descriptors against a node's, seed 002 §III-A/C).
//
// Conventions: a distance is a number of differing bits in [0, 256]. Neighbours are ranked by
// (distance, index): among equal distances the lower index ranks first, so results never
// depend on which kernel ran or on the order of floating-point work.
#pragma once

#include <limits>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

// Number of differing bits of a and b (portable, no SIMD).
int HammingDistance(const Descriptor256& a, const Descriptor256& b);

// Distance of a neighbour that does not exist (empty set, or no runner-up).
inline constexpr int kNoHammingDistance = std::numeric_limits<int>::max();

struct HammingNeighbour {
  int index = -1;  // -1: none
  int distance = kNoHammingDistance;

  friend bool operator==(const HammingNeighbour&, const HammingNeighbour&) = default;
};

// The two nearest train descriptors of one query, best first.
struct NearestTwo {
  HammingNeighbour best;
  HammingNeighbour second;

  friend bool operator==(const NearestTwo&, const NearestTwo&) = default;
};

// One pass over all query x train pairs.
struct HammingNeighbours {
  std::vector<NearestTwo> per_query;        // size n: each query's two nearest train descriptors
  std::vector<HammingNeighbour> per_train;  // size m: each train descriptor's nearest query

  friend bool operator==(const HammingNeighbours&, const HammingNeighbours&) = default;
};

// Which popcount kernel computes the distances. Every kernel returns identical results.
enum class HammingKernel {
  kAuto,    // AVX2 when the CPU has it, else scalar
  kScalar,  // 4 x std::popcount on 64-bit words
  kAvx2,    // nibble-lookup popcount (vpshufb), eight train descriptors per step
};

// True when `kernel` can run on this CPU (kAuto and kScalar always can).
bool HammingKernelAvailable(HammingKernel kernel);

// The kernel kAuto resolves to on this CPU.
HammingKernel SelectedHammingKernel();

// Brute-force nearest neighbours of every query in `train` and of every train descriptor in
// `queries`, ranked by (distance, index). Either set may be empty (neighbours are then -1).
// REQUIRES: HammingKernelAvailable(kernel), else throws Error(kInvalidArgument);
// sizes below 2^31. Thread-safe: no shared state.
HammingNeighbours FindHammingNeighbours(std::span<const Descriptor256> queries,
                                        std::span<const Descriptor256> train,
                                        HammingKernel kernel = HammingKernel::kAuto);

}  // namespace fleetmap
