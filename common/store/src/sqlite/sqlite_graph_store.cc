// SQLite backend of GraphStore (seed 000 §5.2: the embedded choice for real-time use).
//
// Every statement is prepared once at open and reused: per-call overhead over a raw
// prepared-statement loop is what seed 000 Figs 6-7 measure, and `fleetmap bench graph`
// holds us to a ratio against exactly that baseline.
#include <sqlite3.h>

#include <algorithm>
#include <filesystem>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <system_error>
#include <type_traits>
#include <unordered_set>
#include <vector>

#include "backends.h"
#include "edge_covariance_blob.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/annotation_store.h"
#include "fleetmap/store/sensor_index.h"
#include "fleetmap/store/version_store.h"
#include "migration.h"
#include "sqlite/element_rows.h"
#include "sqlite/sqlite_annotation_store.h"
#include "sqlite/sqlite_sensor_index.h"
#include "sqlite/sqlite_store_health.h"
#include "sqlite/sqlite_version_store.h"
#include "sqlite/statement.h"

namespace fleetmap::internal {

namespace {

constexpr const char* kNodeColumns = "id, stamp_ns, robot, outing, landmarks";
constexpr const char* kAnnotationColumns =
    "id, node_id, edge_id, parent_id, type, payload, data_id";

constexpr int kChunkRows = 32;
constexpr const char* kNodeInsertColumns = "id, stamp_ns, robot, outing, landmarks";
constexpr const char* kNodeRow = "(?, ?, ?, ?, ?)";
constexpr const char* kEdgeRow = "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)";

// "INSERT INTO table (columns) VALUES row, row, ... ON CONFLICT (id) DO NOTHING".
std::string InsertRowsSql(const char* table, const char* columns, const char* row,
                          int rows = kChunkRows) {
  std::string sql = std::string("INSERT INTO ") + table + " (" + columns + ") VALUES ";
  for (int r = 0; r < rows; ++r) {
    if (r) sql += ", ";
    sql += row;
  }
  return sql + " ON CONFLICT (id) DO NOTHING";
}

// Turns foreign-key enforcement off for the life of the object (see DoPut).
// REQUIRES: no transaction open on db (SQLite ignores the pragma inside one).
class ForeignKeysOff {
 public:
  explicit ForeignKeysOff(sqlite3* db) : db_(db) { ExecSql(db_, "PRAGMA foreign_keys=OFF"); }
  ~ForeignKeysOff() {
    try {
      ExecSql(db_, "PRAGMA foreign_keys=ON");
    } catch (...) {
      // Only fails on a closed connection, which has nothing left to protect.
    }
  }
  ForeignKeysOff(const ForeignKeysOff&) = delete;
  ForeignKeysOff& operator=(const ForeignKeysOff&) = delete;

 private:
  sqlite3* db_;
};

class SqliteGraphStore final : public GraphStore {
 public:
  SqliteGraphStore(const std::string& path, const StoreOptions& options) : path_(path) {
    const bool create = options.create_if_missing && !options.read_only;
    // NOMUTEX: a GraphStore is used by one thread at a time (see graph_store.h), so SQLite's
    // own per-call mutex would be pure overhead.
    const int flags = (options.read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE) |
                      (create ? SQLITE_OPEN_CREATE : 0) | SQLITE_OPEN_NOMUTEX;
    const int rc = sqlite3_open_v2(path.c_str(), &db_, flags, nullptr);
    if (rc != SQLITE_OK) {
      const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
      sqlite3_close(db_);
      db_ = nullptr;
      std::error_code ec;
      if (!create && !std::filesystem::exists(path, ec)) {
        throw Error(ErrorCode::kNotFound, uri() + " is not a fleetmap map store (no such file)");
      }
      throw Error(ErrorCode::kBackend, "cannot open sqlite store " + path + ": " + message);
    }
    try {
      sqlite3_extended_result_codes(db_, 1);
      sqlite3_busy_timeout(db_, static_cast<int>(std::clamp<std::int64_t>(
                                    options.busy_timeout_ms, 0, std::numeric_limits<int>::max())));
      // Read-only first: a store this binary refuses must be left exactly as it was, so nothing
      // below that writes (the journal mode, the schema table, migrations) runs before the
      // recorded version has been read and checked.
      const std::optional<int> found = RecordedSchemaVersion();
      const int latest = static_cast<int>(SqliteMigrations().size());
      if (!found && !create) {
        std::error_code ec;
        const bool empty = std::filesystem::file_size(path, ec) == 0 && !ec;
        throw Error(
            ErrorCode::kNotFound,
            uri() + " is not a fleetmap map store (" +
                (empty ? "empty file" : "an SQLite database without a fleetmap_schema table") +
                ")");
      }
      if (options.read_only && *found != latest) {
        throw Error(ErrorCode::kInvalidArgument,
                    uri() + " has schema version " + std::to_string(*found) +
                        ", older than this fleetmap's " + std::to_string(latest) +
                        ", and a read-only open does not migrate: open it once read-write "
                        "(any fleetmap command that writes to it) and retry");
      }
      if (!options.read_only) {
        // Seed 000 §6.1: both modes use the write-ahead log; synchronous flushes it on every
        // commit, buffered leaves flushing to the OS (safe against a killed process).
        // 8 KiB pages for new stores (a no-op on existing ones): a 10^6-node chain loads
        // 20-30% faster than with 4 KiB pages (fewer page splits, shorter checkpoint).
        ExecSql(db_, "PRAGMA page_size=8192");
        ExecSql(db_, options.durability == Durability::kScratch ? "PRAGMA journal_mode=MEMORY"
                                                                : "PRAGMA journal_mode=WAL");
      }
      ExecSql(db_, options.durability == Durability::kSynchronous ? "PRAGMA synchronous=FULL"
                                                                  : "PRAGMA synchronous=OFF");
      ExecSql(db_, "PRAGMA foreign_keys=ON");
      ExecSql(db_, "PRAGMA cache_size=-32768");  // 32 MiB: bulk loads append at the right edge of
                                                 // each B-tree, so this is plenty
      // A store already at this binary's schema needs no write to open: a server restarting
      // while another writer holds the lock (a long transaction, a backup) starts at once.
      if (!options.read_only && found != latest) Migrate();
      Prepare();
      versions_ = NewSqliteVersionStore(db_);
      sensors_ = NewSqliteSensorIndex(db_);
      annotations_ = NewSqliteAnnotationStore(db_);
      health_ = NewSqliteStoreHealth(db_, path_);
    } catch (...) {
      health_.reset();
      annotations_.reset();
      sensors_.reset();
      versions_.reset();
      statements_.reset();
      sqlite3_close(db_);
      throw;
    }
  }

  ~SqliteGraphStore() override {
    // Prepared statements first: sqlite3_close refuses a connection that still has some.
    health_.reset();
    annotations_.reset();
    sensors_.reset();
    versions_.reset();
    statements_.reset();
    sqlite3_close(db_);
  }

  std::string uri() const override { return "sqlite:" + path_; }

  VersionStore& versions() override { return *versions_; }
  SensorIndex& sensors() override { return *sensors_; }
  AnnotationStore& annotations() override { return *annotations_; }
  StoreHealth& health() override { return *health_; }

  int schema_version() override {
    return CheckedSchemaVersion(uri(), SchemaRows(), static_cast<int>(SqliteMigrations().size()));
  }

 protected:
  void DoBegin() override { ExecSql(db_, "BEGIN IMMEDIATE"); }
  void DoCommit() override { ExecSql(db_, "COMMIT"); }
  void DoRollback() override {
    if (!sqlite3_get_autocommit(db_)) ExecSql(db_, "ROLLBACK");
  }

  void DoPutNode(const Node& node) override {
    {
      StatementUse s(statements_->insert_node);
      BindNodeRow(*s, 0, node);
      if (s->Run() == 1) return;
    }
    RequireSameAsStored(node);
  }

  void DoPutEdge(const Edge& edge) override {
    try {
      StatementUse s(statements_->insert_edge);
      BindEdgeRow(*s, 0, edge);
      if (s->Run() == 1) return;
    } catch (const Error& e) {
      ThrowWithMissingReference(e, std::span<const Edge>(&edge, 1));
    }
    RequireSameAsStored(edge);
  }

  void DoPutPath(const Path& path) override {
    {
      StatementUse s(statements_->insert_path);
      s->Bind(1, path.id);
      s->Bind(2, path.robot);
      s->Bind(3, path.outing);
      s->Bind(4, path.start_ns);
      s->Bind(5, path.end_ns);
      if (s->Run() == 1) return;
    }
    const std::optional<Path> stored = DoFindPath(path.id);
    if (stored && *stored == path) return;
    throw Error(ErrorCode::kConflict,
                "path " + path.id.ToString() + " is already stored with different content");
  }

  void DoPutAnnotation(const Annotation& a) override {
    try {
      // Bound without a copy, so these must live until Run().
      const Uuid node_id = a.target_kind == AnnotationTarget::kNode ? a.target : Uuid();
      const Uuid edge_id = a.target_kind == AnnotationTarget::kEdge ? a.target : Uuid();
      StatementUse s(statements_->insert_annotation);
      s->Bind(1, a.id);
      s->BindNullableUuid(2, node_id);
      s->BindNullableUuid(3, edge_id);
      s->BindNullableUuid(4, a.parent);
      s->BindText(5, a.type);
      s->BindBlob(6, a.payload);
      if (a.target_kind == AnnotationTarget::kDatum) s->Bind(7, a.data_id);
      if (s->Run() == 1) return;
    } catch (const Error& e) {
      if (e.code() == ErrorCode::kIntegrity) {
        if (auto missing = MissingReference(a)) throw Error(ErrorCode::kIntegrity, *missing);
      }
      throw;
    }
    const std::optional<Annotation> stored = DoFindAnnotation(a.id);
    if (stored && *stored == a) return;
    throw Error(ErrorCode::kConflict,
                "annotation " + a.id.ToString() + " is already stored with different content");
  }

  void DoPut(const GraphBatch& batch) override {
    // Inside an explicit transaction a savepoint keeps the batch atomic on its own.
    const bool nested = in_transaction();
    // A batch of its own checks its references set-wise instead of through SQLite's per-row
    // foreign-key lookups (a third of the instructions of a chain load). It holds the write
    // lock (BEGIN IMMEDIATE) from the check to the commit, and nothing deletes nodes, so the
    // check stays true; every other write keeps the declared foreign keys enforced. The pragma
    // only changes outside a transaction, hence not for nested batches.
    std::optional<ForeignKeysOff> foreign_keys_off;
    if (!nested) foreign_keys_off.emplace(db_);
    ExecSql(db_, nested ? "SAVEPOINT fleetmap_batch" : "BEGIN IMMEDIATE");
    try {
      if (!nested) {
        if (auto missing = MissingReferenceInBatch(batch)) {
          throw Error(ErrorCode::kIntegrity, *missing);
        }
      }
      for (const Path& p : batch.paths) DoPutPath(p);
      PutRows<Node>(batch.nodes, statements_->insert_nodes_chunk);
      PutRows<Edge>(batch.edges, statements_->insert_edges_chunk);
      for (const Annotation& a : batch.annotations) DoPutAnnotation(a);
      ExecSql(db_, nested ? "RELEASE fleetmap_batch" : "COMMIT");
    } catch (...) {
      if (nested) {
        ExecSql(db_, "ROLLBACK TO fleetmap_batch");
        ExecSql(db_, "RELEASE fleetmap_batch");
      } else if (!sqlite3_get_autocommit(db_)) {
        ExecSql(db_, "ROLLBACK");
      }
      throw;
    }
  }

  void DoErase(std::span<const Uuid> nodes, std::span<const Uuid> edges,
               std::span<const Uuid> paths) override {
    // Edges first: the foreign keys (on outside DoPut's own batches) refuse a node or path an
    // edge still names, and the savepoint or transaction undoes the whole call.
    const bool nested = in_transaction();
    ExecSql(db_, nested ? "SAVEPOINT fleetmap_erase" : "BEGIN IMMEDIATE");
    try {
      const auto erase = [&](const char* sql, std::span<const Uuid> ids) {
        Statement statement(db_, sql);
        for (const Uuid& id : ids) {
          statement.Bind(1, id);
          statement.Run();
          statement.Reset();
        }
      };
      erase("DELETE FROM edges WHERE id = ?1", edges);
      erase("DELETE FROM nodes WHERE id = ?1", nodes);
      erase("DELETE FROM paths WHERE id = ?1", paths);
      ExecSql(db_, nested ? "RELEASE fleetmap_erase" : "COMMIT");
    } catch (...) {
      if (nested) {
        ExecSql(db_, "ROLLBACK TO fleetmap_erase");
        ExecSql(db_, "RELEASE fleetmap_erase");
      } else if (!sqlite3_get_autocommit(db_)) {
        ExecSql(db_, "ROLLBACK");
      }
      throw;
    }
  }

  std::optional<Node> DoFindNode(const Uuid& id) override {
    StatementUse s(statements_->find_node);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadNode(*s, true);
  }

  bool DoNodeStored(const Uuid& id) override {
    StatementUse s(statements_->node_stored);
    s->Bind(1, id);
    return s->Step();
  }

  std::optional<Edge> DoFindEdge(const Uuid& id) override {
    StatementUse s(statements_->find_edge);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadEdge(*s, 0);
  }

  std::optional<Path> DoFindPath(const Uuid& id) override {
    StatementUse s(statements_->find_path);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadPath(*s);
  }

  std::optional<Annotation> DoFindAnnotation(const Uuid& id) override {
    StatementUse s(statements_->find_annotation);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadAnnotation(*s);
  }

  std::vector<Node> DoGetNodes(std::span<const Uuid> ids) override {
    // In-process lookups are as cheap as one big query here: no round trip to save.
    return InOneRead([&] {
      std::vector<Node> nodes;
      nodes.reserve(ids.size());
      for (const Uuid& id : ids) {
        if (std::optional<Node> n = DoFindNode(id)) nodes.push_back(std::move(*n));
      }
      return nodes;
    });
  }

  std::vector<Edge> DoEdgesFrom(const Uuid& node) override {
    return ReadEdges(statements_->edges_from, node);
  }
  std::vector<Edge> DoEdgesTo(const Uuid& node) override {
    return ReadEdges(statements_->edges_to, node);
  }

  std::vector<Edge> DoEdgesTouching(std::span<const Uuid> nodes,
                                    std::optional<EdgeKind> kind) override {
    return InOneRead([&] {
      std::vector<Edge> edges;
      std::unordered_set<Uuid> seen;
      const auto add = [&](std::vector<Edge> read) {
        for (Edge& e : read) {
          if (seen.insert(e.id).second) edges.push_back(std::move(e));
        }
      };
      for (const Uuid& n : nodes) {
        if (kind) {
          add(ReadEdgesOfKind(statements_->edges_from_of_kind, n, *kind));
          add(ReadEdgesOfKind(statements_->edges_to_of_kind, n, *kind));
        } else {
          add(ReadEdges(statements_->edges_from, n));
          add(ReadEdges(statements_->edges_to, n));
        }
      }
      return edges;
    });
  }

  std::vector<Edge> DoEdgesOfPath(const Uuid& path) override {
    return ReadEdges(statements_->edges_of_path, path);
  }

  std::vector<Annotation> DoAnnotationsOn(AnnotationTarget kind, const Uuid& target) override {
    return ReadAnnotations(kind == AnnotationTarget::kNode ? statements_->annotations_on_node
                                                           : statements_->annotations_on_edge,
                           target);
  }

  std::vector<Annotation> DoChildAnnotations(const Uuid& parent) override {
    return ReadAnnotations(statements_->annotations_of_parent, parent);
  }

  bool DoDatumStored(std::int64_t data_id) override {
    Statement s(db_, "SELECT 1 FROM data WHERE data_id = ?1");
    s.Bind(1, data_id);
    return s.Step();
  }

  Subgraph DoReadChainUnordered(const Uuid& start) override {
    // One recursive query: UNION (not UNION ALL) drops a node seen before, so a cycle ends.
    // Each row is a node with one of its outgoing metric edges (NULLs at the chain's end).
    StatementUse s(statements_->read_chain);
    s->Bind(1, start);
    // The CTE yields each node once and the join keeps a node's rows together, so a node is
    // new exactly when its id differs from the previous row's.
    Subgraph result;
    while (s->Step()) {
      if (result.nodes.empty() || s->UuidAt(0) != result.nodes.back().id) {
        result.nodes.push_back(ReadNode(*s, true));
      }
      if (!s->IsNull(5)) result.edges.push_back(ReadEdge(*s, 5));
    }
    return result;
  }

  std::vector<Node> DoListNodes(const NodeFilter& filter) override {
    std::string sql = Sql({"SELECT id, stamp_ns, robot, outing, ",
                           filter.with_landmarks ? "landmarks" : "NULL", " FROM nodes WHERE 1"});
    if (filter.robot) sql += " AND robot = ?1";
    if (filter.outing) sql += " AND outing = ?2";
    if (filter.from_ns) sql += " AND stamp_ns >= ?3";
    if (filter.to_ns) sql += " AND stamp_ns < ?4";
    sql += " ORDER BY stamp_ns, id";
    Statement s(db_, sql.c_str());
    if (filter.robot) s.Bind(1, *filter.robot);
    if (filter.outing) s.Bind(2, *filter.outing);
    if (filter.from_ns) s.Bind(3, *filter.from_ns);
    if (filter.to_ns) s.Bind(4, *filter.to_ns);
    std::vector<Node> nodes;
    while (s.Step()) nodes.push_back(ReadNode(s, filter.with_landmarks));
    return nodes;
  }

  std::vector<Path> DoListPaths(const PathFilter& filter) override {
    std::string sql = "SELECT id, robot, outing, start_ns, end_ns FROM paths WHERE 1";
    if (filter.robot) sql += " AND robot = ?1";
    if (filter.outing) sql += " AND outing = ?2";
    sql += " ORDER BY start_ns, id";
    Statement s(db_, sql.c_str());
    if (filter.robot) s.Bind(1, *filter.robot);
    if (filter.outing) s.Bind(2, *filter.outing);
    std::vector<Path> paths;
    while (s.Step()) paths.push_back(ReadPath(s));
    return paths;
  }

  StoreStats DoStats() override {
    Statement s(db_,
                "SELECT (SELECT count(*) FROM nodes), (SELECT count(*) FROM edges),"
                " (SELECT count(*) FROM paths), (SELECT count(*) FROM annotations),"
                " (SELECT coalesce(sum(length(landmarks)), 0) FROM nodes),"
                " (SELECT coalesce(sum(length(payload)), 0) FROM annotations)");
    s.Step();
    return StoreStats{s.Int64(0), s.Int64(1), s.Int64(2), s.Int64(3), s.Int64(4), s.Int64(5)};
  }

 private:
  // Runs `read`, many statements, in one read transaction (a savepoint, which also nests in a
  // caller's): alone, each statement opens and closes its own, taking the write-ahead log's
  // read lock through fcntl each time, which cost more than the lookups themselves (7 % of a
  // streamed download's CPU; two thirds of listing a 60k-node map's edges node by node).
  template <typename Read>
  std::invoke_result_t<Read> InOneRead(Read read) {
    ExecSql(db_, "SAVEPOINT fleetmap_read");
    try {
      std::invoke_result_t<Read> result = read();
      ExecSql(db_, "RELEASE fleetmap_read");
      return result;
    } catch (...) {
      ExecSql(db_, "ROLLBACK TO fleetmap_read");
      ExecSql(db_, "RELEASE fleetmap_read");
      throw;
    }
  }

  struct Statements {
    explicit Statements(sqlite3* db)
        : insert_node(db, InsertRowsSql("nodes", kNodeInsertColumns, kNodeRow, 1).c_str()),
          insert_edge(db, InsertRowsSql("edges", kEdgeColumns, kEdgeRow, 1).c_str()),
          insert_path(db,
                      "INSERT INTO paths (id, robot, outing, start_ns, end_ns)"
                      " VALUES (?1, ?2, ?3, ?4, ?5) ON CONFLICT (id) DO NOTHING"),
          insert_annotation(db,
                            "INSERT INTO annotations (id, node_id, edge_id, parent_id, type,"
                            " payload, data_id) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)"
                            " ON CONFLICT (id) DO NOTHING"),
          find_node(db, Sql({"SELECT ", kNodeColumns, " FROM nodes WHERE id = ?1"}).c_str()),
          node_stored(db, "SELECT 1 FROM nodes WHERE id = ?1"),
          find_edge(db, Sql({"SELECT ", kEdgeColumns, " FROM edges WHERE id = ?1"}).c_str()),
          find_path(db, "SELECT id, robot, outing, start_ns, end_ns FROM paths WHERE id = ?1"),
          find_annotation(
              db, Sql({"SELECT ", kAnnotationColumns, " FROM annotations WHERE id = ?1"}).c_str()),
          edges_from(db, Sql({"SELECT ", kEdgeColumns,
                              " FROM edges WHERE from_id = ?1"
                              " ORDER BY id"})
                             .c_str()),
          edges_to(
              db,
              Sql({"SELECT ", kEdgeColumns, " FROM edges WHERE to_id = ?1 ORDER BY id"}).c_str()),
          edges_from_of_kind(db, Sql({"SELECT ", kEdgeColumns,
                                      " FROM edges WHERE from_id = ?1 AND kind = ?2 ORDER BY id"})
                                     .c_str()),
          edges_to_of_kind(db, Sql({"SELECT ", kEdgeColumns,
                                    " FROM edges WHERE to_id = ?1 AND kind = ?2 ORDER BY id"})
                                   .c_str()),
          edges_of_path(db, Sql({"SELECT ", kEdgeColumnsOfE,
                                 " FROM edges e JOIN nodes n ON n.id = e.to_id"
                                 " WHERE e.path_id = ?1 ORDER BY n.stamp_ns, e.id"})
                                .c_str()),
          annotations_on_node(db, Sql({"SELECT ", kAnnotationColumns,
                                       " FROM annotations WHERE node_id = ?1 ORDER BY id"})
                                      .c_str()),
          annotations_on_edge(db, Sql({"SELECT ", kAnnotationColumns,
                                       " FROM annotations WHERE edge_id = ?1 ORDER BY id"})
                                      .c_str()),
          annotations_of_parent(db, Sql({"SELECT ", kAnnotationColumns,
                                         " FROM annotations WHERE parent_id = ?1 ORDER BY id"})
                                        .c_str()),
          insert_nodes_chunk(db, InsertRowsSql("nodes", kNodeInsertColumns, kNodeRow).c_str()),
          insert_edges_chunk(db, InsertRowsSql("edges", kEdgeColumns, kEdgeRow).c_str()),
          read_chain(db, Sql({"WITH RECURSIVE chain (id) AS (SELECT ?1 UNION SELECT e.to_id"
                              " FROM edges e JOIN chain c ON e.from_id = c.id WHERE e.kind = 1)"
                              " SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks, ",
                              kEdgeColumnsOfE,
                              " FROM chain JOIN nodes n ON n.id = chain.id"
                              " LEFT JOIN edges e ON e.from_id = chain.id AND e.kind = 1"})
                             .c_str()) {}

    Statement insert_node, insert_edge, insert_path, insert_annotation;
    Statement find_node, node_stored, find_edge, find_path, find_annotation;
    Statement edges_from, edges_to, edges_from_of_kind, edges_to_of_kind, edges_of_path;
    Statement annotations_on_node, annotations_on_edge, annotations_of_parent;
    Statement insert_nodes_chunk, insert_edges_chunk;
    Statement read_chain;
  };

  // Binds one node / edge as parameters first+1 ... of a (possibly multi-row) insert.
  static void BindNodeRow(Statement& s, int first, const Node& node) {
    s.Bind(first + 1, node.id);
    s.Bind(first + 2, node.stamp_ns);
    s.Bind(first + 3, node.robot);
    s.Bind(first + 4, node.outing);
    s.BindBlob(first + 5, node.landmarks_blob);
  }

  static void BindEdgeRow(Statement& s, int first, const Edge& edge) {
    s.Bind(first + 1, edge.id);
    s.Bind(first + 2, edge.from);
    s.Bind(first + 3, edge.to);
    s.Bind(first + 4, static_cast<std::int64_t>(edge.kind));
    const Eigen::Quaterniond q = RotationQuaternion(edge.from_T_to);
    const Eigen::Vector3d& t = edge.from_T_to.translation();
    s.Bind(first + 5, t.x());
    s.Bind(first + 6, t.y());
    s.Bind(first + 7, t.z());
    s.Bind(first + 8, q.w());
    s.Bind(first + 9, q.x());
    s.Bind(first + 10, q.y());
    s.Bind(first + 11, q.z());
    s.BindNullableUuid(first + 12, edge.path);
    if (edge.covariance) {
      s.BindBlobCopy(first + 13, EncodeCovarianceBlob(*edge.covariance));
    } else {
      s.BindNull(first + 13);
    }
  }

  static void BindRow(Statement& s, int first, const Node& node) { BindNodeRow(s, first, node); }
  static void BindRow(Statement& s, int first, const Edge& edge) { BindEdgeRow(s, first, edge); }
  static constexpr int kParams(const Node*) { return 5; }
  static constexpr int kParams(const Edge*) { return 13; }

  // ON CONFLICT DO NOTHING skipped a row: identical content is a no-op, anything else is a
  // conflict.
  void RequireSameAsStored(const Node& node) {
    const std::optional<Node> stored = DoFindNode(node.id);
    if (stored && *stored == node) return;
    throw Error(ErrorCode::kConflict,
                "node " + node.id.ToString() + " is already stored with different content");
  }

  void RequireSameAsStored(const Edge& edge) {
    const std::optional<Edge> stored = DoFindEdge(edge.id);
    if (stored && SameEdgeContent(*stored, edge)) return;
    throw Error(ErrorCode::kConflict,
                "edge " + edge.id.ToString() + " is already stored with different content");
  }

  // A constraint refused one of `edges`: name the missing reference rather than SQLite's bare
  // "FOREIGN KEY constraint failed", or rethrow as is.
  [[noreturn]] void ThrowWithMissingReference(const Error& error, std::span<const Edge> edges) {
    if (error.code() == ErrorCode::kIntegrity) {
      for (const Edge& edge : edges) {
        if (auto missing = MissingReference(edge)) throw Error(ErrorCode::kIntegrity, *missing);
      }
    }
    throw error;
  }
  [[noreturn]] void ThrowWithMissingReference(const Error& error, std::span<const Node>) {
    throw error;
  }

  // Batch rows go kChunkRows to a statement: SQLite opens and closes a cursor per index for
  // every statement it runs, and a 32-row INSERT pays that once instead of 32 times (2.3x
  // fewer instructions per chain element under callgrind). A chunk that inserted fewer rows
  // than it carried had duplicates; only then are its rows compared one by one.
  template <typename Row>
  void PutRows(const std::vector<Row>& rows, Statement& chunk) {
    constexpr int params = kParams(static_cast<const Row*>(nullptr));
    std::size_t i = 0;
    for (; i + kChunkRows <= rows.size(); i += kChunkRows) {
      const std::span<const Row> part(rows.data() + i, kChunkRows);
      int inserted = 0;
      try {
        StatementUse s(chunk);
        for (int r = 0; r < kChunkRows; ++r) BindRow(*s, r * params, part[r]);
        inserted = s->Run();
      } catch (const Error& e) {
        ThrowWithMissingReference(e, part);
      }
      if (inserted != kChunkRows) {
        for (const Row& row : part) RequireSameAsStored(row);
      }
    }
    for (; i < rows.size(); ++i) {
      if constexpr (std::is_same_v<Row, Node>) {
        DoPutNode(rows[i]);
      } else {
        DoPutEdge(rows[i]);
      }
    }
  }

  // The rows of fleetmap_schema, each as text (NULL as nullopt), for CheckedSchemaVersion.
  std::vector<std::optional<std::string>> SchemaRows() {
    Statement s(db_, "SELECT CAST(version AS TEXT) FROM fleetmap_schema");
    std::vector<std::optional<std::string>> rows;
    while (s.Step()) rows.push_back(s.IsNull(0) ? std::nullopt : std::optional(s.Text(0)));
    return rows;
  }

  // The checked schema version (CheckedSchemaVersion), or nullopt when there is no
  // fleetmap_schema table (an empty file, a new store, another program's database). Only
  // reads. A file that is not a database throws Error(kCorrupt) (statement.h).
  std::optional<int> RecordedSchemaVersion() {
    try {
      Statement table(db_,
                      "SELECT count(*) FROM sqlite_master WHERE type = 'table' AND name = "
                      "'fleetmap_schema'");
      table.Step();
      if (table.Int64(0) == 0) return std::nullopt;
    } catch (const Error&) {
      if ((sqlite3_errcode(db_) & 0xff) != SQLITE_NOTADB) throw;
      throw Error(ErrorCode::kCorrupt,
                  uri() + " is not a fleetmap map store (not an SQLite database)");
    }
    return CheckedSchemaVersion(uri(), SchemaRows(), static_cast<int>(SqliteMigrations().size()));
  }

  void Migrate() {
    // IMMEDIATE: two processes opening a new store at once migrate one after the other. The
    // schema table is created inside the transaction, so a refusal below rolls it back too.
    ExecSql(db_, "BEGIN IMMEDIATE");
    try {
      ExecSql(db_, "CREATE TABLE IF NOT EXISTS fleetmap_schema (version INTEGER NOT NULL)");
      // Again under the lock: another process may have migrated since the read-only check.
      const auto& migrations = SqliteMigrations();
      const int current =
          CheckedSchemaVersion(uri(), SchemaRows(), static_cast<int>(migrations.size()));
      for (const Migration& m : migrations) {
        if (m.version <= current) continue;
        ExecSql(db_, m.sql);
        ExecSql(db_, "DELETE FROM fleetmap_schema");
        Statement insert(db_, "INSERT INTO fleetmap_schema (version) VALUES (?1)");
        insert.Bind(1, static_cast<std::int64_t>(m.version));
        insert.Run();
      }
      ExecSql(db_, "COMMIT");
    } catch (...) {
      ExecSql(db_, "ROLLBACK");
      throw;
    }
  }

  void Prepare() { statements_ = std::make_unique<Statements>(db_); }

  std::vector<Edge> ReadEdges(Statement& statement, const Uuid& key) {
    StatementUse s(statement);
    s->Bind(1, key);
    std::vector<Edge> edges;
    while (s->Step()) edges.push_back(ReadEdge(*s, 0));
    return edges;
  }

  std::vector<Edge> ReadEdgesOfKind(Statement& statement, const Uuid& key, EdgeKind kind) {
    StatementUse s(statement);
    s->Bind(1, key);
    s->Bind(2, static_cast<std::int64_t>(kind));
    std::vector<Edge> edges;
    while (s->Step()) edges.push_back(ReadEdge(*s, 0));
    return edges;
  }

  std::vector<Annotation> ReadAnnotations(Statement& statement, const Uuid& key) {
    StatementUse s(statement);
    s->Bind(1, key);
    std::vector<Annotation> annotations;
    while (s->Step()) annotations.push_back(ReadAnnotation(*s));
    return annotations;
  }

  std::string path_;
  sqlite3* db_ = nullptr;
  std::unique_ptr<Statements> statements_;
  std::unique_ptr<VersionStore> versions_;        // on db_, sharing its transactions
  std::unique_ptr<SensorIndex> sensors_;          // on db_, sharing its transactions
  std::unique_ptr<AnnotationStore> annotations_;  // on db_, sharing its transactions
  std::unique_ptr<StoreHealth> health_;           // on db_
};

}  // namespace

std::unique_ptr<GraphStore> OpenSqliteGraphStore(const std::string& path,
                                                 const StoreOptions& options) {
  return std::make_unique<SqliteGraphStore>(path, options);
}

}  // namespace fleetmap::internal
