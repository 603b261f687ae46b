// A map's pose graph in g2o's text format (g2o's 3-D SLAM types), for pose-graph optimisers.
//
// Lines, fields separated by one space, numbers as the shortest text that reads back to the
// same double:
//   VERTEX_SE3:QUAT id x y z qx qy qz qw       one per node, in layout order (graph_layout.h):
//                                              id is the node's index in GraphLayout::nodes(),
//                                              i.e. nodes sorted by (stamp_ns, UUID); the pose
//                                              is layout_T_node, the initial estimate
//   FIX id                                     one per component, its reference node
//   EDGE_SE3:QUAT id1 id2 x y z qx qy qz qw I11 I12 ... I16 I22 ... I66
//                                              one per metric edge, in (id1, id2, edge UUID)
//                                              order: the measurement is from_T_to (id1 the
//                                              `from` node), then the upper triangle of the 6x6
//                                              information matrix row by row (21 numbers)
// Quaternions are unit, qw >= 0. Path edges have no pose and are not written. Before them, when
// a comment is given, one line "# comment" (which layout the poses are, graph_layout.h): g2o
// itself skips '#' lines. Nothing else: not every reader of the format skips them, so the UUIDs
// are not in the file. Vertex i is the i-th node by (stamp_ns, UUID); `fleetmap export
// --format graphml` writes each node's UUID beside the same pose.
//
// The information matrix is the identity for every edge (kG2oEdgeInformation on the diagonal;
// rows x, y, z, then the three rotation components), so every measurement weighs the same and
// an optimiser spreads a loop's disagreement evenly. Only MERGE's links carry a covariance
// (Edge::covariance, in (omega, v) with a left perturbation); it is not converted to g2o's
// convention here.
#pragma once

#include <cstddef>
#include <ostream>
#include <string>

#include "fleetmap/core/graph.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

// The diagonal of every edge's information matrix; its off-diagonal entries are 0.
inline constexpr double kG2oEdgeInformation = 1.0;

struct G2oCounts {
  std::size_t vertices = 0;
  std::size_t fixed = 0;
  std::size_t edges = 0;
};

// Writes the pose graph of `map` to `out` and returns what it wrote.
// REQUIRES: `layout` is GraphLayout::Compute(map.nodes, map.edges); an edge end missing from it
// throws Error(kInvalidArgument). Stream failures are the caller's to check.
// `comment` is one line (a newline in it is written as a space); empty writes none.
G2oCounts WriteG2oPoseGraph(const GraphBatch& map, const GraphLayout& layout, std::ostream& out,
                            const std::string& comment = "");

}  // namespace fleetmap
