// PostgreSQL backend of the AnnotationStore (libpqxx 6). Statements go through exec_params
// (planned with the actual values, so the compound query's plan fits its platform and window);
// libpqxx exceptions become fleetmap::Error in PgSession::Translate.
#include "postgres/postgres_annotation_store.h"

#include <cstdio>
#include <string>

#include "annotation_sql.h"
#include "fleetmap/core/error.h"
#include "postgres/element_rows.h"

namespace fleetmap::internal {

namespace {

constexpr SqlDialect kDialect = SqlDialect::kPostgres;

class PostgresAnnotationStore final : public AnnotationStore {
 public:
  explicit PostgresAnnotationStore(PgSession& session) : session_(session) {}

 protected:
  void DoPutBox(const BoxAnnotation& box) override {
    const Annotation& a = box.annotation;
    const bool inserted =
        session_.Atomically("put annotation " + a.id.ToString(), [&](pqxx::transaction_base& t) {
          if (!InsertAnnotation(t, a)) return false;
          t.exec_params(
              "INSERT INTO annotation_bbox2d (annotation_id, x_px, y_px, width_px, height_px,"
              " label, score) VALUES ($1, $2, $3, $4, $5, $6, $7)",
              a.id.ToString(), Text(box.box.x_px), Text(box.box.y_px), Text(box.box.width_px),
              Text(box.box.height_px), box.box.label, Text(box.box.score));
          return true;
        });
    if (inserted) return;
    const std::optional<BoxAnnotation> stored = DoFindBox(a.id);
    if (stored && stored->annotation == a && stored->box == box.box) return;
    throw Error(ErrorCode::kConflict,
                "annotation " + a.id.ToString() + " is already stored with different content");
  }

  std::optional<BoxAnnotation> DoFindBox(const Uuid& id) override {
    return session_.Autocommit(
        "find bbox2d " + id.ToString(),
        [&](pqxx::transaction_base& t) -> std::optional<BoxAnnotation> {
          const pqxx::result r = t.exec_params(FindBoxSql(kDialect), id.ToString());
          if (r.empty()) return std::nullopt;
          BoxAnnotation found{ReadAnnotation(r[0]), {}};
          if (r[0][7].is_null()) {
            throw Error(ErrorCode::kInvalidArgument, "annotation " + id.ToString() + " has type '" +
                                                         found.annotation.type + "', not a bbox2d");
          }
          found.box =
              BoundingBox2d{DoubleField(r[0][7]),  DoubleField(r[0][8]), DoubleField(r[0][9]),
                            DoubleField(r[0][10]), r[0][11].c_str(),     DoubleField(r[0][12])};
          return found;
        });
  }

  std::optional<Annotation> DoFindAnnotation(const Uuid& id) override {
    return session_.Autocommit(
        "find annotation", [&](pqxx::transaction_base& t) -> std::optional<Annotation> {
          const pqxx::result r = t.exec_params(
              "SELECT " + AnnotationColumnsOf("a") + " FROM annotations a WHERE a.id = $1",
              id.ToString());
          if (r.empty()) return std::nullopt;
          return ReadAnnotation(r[0]);
        });
  }

  int DoUpdateBox(const Uuid& id, const BoundingBox2d& box) override {
    return session_.Autocommit("update bbox2d " + id.ToString(), [&](pqxx::transaction_base& t) {
      return static_cast<int>(
          t.exec_params("UPDATE annotation_bbox2d SET x_px = $2, y_px = $3, width_px = $4,"
                        " height_px = $5, label = $6, score = $7 WHERE annotation_id = $1",
                        id.ToString(), Text(box.x_px), Text(box.y_px), Text(box.width_px),
                        Text(box.height_px), box.label, Text(box.score))
              .affected_rows());
    });
  }

  std::int64_t DoDelete(const Uuid& id) override {
    // One statement: atomic by itself, cascading to the payload rows.
    return session_.Autocommit(
        "delete annotation " + id.ToString(), [&](pqxx::transaction_base& t) {
          return static_cast<std::int64_t>(
              t.exec_params(DeleteSubtreeSql(kDialect), id.ToString()).affected_rows());
        });
  }

  std::vector<Annotation> DoOnDatum(std::int64_t data_id) override {
    return ReadAnnotations("annotations on datum", OnDatumSql(kDialect), std::to_string(data_id));
  }

  std::vector<AnnotatedDatum> DoFindAnnotatedData(const AnnotatedDataQuery& q) override {
    const bool with_child = q.filter.child_label.has_value();
    const std::string sql = AnnotatedDataSql(kDialect, with_child);
    return session_.Autocommit("annotated-data query", [&](pqxx::transaction_base& t) {
      const pqxx::result rows =
          with_child ? t.exec_params(sql, q.platform, q.from_ns, q.to_ns, q.filter.label,
                                     *q.filter.child_label)
                     : t.exec_params(sql, q.platform, q.from_ns, q.to_ns, q.filter.label);
      std::vector<AnnotatedDatum> data;
      data.reserve(rows.size());
      for (const pqxx::row& r : rows) {
        data.push_back(AnnotatedDatum{r[0].as<std::int64_t>(), r[1].as<std::int64_t>(),
                                      r[2].as<std::int64_t>()});
      }
      return data;
    });
  }

  void DoLinkToDatum(const Annotation& link, std::int64_t data_id) override {
    const bool inserted = session_.Atomically(
        "link annotation " + link.id.ToString(), [&](pqxx::transaction_base& t) {
          RequireStored(t, link.id, AnnotationTarget::kDatum, std::to_string(data_id));
          if (!InsertAnnotation(t, link)) return false;
          t.exec_params(
              "INSERT INTO annotation_datum_link (annotation_id, data_id) VALUES ($1, $2)",
              link.id.ToString(), data_id);
          return true;
        });
    if (inserted) return;
    for (const Annotation& a : DoLinksToDatum(data_id)) {
      if (a == link) return;  // the same link again
    }
    throw Error(ErrorCode::kConflict,
                "annotation " + link.id.ToString() + " is already stored with different content");
  }

  std::vector<LinkedDatum> DoDataLinkedTo(const Uuid& element) override {
    return session_.Autocommit(
        "data linked to " + element.ToString(), [&](pqxx::transaction_base& t) {
          std::vector<LinkedDatum> data;
          for (const pqxx::row& r : t.exec_params(DataLinkedToSql(kDialect), element.ToString())) {
            data.push_back(
                LinkedDatum{UuidField(r[0]), r[1].as<std::int64_t>(), r[2].as<std::int64_t>()});
          }
          return data;
        });
  }

  std::vector<Annotation> DoAnnotationsOnDataLinkedTo(const Uuid& element) override {
    return ReadAnnotations("annotations on data linked to " + element.ToString(),
                           AnnotationsOnLinkedDataSql(kDialect), element.ToString());
  }

  std::vector<Annotation> DoLinksToDatum(std::int64_t data_id) override {
    return ReadAnnotations("links to datum", LinksToDatumSql(kDialect), std::to_string(data_id));
  }

 private:
  // Error(kIntegrity) naming what annotation `id` would be on when it is not stored.
  static void RequireStored(pqxx::transaction_base& t, const Uuid& id, AnnotationTarget kind,
                            const std::string& key) {
    if (!t.exec_params(TargetExistsSql(kDialect, kind), key).empty()) return;
    throw Error(
        ErrorCode::kIntegrity,
        "annotation " + id.ToString() + " refused: " + TargetNoun(kind) + " " + key +
            (kind == AnnotationTarget::kDatum ? " is not in the sensor index" : " is not stored"));
  }

  // Inserts the annotation row; false when its id was stored already (nothing written).
  static bool InsertAnnotation(pqxx::transaction_base& t, const Annotation& a) {
    const std::string target = a.target.ToString(), parent = a.parent.ToString(),
                      datum = std::to_string(a.data_id);
    const AnnotationTarget kind = a.target_kind;
    RequireStored(t, a.id, kind,
                  kind == AnnotationTarget::kDatum  ? datum
                  : kind == AnnotationTarget::kNone ? parent
                                                    : target);
    return t.exec_params(
                "INSERT INTO annotations (id, node_id, edge_id, parent_id, type, payload,"
                " data_id) VALUES ($1, $2, $3, $4, $5, $6, $7) ON CONFLICT (id) DO NOTHING",
                a.id.ToString(), kind == AnnotationTarget::kNode ? target.c_str() : nullptr,
                kind == AnnotationTarget::kEdge ? target.c_str() : nullptr,
                kind == AnnotationTarget::kNone ? parent.c_str() : nullptr, a.type,
                pqxx::binarystring(a.payload),
                kind == AnnotationTarget::kDatum ? datum.c_str() : nullptr)
               .affected_rows() == 1;
  }

  std::vector<Annotation> ReadAnnotations(const std::string& what, const std::string& sql,
                                          const std::string& key) {
    return session_.Autocommit(what, [&](pqxx::transaction_base& t) {
      std::vector<Annotation> annotations;
      for (const pqxx::row& row : t.exec_params(sql, key)) {
        annotations.push_back(ReadAnnotation(row));
      }
      return annotations;
    });
  }

  PgSession& session_;
};

}  // namespace

std::unique_ptr<AnnotationStore> NewPostgresAnnotationStore(PgSession& session) {
  return std::make_unique<PostgresAnnotationStore>(session);
}

}  // namespace fleetmap::internal
