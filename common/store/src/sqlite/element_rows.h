// How the SQLite backend reads graph elements out of result rows. Shared by the GraphStore
// and the VersionStore, which select the same columns in the same order.
#pragma once

#include "fleetmap/core/graph.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

// Columns id, stamp_ns, robot, outing, landmarks (landmarks_blob left empty unless
// with_landmarks).
Node ReadNode(const Statement& s, bool with_landmarks);
// Columns id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz, path_id from column `first`.
// A pose that is not SE(3) throws Error(kCorrupt).
Edge ReadEdge(const Statement& s, int first);
// Columns id, robot, outing, start_ns, end_ns.
Path ReadPath(const Statement& s);
// Columns id, node_id, edge_id, parent_id, type, payload, data_id.
Annotation ReadAnnotation(const Statement& s);

}  // namespace fleetmap::internal
