#include "annotation_sql.h"

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

namespace {

std::string P(SqlDialect dialect, int n) {
  return (dialect == SqlDialect::kSqlite ? "?" : "$") + std::to_string(n);
}

// (annotation_id, label) of every registered type with a label column: what compound queries
// match labels against, whichever payload table a label lives in.
std::string LabelledCte() {
  std::string union_all;
  for (const AnnotationType& type : AnnotationTypes()) {
    if (type.label_column.empty()) continue;
    if (!union_all.empty()) union_all += " UNION ALL ";
    union_all += "SELECT annotation_id, " + std::string(type.label_column) + " AS label FROM " +
                 std::string(type.table);
  }
  return "labelled (annotation_id, label) AS (" + union_all + ")";
}

}  // namespace

std::string AnnotationColumnsOf(const char* alias) {
  std::string out;
  for (const char* column :
       {"id", "node_id", "edge_id", "parent_id", "type", "payload", "data_id"}) {
    if (!out.empty()) out += ", ";
    out += std::string(alias) + "." + column;
  }
  return out;
}

std::string TargetExistsSql(SqlDialect dialect, AnnotationTarget kind) {
  switch (kind) {
    case AnnotationTarget::kNode:
      return "SELECT 1 FROM nodes WHERE id = " + P(dialect, 1);
    case AnnotationTarget::kEdge:
      return "SELECT 1 FROM edges WHERE id = " + P(dialect, 1);
    case AnnotationTarget::kDatum:
      return "SELECT 1 FROM data WHERE data_id = " + P(dialect, 1);
    case AnnotationTarget::kNone:
      return "SELECT 1 FROM annotations WHERE id = " + P(dialect, 1);
  }
  throw Error(ErrorCode::kInvalidArgument, "unknown annotation target kind");
}

const char* TargetNoun(AnnotationTarget kind) {
  switch (kind) {
    case AnnotationTarget::kNode:
      return "node";
    case AnnotationTarget::kEdge:
      return "edge";
    case AnnotationTarget::kDatum:
      return "datum";
    case AnnotationTarget::kNone:
      return "parent annotation";
  }
  return "target";
}

std::string FindBoxSql(SqlDialect dialect) {
  return "SELECT " + AnnotationColumnsOf("a") +
         ", b.x_px, b.y_px, b.width_px, b.height_px, b.label, b.score FROM annotations a"
         " LEFT JOIN annotation_bbox2d b ON b.annotation_id = a.id WHERE a.id = " +
         P(dialect, 1);
}

std::string DeleteSubtreeSql(SqlDialect dialect) {
  // UNION, not UNION ALL: a parent must be stored before its child, so the tree has no cycle,
  // but a damaged store must still not recurse forever.
  return "WITH RECURSIVE doomed (id) AS (SELECT id FROM annotations WHERE id = " + P(dialect, 1) +
         " UNION SELECT a.id FROM annotations a JOIN doomed d ON a.parent_id = d.id)"
         " DELETE FROM annotations WHERE id IN (SELECT id FROM doomed)";
}

std::string AnnotatedDataSql(SqlDialect dialect, bool with_child) {
  // σ_{label=θ}(Data ⋈ Annotations), optionally ⋈ a child with label φ (seed 000 §4.2): the
  // data range comes from the (platform, sensor, stamp) index, each candidate is probed through
  // annotations_by_datum and the payload keys; EXISTS keeps each datum once.
  std::string sql = "WITH " + LabelledCte() +
                    " SELECT d.data_id, d.stamp_ns, d.sensor FROM data d"
                    " WHERE d.platform = " +
                    P(dialect, 1) + " AND d.stamp_ns >= " + P(dialect, 2) +
                    " AND d.stamp_ns <= " + P(dialect, 3) +
                    " AND EXISTS (SELECT 1 FROM annotations a"
                    " JOIN labelled l ON l.annotation_id = a.id"
                    " WHERE a.data_id = d.data_id AND l.label = " +
                    P(dialect, 4);
  if (with_child) {
    sql +=
        " AND EXISTS (SELECT 1 FROM annotations c JOIN labelled m ON m.annotation_id = c.id"
        " WHERE c.parent_id = a.id AND m.label = " +
        P(dialect, 5) + ")";
  }
  return sql + ") ORDER BY d.stamp_ns, d.data_id";
}

std::string DataLinkedToSql(SqlDialect dialect) {
  return "SELECT a.id, d.data_id, d.stamp_ns FROM annotations a"
         " JOIN annotation_datum_link l ON l.annotation_id = a.id"
         " JOIN data d ON d.data_id = l.data_id WHERE a.node_id = " +
         P(dialect, 1) + " OR a.edge_id = " + P(dialect, 1) +
         " ORDER BY d.stamp_ns, d.data_id, a.id";
}

std::string AnnotationsOnLinkedDataSql(SqlDialect dialect) {
  return "SELECT DISTINCT " + AnnotationColumnsOf("x") +
         " FROM annotations a JOIN annotation_datum_link l ON l.annotation_id = a.id"
         " JOIN annotations x ON x.data_id = l.data_id WHERE a.node_id = " +
         P(dialect, 1) + " OR a.edge_id = " + P(dialect, 1) + " ORDER BY x.data_id, x.id";
}

std::string LinksToDatumSql(SqlDialect dialect) {
  return "SELECT " + AnnotationColumnsOf("a") +
         " FROM annotations a JOIN annotation_datum_link l ON l.annotation_id = a.id"
         " WHERE l.data_id = " +
         P(dialect, 1) + " ORDER BY a.id";
}

std::string OnDatumSql(SqlDialect dialect) {
  return "SELECT " + AnnotationColumnsOf("a") +
         " FROM annotations a WHERE a.data_id = " + P(dialect, 1) + " ORDER BY a.id";
}

}  // namespace fleetmap::internal
