// How the PostgreSQL backend reads graph elements out of libpqxx result rows, and the text it
// sends for UUID arrays. Shared by the GraphStore and the VersionStore, which select the same
// columns (kNodeColumns, kEdgeColumns, ...) in the same order.
#pragma once

#include <initializer_list>
#include <pqxx/pqxx>
#include <span>
#include <string>
#include <string_view>

#include "edge_columns.h"
#include "fleetmap/core/graph.h"

namespace fleetmap::internal {

inline constexpr const char* kNodeColumns = "id, stamp_ns, robot, outing, landmarks";
inline constexpr const char* kPathColumns = "id, robot, outing, start_ns, end_ns";
inline constexpr const char* kAnnotationColumns =
    "id, node_id, edge_id, parent_id, type, payload, data_id";

// The parts concatenated (for building SQL).
std::string Cat(std::initializer_list<std::string_view> parts);

// A PostgreSQL uuid[] literal for "= ANY($1::uuid[])".
std::string UuidArray(std::span<const Uuid> ids);

// A uuid column; NULL reads as nil. Throws Error(kCorrupt) on text that is no UUID.
Uuid UuidField(const pqxx::field& f);
// A bytea column; NULL reads as empty.
std::string BytesField(const pqxx::field& f);
double DoubleField(const pqxx::field& f);

// Rows in the column order of kNodeColumns (landmarks_blob left empty unless
// with_landmarks), kEdgeColumns starting at column `first`, kPathColumns and
// kAnnotationColumns. An edge pose that is not SE(3), or an edge covariance that is not 168
// bytes (edge_covariance_blob.h), not a valid PoseCovariance or on a path edge, throws
// Error(kCorrupt) naming the edge.
Node ReadNode(const pqxx::row& r, bool with_landmarks);
Edge ReadEdge(const pqxx::row& r, pqxx::row::size_type first);
Path ReadPath(const pqxx::row& r);
Annotation ReadAnnotation(const pqxx::row& r);

}  // namespace fleetmap::internal
