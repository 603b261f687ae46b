// A map as GraphML (graphml.graphdrawing.org), for graph tools (Gephi, yEd, Cytoscape,
// NetworkX's read_graphml).
//
// One <graph edgedefault="directed">: a <node> per node, in layout order (graph_layout.h), and
// an <edge> per edge, metric and path, from its `from` node to its `to` node, in (source index,
// target index, edge UUID) order. Node i has id "n<i>", the number g2o_writer.h gives it; edges
// are "e0", "e1", ... (GraphML's DTD makes ids XML IDs, which may not start with a digit as a
// UUID may). Every attribute is declared by a <key> whose id is its attr.name (the GraphML
// primer wants attribute names unique in a document, hence edge_uuid):
//   node: uuid string, stamp_ns long (UTC), robot string, outing string, landmarks int (how
//         many), component int, x y z double (metres: the node's position in its component's
//         layout frame, the translation of layout_T_node)
//   edge: edge_uuid string, kind string ("metric" or "path"), path string (path edges only),
//         tx ty tz qw qx qy qz double (metric edges only: from_T_to, metres and a unit
//         quaternion with qw >= 0)
// Numbers are the shortest text that reads back to the same double. Text is XML-escaped.
#pragma once

#include <ostream>
#include <string_view>

#include "fleetmap/core/graph.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

// Writes `map` to `out` as GraphML. `description`, when not empty, becomes the graph's <desc>.
// REQUIRES: `layout` is GraphLayout::Compute(map.nodes, map.edges); a node or edge end missing
// from it throws Error(kInvalidArgument). Landmarks that do not decode throw Error(kCorrupt)
// naming the node, before anything is written. Stream failures are the caller's to check.
void WriteGraphMl(const GraphBatch& map, const GraphLayout& layout, std::string_view description,
                  std::ostream& out);

}  // namespace fleetmap
