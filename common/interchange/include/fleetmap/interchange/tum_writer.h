// One outing's trajectory in the TUM RGB-D benchmark's trajectory format (that of its
// groundtruth.txt files), for trajectory tools such as evo.
//
// Lines starting with '#' are comments; then one line per node of the outing in (stamp_ns,
// UUID) order:
//   timestamp tx ty tz qx qy qz qw
// timestamp: UTC seconds since the epoch with all nine digits of the nanoseconds
// ("1700000000.250000000", exact); tx ty tz: the translation of layout_T_node in metres;
// qx qy qz qw: its rotation, a unit quaternion with qw >= 0 (graph_layout.h). TUM poses are in
// one frame: when an outing's nodes lie in several components of the layout their poses are in
// different frames, and a comment line says so.
#pragma once

#include <cstddef>
#include <cstdint>
#include <ostream>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

// What a map holds of one outing.
struct OutingSummary {
  Uuid outing;
  Uuid robot;  // of its earliest node
  std::size_t nodes = 0;
  std::int64_t first_ns = 0, last_ns = 0;  // stamps of its earliest and latest node
};

// The outings of `nodes`, ordered by (first_ns, outing UUID).
std::vector<OutingSummary> OutingsOf(const std::vector<Node>& nodes);

struct TumCounts {
  std::size_t poses = 0;
  std::size_t components = 0;  // how many layout components the poses lie in (1 unless split)
};

// Writes the trajectory of `outing` to `out`. `description`, when not empty, becomes the first
// comment line (line breaks become spaces).
// REQUIRES: `layout` is GraphLayout::Compute(map.nodes, map.edges); a node missing from it
// throws Error(kInvalidArgument). Throws Error(kNotFound) when no node of `map` is on `outing`,
// before anything is written. Stream failures are the caller's to check.
TumCounts WriteTumTrajectory(const GraphBatch& map, const GraphLayout& layout, const Uuid& outing,
                             std::string_view description, std::ostream& out);

}  // namespace fleetmap
