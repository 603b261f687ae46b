// MERGE's segment discovery (seed 004 §V-A, Algorithm 1): a robot's submitted graph is
// replayed edge by edge, grouping nodes joined by egomotion (metric edges) into linear
// segments, so that each segment can then be relocalised against the server map like a
// stream of live frames.
//
// The correspondence C maps a node to the segment holding it. For an edge source → target:
//   only the source is in a segment   → the target joins it, after the source  ("prepend")
//   only the target is in a segment   → the source joins it, before the target ("append")
//   both are                          → their segments fuse, source's first    ("fuse")
//   neither is                        → a new segment [source, target]         ("new")
// The names of the first two follow the paper's comments. Nodes are UUIDs; a segment's order
// is the order in which edges placed its nodes, which for a chain fed in any edge order is the
// chain's order.
//
// Not thread-safe; one instance per MERGE.
#pragma once

#include <cstddef>
#include <deque>
#include <optional>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

// Which branch of Algorithm 1 an edge took.
enum class SegmentStep { kPrepend, kAppend, kFuse, kNew };

class SegmentDiscovery {
 public:
  // One egomotion edge T_k (Algorithm 1, lines 1–13). An edge whose ends are already in one
  // segment (a loop) changes nothing and reports kFuse. A self-edge (source == target) starts
  // or joins nothing beyond that one node.
  SegmentStep Add(const Uuid& source, const Uuid& target);

  // The segment holding `node`, as an index into Segments(); none for a node no edge touched.
  std::optional<std::size_t> SegmentOf(const Uuid& node) const;

  // Every segment, in the order segments were first created (fused ones vanish into the one
  // that was created first), each in chain order.
  std::vector<std::vector<Uuid>> Segments() const;

  std::size_t segment_count() const { return live_segments_; }

 private:
  using SegmentId = std::size_t;

  std::unordered_map<Uuid, SegmentId> segment_of_;  // C
  std::vector<std::deque<Uuid>> segments_;          // by id; fused-away ones are empty
  std::size_t live_segments_ = 0;
};

}  // namespace fleetmap
