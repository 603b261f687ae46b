// Map integrity for DOWNLOAD (seed 004 §V-B): whatever subset of the server map a policy
// chooses, the robot must receive a graph without dangling edges and without new
// disconnected fragments, or it could not carry a position estimate across the gaps.
//
// MakeIntegral completes a selection: within each connected component of the map (over metric
// edges, the only ones that carry a pose), the selected nodes are joined by adding the nodes
// on shortest metric paths between their fragments; then every edge, metric or path, with
// both ends selected is kept and no other. A path edge never joins fragments: it records that
// a robot localised in both nodes, not where they are relative to each other.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

struct IntegrityReport {
  std::size_t map_components = 0;      // metric components of the whole map
  std::size_t touched_components = 0;  // of those, the ones holding a selected node
  std::size_t fragments_before = 0;    // metric components of the bare selection
  std::size_t components_after = 0;    // of the completed one: equals touched_components
  std::size_t bridging_nodes = 0;      // nodes added to join fragments
};

struct IntegralSelection {
  std::vector<Uuid> nodes;  // ascending
  std::vector<Uuid> edges;  // ascending; both ends in `nodes`
  IntegrityReport report;
};

// `map_nodes` and `map_edges` are the whole map; `selected` a subset of its nodes (repeats
// allowed). Deterministic: among shortest joins the one reached first in ascending-UUID
// breadth-first order wins. Throws Error(kNotFound) naming a selected node the map lacks, and
// Error(kIntegrity) naming an edge whose end the map lacks.
IntegralSelection MakeIntegral(std::span<const Uuid> map_nodes, std::span<const Edge> map_edges,
                               std::span<const Uuid> selected);

}  // namespace fleetmap
