// A node's UUID names its content: a submitted node whose UUID the store holds with other
// content (another robot's node, a robot that reused an id) is a collision, not a duplicate.
// MERGE's UUID dedup (seed 004 §III-D) may only skip a node the server
// holds as it is.
#pragma once

#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap {

// Throws Error(kConflict) naming the first submitted node stored with other content, and what
// differs (stamp, robot, outing, landmarks), when there is one. Reads only the submitted nodes
// the store holds, in batches. Throws as the store does.
void RefuseCollidingNodes(GraphStore& store, const GraphBatch& submission);

}  // namespace fleetmap
