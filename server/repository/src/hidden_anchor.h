// Where a node the head hides now lies on the visible map. A robot builds on
// what it was sent or what it re-drove; a revert or a promotion may hide that node (or the node
// standing in for it) before the robot's next push. Its edges to that node then need a visible
// node to hang from: the nearest one along the stored metric edges, hidden ones included, with
// the poses composed along the way (a hidden edge is still a measurement; a revert says the
// content is unwanted in the map, not that its geometry is wrong).
#pragma once

#include <cstddef>
#include <optional>

#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct HiddenAnchorLimits {
  double radius_m = 100.0;        // along stored metric edges from the hidden node
  std::size_t max_nodes = 2'000;  // nodes settled before giving up
};

// The node visible at `head` nearest to `hidden` (by metres along stored metric edges added by
// `head`) and the pose of `hidden` in it, as a stand-in: {hidden, visible, visible_T_hidden}.
// nullopt when none is within the limits (the hidden node's piece of the map is hidden whole).
// Throws as the store does.
std::optional<NodeStandIn> AnchorThroughHidden(GraphStore& store, RevisionNumber head,
                                               const Uuid& hidden,
                                               const HiddenAnchorLimits& limits = {});

}  // namespace fleetmap
