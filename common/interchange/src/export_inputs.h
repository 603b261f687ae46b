// What every writer reads from a map, the same way: its nodes and edges in the layout's order
// (graph_layout.h), checked against the layout, and a node's landmarks with the node named when
// they do not decode.
#pragma once

#include <cstddef>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap::interchange_internal {

// map.nodes in layout order: result[i] is the node layout.nodes()[i] places. Throws
// Error(kInvalidArgument) when the map and the layout do not hold the same nodes.
std::vector<const Node*> NodesInLayoutOrder(const GraphBatch& map, const GraphLayout& layout);

struct OrderedEdge {
  const Edge* edge;
  std::size_t from;  // layout indices of its ends
  std::size_t to;
};

// The edges of `map` (only the metric ones when `metric_only`) in (from index, to index, edge
// UUID) order. Throws Error(kInvalidArgument) naming an edge whose end is not in the layout.
std::vector<OrderedEdge> EdgesInLayoutOrder(const GraphBatch& map, const GraphLayout& layout,
                                            bool metric_only);

// DecodeLandmarks of the node's blob; Error(kCorrupt) naming the node when it does not decode.
Landmarks LandmarksOf(const Node& node);

}  // namespace fleetmap::interchange_internal
