// The columns of the edges table, named alike in both backends' schemas, in the order each
// backend's ReadEdge (sqlite/element_rows.h, postgres/element_rows.h) reads them.
#pragma once

namespace fleetmap::internal {

inline constexpr const char* kEdgeColumns =
    "id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz, path_id, covariance";
// kEdgeColumns of the edges table aliased as e.
inline constexpr const char* kEdgeColumnsOfE =
    "e.id, e.from_id, e.to_id, e.kind, e.tx, e.ty, e.tz, e.qw, e.qx, e.qy, e.qz, e.path_id,"
    " e.covariance";

}  // namespace fleetmap::internal
