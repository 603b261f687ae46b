// SQLite backend of the AnnotationStore. Statements are prepared per call: annotating is not
// on a hot path, and the compound query is one statement whatever the data size.
#include "sqlite/sqlite_annotation_store.h"

#include <string>

#include "annotation_sql.h"
#include "fleetmap/core/error.h"
#include "sqlite/element_rows.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

namespace {

constexpr SqlDialect kDialect = SqlDialect::kSqlite;

class SqliteAnnotationStore final : public AnnotationStore {
 public:
  explicit SqliteAnnotationStore(sqlite3* db) : db_(db) {}

 protected:
  void DoPutBox(const BoxAnnotation& box) override {
    Atomically([&] {
      if (!InsertAnnotation(box.annotation)) {
        const std::optional<BoxAnnotation> stored = DoFindBox(box.annotation.id);
        if (stored && stored->annotation == box.annotation && stored->box == box.box) return;
        throw Error(ErrorCode::kConflict, "annotation " + box.annotation.id.ToString() +
                                              " is already stored with different content");
      }
      Statement s(db_,
                  "INSERT INTO annotation_bbox2d (annotation_id, x_px, y_px, width_px,"
                  " height_px, label, score) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)");
      s.Bind(1, box.annotation.id);
      BindBox(s, 2, box.box);
      s.Run();
    });
  }

  std::optional<BoxAnnotation> DoFindBox(const Uuid& id) override {
    Statement s(db_, FindBoxSql(kDialect).c_str());
    s.Bind(1, id);
    if (!s.Step()) return std::nullopt;
    BoxAnnotation found{ReadAnnotation(s), {}};
    if (s.IsNull(7)) {
      throw Error(ErrorCode::kInvalidArgument, "annotation " + id.ToString() + " has type '" +
                                                   found.annotation.type + "', not a bbox2d");
    }
    found.box = BoundingBox2d{s.Double(7),  s.Double(8), s.Double(9),
                              s.Double(10), s.Text(11),  s.Double(12)};
    return found;
  }

  std::optional<Annotation> DoFindAnnotation(const Uuid& id) override {
    Statement s(
        db_,
        ("SELECT " + AnnotationColumnsOf("a") + " FROM annotations a WHERE a.id = ?1").c_str());
    s.Bind(1, id);
    if (!s.Step()) return std::nullopt;
    return ReadAnnotation(s);
  }

  int DoUpdateBox(const Uuid& id, const BoundingBox2d& box) override {
    Statement s(db_,
                "UPDATE annotation_bbox2d SET x_px = ?2, y_px = ?3, width_px = ?4,"
                " height_px = ?5, label = ?6, score = ?7 WHERE annotation_id = ?1");
    s.Bind(1, id);
    BindBox(s, 2, box);
    return s.Run();
  }

  std::int64_t DoDelete(const Uuid& id) override {
    std::int64_t deleted = 0;
    Atomically([&] {
      Statement s(db_, DeleteSubtreeSql(kDialect).c_str());
      s.Bind(1, id);
      deleted = s.Run();
    });
    return deleted;
  }

  std::vector<Annotation> DoOnDatum(std::int64_t data_id) override {
    return ReadAnnotations(OnDatumSql(kDialect), data_id);
  }

  std::vector<AnnotatedDatum> DoFindAnnotatedData(const AnnotatedDataQuery& q) override {
    const bool with_child = q.filter.child_label.has_value();
    Statement s(db_, AnnotatedDataSql(kDialect, with_child).c_str());
    s.Bind(1, q.platform);
    s.Bind(2, q.from_ns);
    s.Bind(3, q.to_ns);
    s.BindText(4, q.filter.label);
    if (with_child) s.BindText(5, *q.filter.child_label);
    std::vector<AnnotatedDatum> data;
    while (s.Step()) data.push_back(AnnotatedDatum{s.Int64(0), s.Int64(1), s.Int64(2)});
    return data;
  }

  void DoLinkToDatum(const Annotation& link, std::int64_t data_id) override {
    Atomically([&] {
      RequireStored(link.id, AnnotationTarget::kDatum, data_id, Uuid());
      if (!InsertAnnotation(link)) {
        for (const Annotation& a : DoLinksToDatum(data_id)) {
          if (a == link) return;  // the same link again
        }
        throw Error(ErrorCode::kConflict, "annotation " + link.id.ToString() +
                                              " is already stored with different content");
      }
      Statement s(db_,
                  "INSERT INTO annotation_datum_link (annotation_id, data_id) VALUES (?1, ?2)");
      s.Bind(1, link.id);
      s.Bind(2, data_id);
      s.Run();
    });
  }

  std::vector<LinkedDatum> DoDataLinkedTo(const Uuid& element) override {
    Statement s(db_, DataLinkedToSql(kDialect).c_str());
    s.Bind(1, element);
    std::vector<LinkedDatum> data;
    while (s.Step()) data.push_back(LinkedDatum{s.UuidAt(0), s.Int64(1), s.Int64(2)});
    return data;
  }

  std::vector<Annotation> DoAnnotationsOnDataLinkedTo(const Uuid& element) override {
    Statement s(db_, AnnotationsOnLinkedDataSql(kDialect).c_str());
    s.Bind(1, element);
    std::vector<Annotation> annotations;
    while (s.Step()) annotations.push_back(ReadAnnotation(s));
    return annotations;
  }

  std::vector<Annotation> DoLinksToDatum(std::int64_t data_id) override {
    return ReadAnnotations(LinksToDatumSql(kDialect), data_id);
  }

 private:
  // Runs fn under a savepoint: inside the GraphStore's open transaction it undoes only fn's
  // writes on failure; outside one it is a transaction of its own.
  template <typename Fn>
  void Atomically(Fn&& fn) {
    ExecSql(db_, "SAVEPOINT fleetmap_annotation");
    try {
      fn();
    } catch (...) {
      ExecSql(db_, "ROLLBACK TO fleetmap_annotation");
      ExecSql(db_, "RELEASE fleetmap_annotation");
      throw;
    }
    ExecSql(db_, "RELEASE fleetmap_annotation");
  }

  static void BindBox(Statement& s, int first, const BoundingBox2d& box) {
    s.Bind(first, box.x_px);
    s.Bind(first + 1, box.y_px);
    s.Bind(first + 2, box.width_px);
    s.Bind(first + 3, box.height_px);
    s.BindText(first + 4, box.label);
    s.Bind(first + 5, box.score);
  }

  // Error(kIntegrity) naming what annotation `id` would be on when it is not stored.
  void RequireStored(const Uuid& id, AnnotationTarget kind, std::int64_t data_id,
                     const Uuid& uuid) {
    Statement s(db_, TargetExistsSql(kDialect, kind).c_str());
    if (kind == AnnotationTarget::kDatum) {
      s.Bind(1, data_id);
    } else {
      s.Bind(1, uuid);
    }
    if (s.Step()) return;
    const std::string what =
        kind == AnnotationTarget::kDatum ? std::to_string(data_id) : uuid.ToString();
    throw Error(
        ErrorCode::kIntegrity,
        "annotation " + id.ToString() + " refused: " + TargetNoun(kind) + " " + what +
            (kind == AnnotationTarget::kDatum ? " is not in the sensor index" : " is not stored"));
  }

  // Inserts the annotation row; false when its id was stored already (nothing written).
  bool InsertAnnotation(const Annotation& a) {
    const Uuid& on = a.target_kind == AnnotationTarget::kNone ? a.parent : a.target;
    RequireStored(a.id, a.target_kind, a.data_id, on);
    const Uuid node_id = a.target_kind == AnnotationTarget::kNode ? a.target : Uuid();
    const Uuid edge_id = a.target_kind == AnnotationTarget::kEdge ? a.target : Uuid();
    Statement s(db_,
                "INSERT INTO annotations (id, node_id, edge_id, parent_id, type, payload, data_id)"
                " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7) ON CONFLICT (id) DO NOTHING");
    s.Bind(1, a.id);
    s.BindNullableUuid(2, node_id);
    s.BindNullableUuid(3, edge_id);
    s.BindNullableUuid(4, a.parent);
    s.BindText(5, a.type);
    s.BindBlob(6, a.payload);
    if (a.target_kind == AnnotationTarget::kDatum) s.Bind(7, a.data_id);
    return s.Run() == 1;
  }

  std::vector<Annotation> ReadAnnotations(const std::string& sql, std::int64_t key) {
    Statement s(db_, sql.c_str());
    s.Bind(1, key);
    std::vector<Annotation> annotations;
    while (s.Step()) annotations.push_back(ReadAnnotation(s));
    return annotations;
  }

  sqlite3* db_;
};

}  // namespace

std::unique_ptr<AnnotationStore> NewSqliteAnnotationStore(sqlite3* db) {
  return std::make_unique<SqliteAnnotationStore>(db);
}

}  // namespace fleetmap::internal
