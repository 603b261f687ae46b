// How the SQLite backend reads graph elements out of result rows. Shared by the GraphStore
// and the VersionStore, which select the same columns in the same order.
#pragma once

#include "edge_columns.h"
#include "fleetmap/core/graph.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

// Columns id, stamp_ns, robot, outing, landmarks (landmarks_blob left empty unless
// with_landmarks).
Node ReadNode(const Statement& s, bool with_landmarks);
// Columns kEdgeColumns from column `first`. A pose that is not SE(3), or a covariance that is
// not 168 bytes (edge_covariance_blob.h), not a valid PoseCovariance or on a path edge, throws
// Error(kCorrupt) naming the edge.
Edge ReadEdge(const Statement& s, int first);
// Columns id, robot, outing, start_ns, end_ns.
Path ReadPath(const Statement& s);
// Columns id, node_id, edge_id, parent_id, type, payload, data_id.
Annotation ReadAnnotation(const Statement& s);

}  // namespace fleetmap::internal
