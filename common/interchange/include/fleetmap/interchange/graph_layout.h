// Where each node of an experience graph sits, found by composing its metric edges: the one
// picture of a map that `fleetmap export` writes out (and `render` will draw).
//
// Conventions (as se3.h):
// - The graph falls into connected components over its metric edges; path edges (seed 002 §IV)
//   carry no pose and take no part. Each component has its own frame, "layout": the camera frame
//   of its reference node, the earliest of its nodes by (stamp_ns, UUID). Frames of different
//   components are unrelated: nothing measured joins them.
// - layout_T_node maps points in a node's camera frame into its component's layout frame:
//   p_layout = layout_T_node * p_camera. The reference node's pose is the identity.
// - Poses are composed breadth first from the reference: crossing a metric edge forwards gives
//   layout_T_to = layout_T_from * from_T_to, backwards layout_T_from = layout_T_to *
//   inverse(from_T_to). Where edges form a loop the measurements disagree a little; the first
//   pose a node is reached with wins (fewest edges from the reference; among those, the node
//   dequeued first, whose edges are followed in UUID order), so the result depends only on the
//   graph, never on the order its elements were read in. Nothing is optimised: the layout shows
//   the map as its edges measured it.
// - Nodes are numbered 0..N-1 in (stamp_ns, UUID) order (nodes()); components 0..C-1 in the
//   order of their reference nodes. Exports use these numbers (g2o vertex ids).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <unordered_map>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

// One node's place in the layout.
struct LaidOutNode {
  Uuid id;
  std::int64_t stamp_ns = 0;
  Uuid robot;
  Uuid outing;
  int component = 0;  // 0-based, in the order of the components' reference nodes
  Se3 layout_T_node = Se3::Identity();
};

class GraphLayout {
 public:
  // Lays out `nodes` by the metric edges among `edges` (path edges are only checked).
  // Throws Error(kInvalidArgument) naming a node UUID given twice, and Error(kIntegrity) naming
  // an edge (metric or path) with an end that is not among `nodes`. An empty graph has no
  // components.
  static GraphLayout Compute(const std::vector<Node>& nodes, const std::vector<Edge>& edges);

  // Every node in (stamp_ns, UUID) order: a node's index here is its number.
  const std::vector<LaidOutNode>& nodes() const { return nodes_; }
  // This layout with other poses for its nodes (by number): the same nodes, numbers, components
  // and references, as a relaxation of it gives (fleetmap/relaxation/relaxed_layout.h).
  // Throws Error(kInvalidArgument) unless there is one pose per node and every reference's is
  // the identity (a component's frame is its reference's camera frame).
  GraphLayout WithPoses(std::vector<Se3> layout_T_node) const;

  // The number of `id` in nodes(); nullopt for a node not in the layout.
  std::optional<std::size_t> IndexOf(const Uuid& id) const;
  std::size_t component_count() const { return references_.size(); }
  // The reference node of each component (its index in nodes()): component c's is
  // references()[c], and its pose is the identity.
  const std::vector<std::size_t>& references() const { return references_; }

 private:
  std::vector<LaidOutNode> nodes_;
  std::unordered_map<Uuid, std::size_t> index_of_;
  std::vector<std::size_t> references_;
};

}  // namespace fleetmap
