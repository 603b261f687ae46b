// Brute-force matching of binary descriptors: the correspondence step of localising a frame
// against a node (docs/ebn-core.md; seed 002 §III-C).
//
// A query i and a train descriptor j match when all of these hold:
// - mutual best (cross-check): j is i's nearest train descriptor and i is j's nearest query;
// - Lowe's ratio test: d(i, j) < ratio x d(i, second nearest train descriptor of i);
//   a query with a single train candidate has no runner-up and passes;
// - d(i, j) <= max_distance.
// Nearest means least Hamming distance, ties going to the lowest index, so results are
// deterministic and the same on every kernel.
#pragma once

#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/hamming.h"

namespace fleetmap {

struct DescriptorMatch {
  int query_index = -1;
  int train_index = -1;
  int distance = 0;  // bits

  friend bool operator==(const DescriptorMatch&, const DescriptorMatch&) = default;
};

struct MatchOptions {
  // Lowe ratio in (0, 1]; 1.0 disables the test (it would otherwise reject exact ties too).
  double ratio = 0.8;
  // Largest accepted distance in bits, [0, 256]; 256 accepts every mutual best.
  int max_distance = 80;
  HammingKernel kernel = HammingKernel::kAuto;
};

// Matches in increasing query_index order, at most one per query and per train descriptor.
// REQUIRES: options within the ranges above, else throws Error(kInvalidArgument).
// Thread-safe: no shared state.
std::vector<DescriptorMatch> MatchDescriptors(std::span<const Descriptor256> queries,
                                              std::span<const Descriptor256> train,
                                              const MatchOptions& options = {});

}  // namespace fleetmap
