// Where DOWNLOAD's policies place the map's nodes: its metric components laid out in metres.
//
// Nodes carry no absolute position, only the 6-DoF poses of the metric edges between them
// (edge.h: from_T_to). So each connected component of the graph over metric edges gets its own
// frame, the camera frame of its lowest-UUID node, and every other node of it the pose
// root_T_node composed from there along the shortest chain in metres (Dijkstra over the edges'
// translation lengths: the shortest chains drift least). Around a loop the first pose reached
// wins; nothing is optimised, so a long loop's drift shows as two places where there is one.
// Path edges carry no pose and are ignored.
//
// The coverage guarantee cuts this layout into stretches (stretch_coverage.h) and a route
// download places its route in it (download_route.h). It differs from the export's layout
// (fleetmap/interchange/graph_layout.h, rooted at the earliest node by stamp) only in its root:
// the lowest UUID, which depends on nothing but the ids, whatever order the nodes come in.
//
// Conventions: poses a_T_b (se3.h), metres.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"

namespace fleetmap {

struct MapLayout {
  // By position in the `nodes` given to LayOutMap. Components are numbered 0, 1, ... in
  // ascending order of their lowest UUID.
  std::vector<std::size_t> component;
  std::vector<Se3> root_T_node;  // in the frame of its component's lowest-UUID node
  std::size_t component_count = 0;

  Eigen::Vector3d position_m(std::size_t node) const { return root_T_node[node].translation(); }
};

// `nodes` is the map (any order, no id twice); the metric `edges` between them lay it out,
// others are ignored. The nodes' order does not matter: each node gets the same component root
// and pose whatever it is. Throws Error(kIntegrity) naming a metric edge with an end outside
// `nodes`.
MapLayout LayOutMap(std::span<const Node* const> nodes, std::span<const Edge> edges);

}  // namespace fleetmap
