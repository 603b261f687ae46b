// The SQL of the AnnotationStore, shared by both backends: the statements are the same text
// but for the parameter marker (SQLite "?N", PostgreSQL "$N"), so a backend never drifts from
// the other in what a query means.
#pragma once

#include <string>

#include "fleetmap/store/annotation_store.h"

namespace fleetmap::internal {

enum class SqlDialect { kSqlite, kPostgres };

// The columns GraphStore backends read annotations from (element_rows.h), qualified by alias.
std::string AnnotationColumnsOf(const char* alias);

// What an annotation is on, for existence checks: "SELECT 1 FROM <table> WHERE <key> = P1".
// REQUIRES: a valid target kind.
std::string TargetExistsSql(SqlDialect dialect, AnnotationTarget kind);
// "node", "edge", "datum" or "parent annotation", for messages.
const char* TargetNoun(AnnotationTarget kind);

// Annotation columns (7) then the box columns x_px, y_px, width_px, height_px, label, score
// (NULL when the annotation has no box), for the annotation P1.
std::string FindBoxSql(SqlDialect dialect);

// Deletes the annotation P1 and every annotation below it in one statement; payload rows go
// by their ON DELETE CASCADE.
std::string DeleteSubtreeSql(SqlDialect dialect);

// Seed 000 §4.2 compound query: columns data_id, stamp_ns, sensor. Parameters: P1 platform,
// P2 from_ns, P3 to_ns, P4 label and, when with_child, P5 child label.
std::string AnnotatedDataSql(SqlDialect dialect, bool with_child);

// Links (seed 000 §4.3.1). P1 is the node or edge UUID, or the data_id for LinksToDatumSql.
std::string DataLinkedToSql(SqlDialect dialect);             // link id, data_id, stamp_ns
std::string AnnotationsOnLinkedDataSql(SqlDialect dialect);  // annotation columns
std::string LinksToDatumSql(SqlDialect dialect);             // annotation columns
std::string OnDatumSql(SqlDialect dialect);                  // annotation columns

}  // namespace fleetmap::internal
