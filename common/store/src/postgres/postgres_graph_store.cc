// PostgreSQL backend of GraphStore (seed 000 §5.2: the central, multi-user choice), through
// libpqxx 6.
//
// - Individual calls are one prepared statement each, in autocommit (pqxx::nontransaction),
//   so an individual write costs one round trip like a plain libpqxx loop.
// - Batches stream every table through COPY into session-local staging tables, then move the
//   rows with one INSERT ... SELECT per table. The staging step is what lets a COPY-speed
//   load still give the GraphStore contract: identical duplicates are no-ops, conflicting
//   ones and dangling edges are reported by UUID, and the batch is atomic.
// - libpqxx exceptions stop here (PgSession::Translate) and become fleetmap::Error with the
//   statement's context.
// - The connection lives in a PgSession shared with this store's VersionStore
//   (postgres_version_store.cc), so both see the same explicit Transaction.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <optional>
#include <pqxx/pqxx>
#include <string>
#include <type_traits>
#include <vector>

#include "backends.h"
#include "edge_covariance_blob.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/annotation_store.h"
#include "fleetmap/store/sensor_index.h"
#include "fleetmap/store/version_store.h"
#include "migration.h"
#include "postgres/element_rows.h"
#include "postgres/pg_session.h"
#include "postgres/postgres_annotation_store.h"
#include "postgres/postgres_sensor_index.h"
#include "postgres/postgres_store_health.h"
#include "postgres/postgres_version_store.h"

namespace fleetmap::internal {

namespace {

// Any constant will do; it only has to be the same in every fleetmap binary.
constexpr long long kMigrationLockKey = 0x666c6565746d6170LL;  // "fleetmap"

std::string NullableUuidText(const Uuid& id) {
  return id.IsNil() ? std::string() : id.ToString();
}

// bytea in COPY text format: "\x" + hex. (stream_to escapes the backslash for COPY.) The same
// text is bytea's input form for a parameter.
std::string ByteaHex(std::string_view bytes) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(2 + 2 * bytes.size());
  out += "\\x";
  for (unsigned char c : bytes) {
    out += kHex[c >> 4];
    out += kHex[c & 0xf];
  }
  return out;
}

// An edge's covariance column as text (ByteaHex of edge_covariance_blob.h's bytes), empty for
// none.
std::string CovarianceText(const Edge& edge) {
  return edge.covariance ? ByteaHex(EncodeCovarianceBlob(*edge.covariance)) : std::string();
}

class PostgresGraphStore final : public GraphStore {
 public:
  PostgresGraphStore(const std::string& uri, const StoreOptions& options) : session_(uri) {
    // Setup steps: run again on a connection that replaces this one (pg_session.h).
    session_.AddConnectionSetup("connect", [this, options] {
      pqxx::nontransaction t(session_.connection());
      // Seed 000 §6.1: synchronous waits for the WAL flush at every commit; buffered lets
      // commits return before it (a server crash may lose the last ones, never corrupts).
      t.exec(options.durability == Durability::kSynchronous ? "SET synchronous_commit = on"
                                                            : "SET synchronous_commit = off");
      t.exec("SET client_min_messages = warning");
      // As SQLite's busy timeout: a writer blocked by another's lock gives up after this long
      // (Error(kBackend)) instead of waiting for ever; callers retry what is transient.
      t.exec("SET lock_timeout = " +
             std::to_string(std::max<std::int64_t>(0, options.busy_timeout_ms)));
    });
    // Read-only first: a database this binary refuses must be left exactly as it was, so the
    // schema table is neither created nor migrated before the recorded version is checked.
    const bool create = options.create_if_missing && !options.read_only;
    const std::optional<int> found = RecordedSchemaVersion();
    const int latest = static_cast<int>(PostgresMigrations().size());
    if (!found && !create) {
      throw Error(ErrorCode::kNotFound,
                  session_.uri() +
                      " is not a fleetmap map store (a database without a fleetmap_schema "
                      "table)");
    }
    if (options.read_only && *found != latest) {
      throw Error(ErrorCode::kInvalidArgument,
                  session_.uri() + " has schema version " + std::to_string(*found) +
                      ", older than this fleetmap's " + std::to_string(latest) +
                      ", and a read-only open does not migrate: open it once read-write (any "
                      "fleetmap command that writes to it) and retry");
    }
    if (!options.read_only) Migrate();
    session_.AddConnectionSetup("prepare", [this] { Prepare(); });
    versions_ = NewPostgresVersionStore(session_);
    sensors_ = NewPostgresSensorIndex(session_);
    annotations_ = NewPostgresAnnotationStore(session_);
    health_ = NewPostgresStoreHealth(session_);
    if (options.read_only) {
      // Only now: the session-local staging tables above are created with CREATE TEMP TABLE,
      // which a read-only transaction refuses (they change nothing of the database's own).
      session_.AddConnectionSetup("connect read-only", [this] {
        pqxx::nontransaction t(session_.connection());
        t.exec("SET default_transaction_read_only = on");
      });
    }
  }

  std::string uri() const override { return session_.uri(); }

  VersionStore& versions() override { return *versions_; }
  SensorIndex& sensors() override { return *sensors_; }
  AnnotationStore& annotations() override { return *annotations_; }
  StoreHealth& health() override { return *health_; }

  int schema_version() override {
    return session_.Autocommit("schema version", [&](pqxx::transaction_base& t) {
      return CheckedSchemaVersion(session_.uri(), SchemaRows(t),
                                  static_cast<int>(PostgresMigrations().size()));
    });
  }

 protected:
  void DoBegin() override { session_.Begin(); }
  void DoCommit() override { session_.Commit(); }
  void DoRollback() override { session_.Rollback(); }

  void DoPutNode(const Node& node) override {
    const int inserted =
        session_.Autocommit("put node " + node.id.ToString(), [&](pqxx::transaction_base& t) {
          return t
              .exec_prepared("insert_node", node.id.ToString(), node.stamp_ns,
                             node.robot.ToString(), node.outing.ToString(),
                             pqxx::binarystring(node.landmarks_blob))
              .affected_rows();
        });
    if (inserted == 1) return;
    const std::optional<Node> stored = DoFindNode(node.id);
    if (stored && *stored == node) return;
    throw Error(ErrorCode::kConflict,
                "node " + node.id.ToString() + " is already stored with different content");
  }

  void DoPutEdge(const Edge& edge) override {
    const Eigen::Quaterniond q = RotationQuaternion(edge.from_T_to);
    const Eigen::Vector3d& t = edge.from_T_to.translation();
    int inserted = 0;
    try {
      inserted =
          session_.Autocommit("put edge " + edge.id.ToString(), [&](pqxx::transaction_base& txn) {
            return txn
                .exec_prepared("insert_edge", edge.id.ToString(), edge.from.ToString(),
                               edge.to.ToString(), static_cast<int>(edge.kind), Text(t.x()),
                               Text(t.y()), Text(t.z()), Text(q.w()), Text(q.x()), Text(q.y()),
                               Text(q.z()), NullableUuidText(edge.path), CovarianceText(edge))
                .affected_rows();
          });
    } catch (const Error& e) {
      // Outside a transaction we can ask which reference is missing; inside one the
      // transaction is aborted and the server's message (which names the key) has to do.
      if (e.code() == ErrorCode::kIntegrity && !session_.transaction()) {
        if (auto missing = MissingReference(edge)) throw Error(ErrorCode::kIntegrity, *missing);
      }
      throw;
    }
    if (inserted == 1) return;
    const std::optional<Edge> stored = DoFindEdge(edge.id);
    if (stored && SameEdgeContent(*stored, edge)) return;
    throw Error(ErrorCode::kConflict,
                "edge " + edge.id.ToString() + " is already stored with different content");
  }

  void DoPutPath(const Path& path) override {
    const int inserted =
        session_.Autocommit("put path " + path.id.ToString(), [&](pqxx::transaction_base& t) {
          return t
              .exec_prepared("insert_path", path.id.ToString(), path.robot.ToString(),
                             path.outing.ToString(), path.start_ns, path.end_ns)
              .affected_rows();
        });
    if (inserted == 1) return;
    const std::optional<Path> stored = DoFindPath(path.id);
    if (stored && *stored == path) return;
    throw Error(ErrorCode::kConflict,
                "path " + path.id.ToString() + " is already stored with different content");
  }

  void DoPutAnnotation(const Annotation& a) override {
    int inserted = 0;
    const std::string datum = std::to_string(a.data_id);
    try {
      inserted =
          session_.Autocommit("put annotation " + a.id.ToString(), [&](pqxx::transaction_base& t) {
            return t
                .exec_prepared(
                    "insert_annotation", a.id.ToString(),
                    NullableUuidText(a.target_kind == AnnotationTarget::kNode ? a.target : Uuid()),
                    NullableUuidText(a.target_kind == AnnotationTarget::kEdge ? a.target : Uuid()),
                    NullableUuidText(a.parent), a.type, pqxx::binarystring(a.payload),
                    a.target_kind == AnnotationTarget::kDatum ? datum.c_str() : nullptr)
                .affected_rows();
          });
    } catch (const Error& e) {
      if (e.code() == ErrorCode::kIntegrity && !session_.transaction()) {
        if (auto missing = MissingReference(a)) throw Error(ErrorCode::kIntegrity, *missing);
      }
      throw;
    }
    if (inserted == 1) return;
    const std::optional<Annotation> stored = DoFindAnnotation(a.id);
    if (stored && *stored == a) return;
    throw Error(ErrorCode::kConflict,
                "annotation " + a.id.ToString() + " is already stored with different content");
  }

  void DoPut(const GraphBatch& batch) override {
    session_.Translate("batch put", [&] {
      if (pqxx::work* txn = session_.transaction()) {
        // Inside an explicit transaction a savepoint keeps the batch atomic on its own.
        pqxx::subtransaction sub(*txn, "fleetmap_batch");
        PutBatch(sub, batch);
        sub.commit();
      } else {
        pqxx::work work(session_.connection());
        PutBatch(work, batch);
        work.commit();
        RefreshStatisticsAfter(batch);
      }
    });
  }

  void DoErase(std::span<const Uuid> nodes, std::span<const Uuid> edges,
               std::span<const Uuid> paths) override {
    // Edges first: the foreign keys refuse a node or path an edge still names, and the
    // transaction (or savepoint) undoes the whole call.
    session_.Atomically("erase elements", [&](pqxx::transaction_base& t) {
      for (const Uuid& id : edges) t.exec_params("DELETE FROM edges WHERE id = $1", id.ToString());
      for (const Uuid& id : nodes) t.exec_params("DELETE FROM nodes WHERE id = $1", id.ToString());
      for (const Uuid& id : paths) t.exec_params("DELETE FROM paths WHERE id = $1", id.ToString());
    });
  }

  std::optional<Node> DoFindNode(const Uuid& id) override {
    return session_.Autocommit("find node", [&](pqxx::transaction_base& t) -> std::optional<Node> {
      const pqxx::result r = t.exec_prepared("find_node", id.ToString());
      if (r.empty()) return std::nullopt;
      return ReadNode(r[0], true);
    });
  }

  bool DoNodeStored(const Uuid& id) override {
    return session_.Autocommit("find node", [&](pqxx::transaction_base& t) {
      return !t.exec_prepared("node_stored", id.ToString()).empty();
    });
  }

  std::optional<Edge> DoFindEdge(const Uuid& id) override {
    return session_.Autocommit("find edge", [&](pqxx::transaction_base& t) -> std::optional<Edge> {
      const pqxx::result r = t.exec_prepared("find_edge", id.ToString());
      if (r.empty()) return std::nullopt;
      return ReadEdge(r[0], 0);
    });
  }

  std::optional<Path> DoFindPath(const Uuid& id) override {
    return session_.Autocommit("find path", [&](pqxx::transaction_base& t) -> std::optional<Path> {
      const pqxx::result r = t.exec_prepared("find_path", id.ToString());
      if (r.empty()) return std::nullopt;
      return ReadPath(r[0]);
    });
  }

  std::optional<Annotation> DoFindAnnotation(const Uuid& id) override {
    return session_.Autocommit(
        "find annotation", [&](pqxx::transaction_base& t) -> std::optional<Annotation> {
          const pqxx::result r = t.exec_prepared("find_annotation", id.ToString());
          if (r.empty()) return std::nullopt;
          return ReadAnnotation(r[0]);
        });
  }

  std::vector<Node> DoGetNodes(std::span<const Uuid> ids) override {
    return session_.Autocommit("get nodes", [&](pqxx::transaction_base& t) {
      std::vector<Node> nodes;
      for (const pqxx::row& row : t.exec_prepared("get_nodes", UuidArray(ids))) {
        nodes.push_back(ReadNode(row, true));
      }
      return nodes;
    });
  }

  std::vector<Edge> DoEdgesFrom(const Uuid& node) override {
    return ReadEdges("edges_from", node.ToString());
  }
  std::vector<Edge> DoEdgesTo(const Uuid& node) override {
    return ReadEdges("edges_to", node.ToString());
  }
  std::vector<Edge> DoEdgesTouching(std::span<const Uuid> nodes,
                                    std::optional<EdgeKind> kind) override {
    if (!kind) return ReadEdges("edges_touching", UuidArray(nodes));
    return session_.Autocommit("edges_touching_of_kind", [&](pqxx::transaction_base& t) {
      std::vector<Edge> edges;
      for (const pqxx::row& row :
           t.exec_prepared("edges_touching_of_kind", UuidArray(nodes), static_cast<int>(*kind))) {
        edges.push_back(ReadEdge(row, 0));
      }
      return edges;
    });
  }
  std::vector<Edge> DoEdgesOfPath(const Uuid& path) override {
    return ReadEdges("edges_of_path", path.ToString());
  }

  std::vector<Annotation> DoAnnotationsOn(AnnotationTarget kind, const Uuid& target) override {
    return ReadAnnotations(
        kind == AnnotationTarget::kNode ? "annotations_on_node" : "annotations_on_edge", target);
  }
  std::vector<Annotation> DoChildAnnotations(const Uuid& parent) override {
    return ReadAnnotations("annotations_of_parent", parent);
  }

  bool DoDatumStored(std::int64_t data_id) override {
    return session_.Autocommit("find datum", [&](pqxx::transaction_base& t) {
      return !t.exec_params("SELECT 1 FROM data WHERE data_id = $1", data_id).empty();
    });
  }

  Subgraph DoReadChainUnordered(const Uuid& start) override {
    return session_.Autocommit("read chain", [&](pqxx::transaction_base& t) {
      Subgraph result;
      const pqxx::result rows = t.exec_prepared("read_chain", start.ToString());
      result.nodes.reserve(rows.size());
      Uuid last;
      for (const pqxx::row& row : rows) {
        // Rows come grouped by node (ORDER BY), one per outgoing metric edge.
        const Uuid id = UuidField(row[0]);
        if (result.nodes.empty() || id != last) result.nodes.push_back(ReadNode(row, true));
        last = id;
        if (!row[5].is_null()) result.edges.push_back(ReadEdge(row, 5));
      }
      return result;
    });
  }

  std::vector<Node> DoListNodes(const NodeFilter& f) override {
    // A NULL parameter disables its condition; unnamed statements are planned with the
    // actual values, so the planner folds those conditions away and uses the indexes.
    const std::string sql =
        Cat({"SELECT id, stamp_ns, robot, outing, ", f.with_landmarks ? "landmarks" : "NULL",
             " FROM nodes WHERE ($1::uuid IS NULL OR robot = $1::uuid)"
             " AND ($2::uuid IS NULL OR outing = $2::uuid)"
             " AND ($3::bigint IS NULL OR stamp_ns >= $3::bigint)"
             " AND ($4::bigint IS NULL OR stamp_ns < $4::bigint) ORDER BY stamp_ns, id"});
    const std::string robot = f.robot ? f.robot->ToString() : "";
    const std::string outing = f.outing ? f.outing->ToString() : "";
    const std::string from = f.from_ns ? std::to_string(*f.from_ns) : "";
    const std::string to = f.to_ns ? std::to_string(*f.to_ns) : "";
    return session_.Autocommit("list nodes", [&](pqxx::transaction_base& t) {
      std::vector<Node> nodes;
      const pqxx::result rows =
          t.exec_params(sql, f.robot ? robot.c_str() : nullptr, f.outing ? outing.c_str() : nullptr,
                        f.from_ns ? from.c_str() : nullptr, f.to_ns ? to.c_str() : nullptr);
      for (const pqxx::row& row : rows) nodes.push_back(ReadNode(row, f.with_landmarks));
      return nodes;
    });
  }

  std::vector<Path> DoListPaths(const PathFilter& f) override {
    const std::string robot = f.robot ? f.robot->ToString() : "";
    const std::string outing = f.outing ? f.outing->ToString() : "";
    return session_.Autocommit("list paths", [&](pqxx::transaction_base& t) {
      std::vector<Path> paths;
      const pqxx::result rows = t.exec_params(
          "SELECT id, robot, outing, start_ns, end_ns FROM paths"
          " WHERE ($1::uuid IS NULL OR robot = $1::uuid)"
          " AND ($2::uuid IS NULL OR outing = $2::uuid) ORDER BY start_ns, id",
          f.robot ? robot.c_str() : nullptr, f.outing ? outing.c_str() : nullptr);
      for (const pqxx::row& row : rows) paths.push_back(ReadPath(row));
      return paths;
    });
  }

  StoreStats DoStats() override {
    return session_.Autocommit("stats", [&](pqxx::transaction_base& t) {
      const pqxx::row r = t.exec(
          "SELECT (SELECT count(*) FROM nodes), (SELECT count(*) FROM edges),"
          " (SELECT count(*) FROM paths), (SELECT count(*) FROM annotations),"
          " (SELECT coalesce(sum(octet_length(landmarks)), 0) FROM nodes),"
          " (SELECT coalesce(sum(octet_length(payload)), 0) FROM annotations)")[0];
      return StoreStats{r[0].as<std::int64_t>(), r[1].as<std::int64_t>(), r[2].as<std::int64_t>(),
                        r[3].as<std::int64_t>(), r[4].as<std::int64_t>(), r[5].as<std::int64_t>()};
    });
  }

 private:
  // The rows of fleetmap_schema, each as text (NULL as nullopt), for CheckedSchemaVersion:
  // as text, because a newer or damaged store may hold a bigint, or anything, there.
  static std::vector<std::optional<std::string>> SchemaRows(pqxx::transaction_base& t) {
    std::vector<std::optional<std::string>> rows;
    for (const pqxx::row& row : t.exec("SELECT version::text FROM fleetmap_schema")) {
      rows.push_back(row[0].is_null() ? std::nullopt : std::optional(row[0].as<std::string>()));
    }
    return rows;
  }

  // The checked schema version (CheckedSchemaVersion), or nullopt when the database has no
  // fleetmap_schema table. Only reads.
  std::optional<int> RecordedSchemaVersion() {
    return session_.Translate("read the schema version of " + session_.uri(), [&] {
      pqxx::read_transaction t(session_.connection());
      std::optional<int> version;
      if (t.exec("SELECT to_regclass('fleetmap_schema') IS NOT NULL")[0][0].as<bool>()) {
        version = CheckedSchemaVersion(session_.uri(), SchemaRows(t),
                                       static_cast<int>(PostgresMigrations().size()));
      }
      t.commit();
      return version;
    });
  }

  void Migrate() {
    session_.Translate("migrate " + session_.uri(), [&] {
      pqxx::work t(session_.connection());
      // Two servers opening a fresh database at once migrate one after the other.
      t.exec("SELECT pg_advisory_xact_lock(" + std::to_string(kMigrationLockKey) + ")");
      t.exec("CREATE TABLE IF NOT EXISTS fleetmap_schema (version integer NOT NULL)");
      // Again under the lock: another server may have migrated since the read-only check. A
      // refusal here rolls the transaction back, table and all.
      const auto& migrations = PostgresMigrations();
      const int current =
          CheckedSchemaVersion(session_.uri(), SchemaRows(t), static_cast<int>(migrations.size()));
      for (const Migration& m : migrations) {
        if (m.version <= current) continue;
        t.exec(m.sql, m.name);
        t.exec("DELETE FROM fleetmap_schema");
        t.exec("INSERT INTO fleetmap_schema (version) VALUES (" + std::to_string(m.version) + ")");
      }
      t.commit();
    });
  }

  void Prepare() {
    pqxx::connection& c = session_.connection();
    c.prepare("insert_node",
              "INSERT INTO nodes (id, stamp_ns, robot, outing, landmarks)"
              " VALUES ($1, $2, $3, $4, $5) ON CONFLICT (id) DO NOTHING");
    c.prepare("insert_edge",
              Cat({"INSERT INTO edges (", kEdgeColumns,
                   ") VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, NULLIF($12, '')::uuid,"
                   " NULLIF($13, '')::bytea) ON CONFLICT (id) DO NOTHING"}));
    c.prepare("insert_path",
              "INSERT INTO paths (id, robot, outing, start_ns, end_ns)"
              " VALUES ($1, $2, $3, $4, $5) ON CONFLICT (id) DO NOTHING");
    c.prepare("insert_annotation",
              "INSERT INTO annotations (id, node_id, edge_id, parent_id, type, payload, data_id)"
              " VALUES ($1, NULLIF($2, '')::uuid, NULLIF($3, '')::uuid, NULLIF($4, '')::uuid,"
              " $5, $6, $7) ON CONFLICT (id) DO NOTHING");
    c.prepare("find_node", Cat({"SELECT ", kNodeColumns, " FROM nodes WHERE id = $1"}));
    c.prepare("node_stored", "SELECT 1 FROM nodes WHERE id = $1");
    c.prepare("find_edge", Cat({"SELECT ", kEdgeColumns, " FROM edges WHERE id = $1"}));
    c.prepare("find_path", "SELECT id, robot, outing, start_ns, end_ns FROM paths WHERE id = $1");
    c.prepare("find_annotation",
              Cat({"SELECT ", kAnnotationColumns, " FROM annotations WHERE id = $1"}));
    c.prepare("get_nodes",
              Cat({"SELECT ", kNodeColumns, " FROM nodes WHERE id = ANY($1::uuid[])"}));
    c.prepare("edges_from",
              Cat({"SELECT ", kEdgeColumns, " FROM edges WHERE from_id = $1 ORDER BY id"}));
    c.prepare("edges_to",
              Cat({"SELECT ", kEdgeColumns, " FROM edges WHERE to_id = $1 ORDER BY id"}));
    c.prepare("edges_touching",
              Cat({"SELECT ", kEdgeColumns,
                   " FROM edges WHERE from_id = ANY($1::uuid[]) OR to_id = ANY($1::uuid[])"
                   " ORDER BY id"}));
    c.prepare("edges_touching_of_kind",
              Cat({"SELECT ", kEdgeColumns,
                   " FROM edges WHERE (from_id = ANY($1::uuid[]) OR to_id = ANY($1::uuid[]))"
                   " AND kind = $2 ORDER BY id"}));
    c.prepare("edges_of_path", Cat({"SELECT ", kEdgeColumnsOfE,
                                    " FROM edges e JOIN nodes n ON n.id = e.to_id"
                                    " WHERE e.path_id = $1 ORDER BY n.stamp_ns, e.id"}));
    c.prepare("annotations_on_node", Cat({"SELECT ", kAnnotationColumns,
                                          " FROM annotations WHERE node_id = $1 ORDER BY id"}));
    c.prepare("annotations_on_edge", Cat({"SELECT ", kAnnotationColumns,
                                          " FROM annotations WHERE edge_id = $1 ORDER BY id"}));
    c.prepare("annotations_of_parent", Cat({"SELECT ", kAnnotationColumns,
                                            " FROM annotations WHERE parent_id = $1 ORDER BY id"}));
    // UNION (not UNION ALL) drops rows seen before, so a cycle ends the recursion.
    c.prepare("read_chain",
              Cat({"WITH RECURSIVE chain (id) AS (SELECT $1::uuid UNION SELECT e.to_id FROM edges e"
                   " JOIN chain c ON e.from_id = c.id WHERE e.kind = 1)"
                   " SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks, ",
                   kEdgeColumnsOfE,
                   " FROM chain JOIN nodes n ON n.id = chain.id"
                   " LEFT JOIN edges e ON e.from_id = chain.id AND e.kind = 1 ORDER BY n.id"}));
    // Session-local staging tables for batches (see the file comment).
    pqxx::nontransaction t(c);
    for (const char* table : {"nodes", "edges", "paths", "annotations"}) {
      t.exec(Cat({"CREATE TEMP TABLE IF NOT EXISTS stage_", table, " (LIKE ", table,
                  ") ON COMMIT DELETE ROWS"}));
    }
  }

  // Fails the batch with Error(kind, message(row)) if the check query returns a row.
  template <typename Message>
  static void Refuse(pqxx::transaction_base& t, ErrorCode kind, const std::string& sql,
                     Message&& message) {
    const pqxx::result r = t.exec(sql);
    if (!r.empty()) throw Error(kind, message(r[0]));
  }

  void PutBatch(pqxx::transaction_base& t, const GraphBatch& batch) {
    // A subtransaction's staging rows survive until the outer commit: start clean.
    t.exec(
        "DELETE FROM stage_paths; DELETE FROM stage_nodes; DELETE FROM stage_edges;"
        " DELETE FROM stage_annotations");
    if (!batch.paths.empty()) PutPaths(t, batch.paths);
    if (!batch.nodes.empty()) PutNodes(t, batch.nodes);
    if (!batch.edges.empty()) PutEdges(t, batch.edges);
    if (!batch.annotations.empty()) PutAnnotations(t, batch.annotations);
  }

  // Each kind of a batch: streamed into its staging table, checked against what is stored,
  // inserted where new; an element stored with other content, or a reference to what is not
  // stored, fails the batch.
  static void PutPaths(pqxx::transaction_base& t, const std::vector<Path>& paths) {
    {
      pqxx::stream_to s(t, "stage_paths",
                        std::vector<std::string>{"id", "robot", "outing", "start_ns", "end_ns"});
      for (const Path& p : paths) {
        s << std::make_tuple(p.id.ToString(), p.robot.ToString(), p.outing.ToString(), p.start_ns,
                             p.end_ns);
      }
      s.complete();
    }
    t.exec("INSERT INTO paths SELECT * FROM stage_paths ON CONFLICT (id) DO NOTHING");
    Refuse(t, ErrorCode::kConflict,
           "SELECT s.id FROM stage_paths s JOIN paths p ON p.id = s.id WHERE"
           " (p.robot, p.outing, p.start_ns, p.end_ns) IS DISTINCT FROM"
           " (s.robot, s.outing, s.start_ns, s.end_ns) LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"path ", r[0].c_str(), " is already stored with different content"});
           });
  }

  static void PutNodes(pqxx::transaction_base& t, const std::vector<Node>& nodes) {
    {
      pqxx::stream_to s(t, "stage_nodes",
                        std::vector<std::string>{"id", "stamp_ns", "robot", "outing", "landmarks"});
      for (const Node& n : nodes) {
        s << std::make_tuple(n.id.ToString(), n.stamp_ns, n.robot.ToString(), n.outing.ToString(),
                             ByteaHex(n.landmarks_blob));
      }
      s.complete();
    }
    t.exec("INSERT INTO nodes SELECT * FROM stage_nodes ON CONFLICT (id) DO NOTHING");
    Refuse(t, ErrorCode::kConflict,
           "SELECT s.id FROM stage_nodes s JOIN nodes n ON n.id = s.id WHERE"
           " (n.stamp_ns, n.robot, n.outing, n.landmarks) IS DISTINCT FROM"
           " (s.stamp_ns, s.robot, s.outing, s.landmarks) LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"node ", r[0].c_str(), " is already stored with different content"});
           });
  }

  static void PutEdges(pqxx::transaction_base& t, const std::vector<Edge>& edges) {
    {
      pqxx::stream_to s(t, "stage_edges",
                        std::vector<std::string>{"id", "from_id", "to_id", "kind", "tx", "ty", "tz",
                                                 "qw", "qx", "qy", "qz", "path_id", "covariance"});
      for (const Edge& e : edges) {
        const Eigen::Quaterniond q = RotationQuaternion(e.from_T_to);
        const Eigen::Vector3d& p = e.from_T_to.translation();
        const std::string path = e.path.ToString();
        const std::string covariance = CovarianceText(e);
        s << std::make_tuple(e.id.ToString(), e.from.ToString(), e.to.ToString(),
                             static_cast<int>(e.kind), Text(p.x()), Text(p.y()), Text(p.z()),
                             Text(q.w()), Text(q.x()), Text(q.y()), Text(q.z()),
                             e.path.IsNil() ? nullptr : path.c_str(),
                             e.covariance ? covariance.c_str() : nullptr);
      }
      s.complete();
    }
    // Name the first missing reference before the foreign keys fail without a UUID.
    for (const auto& [column, table, what] :
         {std::tuple{"from_id", "nodes", "from-node"}, std::tuple{"to_id", "nodes", "to-node"},
          std::tuple{"path_id", "paths", "path"}}) {
      Refuse(t, ErrorCode::kIntegrity,
             Cat({"SELECT s.id, s.", column, " FROM stage_edges s LEFT JOIN ", table,
                  " x ON x.id = s.", column, " WHERE s.", column, " IS NOT NULL AND x.id IS NULL",
                  " LIMIT 1"}),
             [&](const pqxx::row& r) {
               return Cat({"edge ", r[0].c_str(), " refused: ", what, " ", r[1].c_str(),
                           " is not stored"});
             });
    }
    t.exec("INSERT INTO edges SELECT * FROM stage_edges ON CONFLICT (id) DO NOTHING");
    // Poses within 1e-9 count as equal, as SameEdgeContent does for single edges.
    Refuse(t, ErrorCode::kConflict,
           "SELECT s.id FROM stage_edges s JOIN edges e ON e.id = s.id WHERE"
           " (e.from_id, e.to_id, e.kind, e.path_id) IS DISTINCT FROM"
           " (s.from_id, s.to_id, s.kind, s.path_id) OR abs(e.tx - s.tx) > 1e-9 OR"
           " abs(e.ty - s.ty) > 1e-9 OR abs(e.tz - s.tz) > 1e-9 OR abs(e.qw - s.qw) > 1e-9 OR"
           " abs(e.qx - s.qx) > 1e-9 OR abs(e.qy - s.qy) > 1e-9 OR abs(e.qz - s.qz) > 1e-9"
           " OR (e.covariance IS NULL) <> (s.covariance IS NULL) LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"edge ", r[0].c_str(), " is already stored with different content"});
           });
    RefuseDifferentCovariances(t);
  }

  static void PutAnnotations(pqxx::transaction_base& t,
                             const std::vector<Annotation>& annotations) {
    {
      pqxx::stream_to s(t, "stage_annotations",
                        std::vector<std::string>{"id", "node_id", "edge_id", "parent_id", "type",
                                                 "payload", "data_id"});
      for (const Annotation& a : annotations) {
        const std::string target = a.target.ToString(), parent = a.parent.ToString();
        const char* node = a.target_kind == AnnotationTarget::kNode ? target.c_str() : nullptr;
        const char* edge = a.target_kind == AnnotationTarget::kEdge ? target.c_str() : nullptr;
        const std::string datum = std::to_string(a.data_id);
        s << std::make_tuple(a.id.ToString(), node, edge,
                             a.parent.IsNil() ? nullptr : parent.c_str(), a.type,
                             ByteaHex(a.payload),
                             a.target_kind == AnnotationTarget::kDatum ? datum.c_str() : nullptr);
      }
      s.complete();
    }
    for (const auto& [column, table, what] :
         {std::tuple{"node_id", "nodes", "node"}, std::tuple{"edge_id", "edges", "edge"}}) {
      Refuse(t, ErrorCode::kIntegrity,
             Cat({"SELECT s.id, s.", column, " FROM stage_annotations s LEFT JOIN ", table,
                  " x ON x.id = s.", column, " WHERE s.", column, " IS NOT NULL AND x.id IS NULL",
                  " LIMIT 1"}),
             [&](const pqxx::row& r) {
               return Cat({"annotation ", r[0].c_str(), " refused: ", what, " ", r[1].c_str(),
                           " is not stored"});
             });
    }
    Refuse(t, ErrorCode::kIntegrity,
           "SELECT s.id, s.data_id FROM stage_annotations s WHERE s.data_id IS NOT NULL"
           " AND NOT EXISTS (SELECT 1 FROM data d WHERE d.data_id = s.data_id) LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"annotation ", r[0].c_str(), " refused: datum ", r[1].c_str(),
                         " is not in the sensor index"});
           });
    Refuse(t, ErrorCode::kIntegrity,
           "SELECT s.id, s.parent_id FROM stage_annotations s WHERE s.parent_id IS NOT NULL"
           " AND NOT EXISTS (SELECT 1 FROM annotations a WHERE a.id = s.parent_id)"
           " AND NOT EXISTS (SELECT 1 FROM stage_annotations b WHERE b.id = s.parent_id)"
           " LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"annotation ", r[0].c_str(), " refused: parent annotation ", r[1].c_str(),
                         " is not stored"});
           });
    t.exec("INSERT INTO annotations SELECT * FROM stage_annotations ON CONFLICT (id) DO NOTHING");
    Refuse(t, ErrorCode::kConflict,
           "SELECT s.id FROM stage_annotations s JOIN annotations a ON a.id = s.id WHERE"
           " (a.node_id, a.edge_id, a.parent_id, a.type, a.payload, a.data_id) IS DISTINCT FROM"
           " (s.node_id, s.edge_id, s.parent_id, s.type, s.payload, s.data_id) LIMIT 1",
           [](const pqxx::row& r) {
             return Cat({"annotation ", r[0].c_str(), " is already stored with different content"});
           });
  }

  // Stored and staged covariances whose bytes differ are judged as SameEdgeContent judges them
  // (equal within a relative 1e-6), which SQL cannot do for a matrix. Only an edge put again
  // with other numbers gets here.
  static void RefuseDifferentCovariances(pqxx::transaction_base& t) {
    const pqxx::result rows = t.exec(
        "SELECT s.id, e.covariance, s.covariance FROM stage_edges s JOIN edges e ON e.id = s.id"
        " WHERE e.covariance <> s.covariance");
    for (const pqxx::row& r : rows) {
      const Uuid id = UuidField(r[0]);
      Edge stored, staged;  // alike but for their covariances
      stored.covariance = DecodeCovarianceBlob(BytesField(r[1]), id);
      staged.covariance = DecodeCovarianceBlob(BytesField(r[2]), id);
      if (!SameEdgeContent(stored, staged)) {
        throw Error(ErrorCode::kConflict,
                    "edge " + id.ToString() + " is already stored with different content");
      }
    }
  }

  // A bulk load leaves the planner without statistics until autovacuum gets round to it;
  // meanwhile the recursive ReadChain query plans a sequential scan of edges per step and goes
  // quadratic (6.6 s instead of 31 ms for a 10^4 chain). So a batch that grew a table by more
  // than a tenth of its analysed size (and by at least 1000 rows) analyses what it touched.
  void RefreshStatisticsAfter(const GraphBatch& batch) {
    constexpr double kMinRows = 1000, kGrowth = 0.1;
    pqxx::nontransaction t(session_.connection());
    std::string tables;
    for (const auto& [table, rows] :
         {std::pair{"nodes", batch.nodes.size()}, std::pair{"edges", batch.edges.size()}}) {
      if (static_cast<double>(rows) < kMinRows) continue;
      const double analysed =
          t.exec_params1("SELECT reltuples FROM pg_class WHERE oid = $1::regclass", table)[0]
              .as<double>();
      if (analysed < 0 || static_cast<double>(rows) > kGrowth * analysed) {
        tables += tables.empty() ? table : std::string(", ") + table;
      }
    }
    if (!tables.empty()) t.exec("ANALYZE " + tables);
  }

  std::vector<Edge> ReadEdges(const char* statement, const std::string& key) {
    return session_.Autocommit(statement, [&](pqxx::transaction_base& t) {
      std::vector<Edge> edges;
      for (const pqxx::row& row : t.exec_prepared(statement, key))
        edges.push_back(ReadEdge(row, 0));
      return edges;
    });
  }

  std::vector<Annotation> ReadAnnotations(const char* statement, const Uuid& key) {
    return session_.Autocommit(statement, [&](pqxx::transaction_base& t) {
      std::vector<Annotation> annotations;
      for (const pqxx::row& row : t.exec_prepared(statement, key.ToString())) {
        annotations.push_back(ReadAnnotation(row));
      }
      return annotations;
    });
  }

  PgSession session_;
  std::unique_ptr<VersionStore> versions_;        // shares session_, so declared after it
  std::unique_ptr<SensorIndex> sensors_;          // shares session_, so declared after it
  std::unique_ptr<AnnotationStore> annotations_;  // shares session_, so declared after it
  std::unique_ptr<StoreHealth> health_;           // shares session_, so declared after it
};

}  // namespace

std::unique_ptr<GraphStore> OpenPostgresGraphStore(const std::string& uri,
                                                   const StoreOptions& options) {
  return std::make_unique<PostgresGraphStore>(uri, options);
}

std::string RedactPassword(const std::string& uri) {
  // scheme://user:password@host...  ->  scheme://user@host...
  std::string out = uri;
  const std::size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const std::size_t start = scheme + 3;
    const std::size_t at = out.find('@', start);
    const std::size_t slash = out.find('/', start);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const std::size_t colon = out.find(':', start);
      if (colon != std::string::npos && colon < at) out.erase(colon, at - colon);
    }
  }
  // ...?password=secret&...  ->  ...?password=***&...
  const std::size_t key = out.find("password=");
  if (key != std::string::npos) {
    const std::size_t value = key + std::string("password=").size();
    const std::size_t end = out.find('&', value);
    out.replace(value, (end == std::string::npos ? out.size() : end) - value, "***");
  }
  return out;
}

}  // namespace fleetmap::internal
