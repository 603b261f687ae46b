// Raw baselines: see raw_baseline.h. Written the way one would without GraphStore: prepared
// statements, no validation, no conflict checks, values materialised into the same Node and
// Edge types our API returns (so both sides pay for building the result).
#include "raw_baseline.h"

#include <sqlite3.h>

#include <Eigen/Geometry>
#include <pqxx/pqxx>
#include <string_view>
#include <unordered_map>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"
#include "raw_sqlite_connection.h"

namespace fleetmap::bench {

namespace {

// Seed 000 Fig. 7 right: the same recursive query GraphStore's backends run, so the batch
// read compares our ordering and materialisation against the minimal client.
constexpr const char* kSqliteReadChain =
    "WITH RECURSIVE chain (id) AS (SELECT ?1 UNION SELECT e.to_id FROM edges e"
    " JOIN chain c ON e.from_id = c.id WHERE e.kind = 1)"
    " SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks,"
    " e.id, e.from_id, e.to_id, e.kind, e.tx, e.ty, e.tz, e.qw, e.qx, e.qy, e.qz, e.path_id"
    " FROM chain JOIN nodes n ON n.id = chain.id"
    " LEFT JOIN edges e ON e.from_id = chain.id AND e.kind = 1";
constexpr const char* kPostgresReadChain =
    "WITH RECURSIVE chain (id) AS (SELECT $1::uuid UNION SELECT e.to_id FROM edges e"
    " JOIN chain c ON e.from_id = c.id WHERE e.kind = 1)"
    " SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks,"
    " e.id, e.from_id, e.to_id, e.kind, e.tx, e.ty, e.tz, e.qw, e.qx, e.qy, e.qz, e.path_id"
    " FROM chain JOIN nodes n ON n.id = chain.id"
    " LEFT JOIN edges e ON e.from_id = chain.id AND e.kind = 1";

Se3 PoseFromColumns(double tx, double ty, double tz, double qw, double qx, double qy, double qz) {
  Se3 pose = Se3::Identity();
  pose.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  pose.translation() = Eigen::Vector3d(tx, ty, tz);
  return pose;
}

// Orders an unordered chain by walking outgoing edges from start (a linear chain has at most
// one per node). Returns the number of nodes in the walk.
std::size_t WalkChain(const Uuid& start, std::vector<Node>& nodes, const std::vector<Edge>& edges) {
  std::unordered_map<Uuid, std::size_t> node_index;
  node_index.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) node_index.emplace(nodes[i].id, i);
  std::unordered_map<Uuid, const Edge*> next;
  next.reserve(edges.size());
  for (const Edge& e : edges) next.emplace(e.from, &e);
  std::vector<Node> ordered;
  ordered.reserve(nodes.size());
  Uuid current = start;
  while (ordered.size() < nodes.size()) {
    auto node = node_index.find(current);
    if (node == node_index.end()) break;
    ordered.push_back(std::move(nodes[node->second]));
    auto edge = next.find(current);
    if (edge == next.end()) break;
    current = edge->second->to;
  }
  nodes = std::move(ordered);
  return nodes.size();
}

// "postgresql://user:secret@host/db" -> "postgresql://user@host/db" for messages.
std::string Redacted(const std::string& uri) {
  const std::size_t scheme = uri.find("://");
  const std::size_t at = uri.find('@');
  if (scheme == std::string::npos || at == std::string::npos) return uri;
  const std::size_t colon = uri.find(':', scheme + 3);
  if (colon == std::string::npos || colon > at) return uri;
  return uri.substr(0, colon) + uri.substr(at);
}

// --- SQLite ------------------------------------------------------------------------------

class RawSqliteChain final : public ChainWorkload {
 public:
  RawSqliteChain(const std::string& path, Durability durability) : conn_(path, durability) {
    insert_node_ = Prepare(
        "INSERT INTO nodes (id, stamp_ns, robot, outing, landmarks) VALUES (?1, ?2, ?3, ?4, ?5)");
    insert_edge_ = Prepare(
        "INSERT INTO edges (id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz, path_id)"
        " VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)");
    find_node_ = Prepare("SELECT id, stamp_ns, robot, outing, landmarks FROM nodes WHERE id = ?1");
    edges_from_ = Prepare(
        "SELECT id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz, path_id FROM edges"
        " WHERE from_id = ?1 ORDER BY id");
    read_chain_ = Prepare(kSqliteReadChain);
  }

  void CreateIndividual(const GraphBatch& chain) override {
    if (chain.nodes.empty()) return;
    InsertNode(chain.nodes[0]);
    for (std::size_t i = 1; i < chain.nodes.size(); ++i) {
      InsertNode(chain.nodes[i]);
      InsertEdge(chain.edges[i - 1]);
    }
  }

  void CreateBatch(const GraphBatch& chain) override {
    conn_.InTransaction([&] {
      for (const Node& n : chain.nodes) InsertNode(n);
      for (const Edge& e : chain.edges) InsertEdge(e);
    });
  }

  std::size_t ReadIndividual(const Uuid& start) override {
    std::size_t count = 0;
    Uuid current = start;
    std::vector<Edge> edges;
    while (true) {
      sqlite3_stmt* s = find_node_.get();
      BindUuid(s, 1, current);
      if (Step(s) != SQLITE_ROW) {
        sqlite3_reset(s);
        throw Error(ErrorCode::kNotFound, "raw sqlite baseline: no node " + current.ToString());
      }
      const Node node = ReadNode(s, 0);
      sqlite3_reset(s);
      ++count;

      s = edges_from_.get();
      BindUuid(s, 1, node.id);
      edges.clear();
      while (Step(s) == SQLITE_ROW) edges.push_back(ReadEdge(s, 0));
      sqlite3_reset(s);
      if (edges.empty()) return count;
      current = edges.front().to;
    }
  }

  std::size_t ReadBatch(const Uuid& start) override {
    sqlite3_stmt* s = read_chain_.get();
    BindUuid(s, 1, start);
    std::vector<Node> nodes;
    std::vector<Edge> edges;
    while (Step(s) == SQLITE_ROW) {
      // One row per node (and its outgoing metric edge); a node with several edges repeats,
      // which a chain never has.
      nodes.push_back(ReadNode(s, 0));
      if (sqlite3_column_type(s, 5) != SQLITE_NULL) edges.push_back(ReadEdge(s, 5));
    }
    sqlite3_reset(s);
    return WalkChain(start, nodes, edges);
  }

 private:
  SqliteStatement Prepare(const char* sql) { return conn_.Prepare(sql); }
  int Step(sqlite3_stmt* s) { return conn_.Step(s); }
  void Run(sqlite3_stmt* s) { conn_.Run(s); }

  // Bound without a copy: the UUID must outlive the next step.
  static void BindUuid(sqlite3_stmt* s, int index, const Uuid& id) {
    sqlite3_bind_blob(s, index, id.data(), Uuid::kSize, SQLITE_STATIC);
  }

  void InsertNode(const Node& node) {
    sqlite3_stmt* s = insert_node_.get();
    BindUuid(s, 1, node.id);
    sqlite3_bind_int64(s, 2, node.stamp_ns);
    BindUuid(s, 3, node.robot);
    BindUuid(s, 4, node.outing);
    sqlite3_bind_blob64(s, 5, node.landmarks_blob.data(), node.landmarks_blob.size(),
                        SQLITE_STATIC);
    Run(s);
  }

  void InsertEdge(const Edge& edge) {
    sqlite3_stmt* s = insert_edge_.get();
    const Eigen::Quaterniond q(edge.from_T_to.linear());
    const Eigen::Vector3d& t = edge.from_T_to.translation();
    BindUuid(s, 1, edge.id);
    BindUuid(s, 2, edge.from);
    BindUuid(s, 3, edge.to);
    sqlite3_bind_int(s, 4, static_cast<int>(edge.kind));
    sqlite3_bind_double(s, 5, t.x());
    sqlite3_bind_double(s, 6, t.y());
    sqlite3_bind_double(s, 7, t.z());
    sqlite3_bind_double(s, 8, q.w());
    sqlite3_bind_double(s, 9, q.x());
    sqlite3_bind_double(s, 10, q.y());
    sqlite3_bind_double(s, 11, q.z());
    if (edge.path.IsNil()) {
      sqlite3_bind_null(s, 12);
    } else {
      BindUuid(s, 12, edge.path);
    }
    Run(s);
  }

  static Uuid UuidColumn(sqlite3_stmt* s, int column) {
    if (sqlite3_column_type(s, column) == SQLITE_NULL) return Uuid();
    const void* bytes = sqlite3_column_blob(s, column);
    const int size = sqlite3_column_bytes(s, column);
    return Uuid::FromBytes(
        std::string_view(static_cast<const char*>(bytes), static_cast<std::size_t>(size)));
  }

  static Node ReadNode(sqlite3_stmt* s, int first) {
    Node n;
    n.id = UuidColumn(s, first);
    n.stamp_ns = sqlite3_column_int64(s, first + 1);
    n.robot = UuidColumn(s, first + 2);
    n.outing = UuidColumn(s, first + 3);
    const void* blob = sqlite3_column_blob(s, first + 4);
    const int size = sqlite3_column_bytes(s, first + 4);
    if (size > 0)
      n.landmarks_blob.assign(static_cast<const char*>(blob), static_cast<std::size_t>(size));
    return n;
  }

  static Edge ReadEdge(sqlite3_stmt* s, int first) {
    Edge e;
    e.id = UuidColumn(s, first);
    e.from = UuidColumn(s, first + 1);
    e.to = UuidColumn(s, first + 2);
    e.kind = static_cast<EdgeKind>(sqlite3_column_int(s, first + 3));
    double v[7];
    for (int i = 0; i < 7; ++i) v[i] = sqlite3_column_double(s, first + 4 + i);
    e.from_T_to = PoseFromColumns(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    e.path = UuidColumn(s, first + 11);
    return e;
  }

  RawSqliteConnection conn_;  // declared first: closed after the statements are finalized
  SqliteStatement insert_node_, insert_edge_, find_node_, edges_from_, read_chain_;
};

// --- PostgreSQL ---------------------------------------------------------------------------

// Runs fn; libpqxx's exceptions become fleetmap::Error with context.
template <typename Fn>
auto TranslatePqxx(const std::string& context, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const Error&) {
    throw;
  } catch (const pqxx::sql_error& e) {
    throw Error(ErrorCode::kBackend, context + ": " + e.what() + " (statement: " + e.query() + ")");
  } catch (const std::exception& e) {
    throw Error(ErrorCode::kBackend, context + ": " + e.what());
  }
}

Uuid UuidField(const pqxx::field& f) {
  return f.is_null() ? Uuid() : Uuid::Parse(std::string_view(f.c_str(), f.size()));
}

Node NodeFromRow(const pqxx::row& r) {
  Node n;
  n.id = UuidField(r[0]);
  n.stamp_ns = r[1].as<std::int64_t>();
  n.robot = UuidField(r[2]);
  n.outing = UuidField(r[3]);
  n.landmarks_blob = pqxx::binarystring(r[4]).str();
  return n;
}

Edge EdgeFromRow(const pqxx::row& r, pqxx::row::size_type first) {
  Edge e;
  e.id = UuidField(r[first]);
  e.from = UuidField(r[first + 1]);
  e.to = UuidField(r[first + 2]);
  e.kind = static_cast<EdgeKind>(r[first + 3].as<int>());
  e.from_T_to = PoseFromColumns(r[first + 4].as<double>(), r[first + 5].as<double>(),
                                r[first + 6].as<double>(), r[first + 7].as<double>(),
                                r[first + 8].as<double>(), r[first + 9].as<double>(),
                                r[first + 10].as<double>());
  e.path = UuidField(r[first + 11]);
  return e;
}

// COPY's text input of bytea: the hex form "\x0a1b..." (stream_to escapes the backslash).
std::string ByteaHex(const std::string& bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string hex = "\\x";
  hex.reserve(2 + 2 * bytes.size());
  for (unsigned char c : bytes) {
    hex += kDigits[c >> 4];
    hex += kDigits[c & 0xf];
  }
  return hex;
}

class RawPostgresChain final : public ChainWorkload {
 public:
  RawPostgresChain(const std::string& uri, Durability durability)
      : context_("raw postgresql baseline " + Redacted(uri)),
        conn_(TranslatePqxx(context_, [&] { return std::make_unique<pqxx::connection>(uri); })) {
    TranslatePqxx(context_, [&] {
      pqxx::nontransaction session(*conn_);
      session.exec(durability == Durability::kSynchronous ? "SET synchronous_commit = on"
                                                          : "SET synchronous_commit = off");
      conn_->prepare("insert_node",
                     "INSERT INTO nodes (id, stamp_ns, robot, outing, landmarks)"
                     " VALUES ($1, $2, $3, $4, $5)");
      conn_->prepare("insert_edge",
                     "INSERT INTO edges (id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz,"
                     " path_id) VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12)");
      conn_->prepare("find_node",
                     "SELECT id, stamp_ns, robot, outing, landmarks FROM nodes WHERE id = $1");
      conn_->prepare("edges_from",
                     "SELECT id, from_id, to_id, kind, tx, ty, tz, qw, qx, qy, qz, path_id"
                     " FROM edges WHERE from_id = $1 ORDER BY id");
      conn_->prepare("read_chain", kPostgresReadChain);
    });
  }

  void CreateIndividual(const GraphBatch& chain) override {
    TranslatePqxx(context_ + " (individual create)", [&] {
      // Autocommit: every statement is its own transaction, as every GraphStore call.
      pqxx::nontransaction session(*conn_);
      if (chain.nodes.empty()) return;
      InsertNode(session, chain.nodes[0]);
      for (std::size_t i = 1; i < chain.nodes.size(); ++i) {
        InsertNode(session, chain.nodes[i]);
        InsertEdge(session, chain.edges[i - 1]);
      }
    });
  }

  void CreateBatch(const GraphBatch& chain) override {
    TranslatePqxx(context_ + " (batch create)", [&] {
      // The bulk path libpq offers: COPY in one transaction.
      pqxx::work txn(*conn_);
      {
        pqxx::stream_to nodes(
            txn, "nodes",
            std::vector<std::string>{"id", "stamp_ns", "robot", "outing", "landmarks"});
        for (const Node& n : chain.nodes) {
          nodes << std::make_tuple(n.id.ToString(), n.stamp_ns, n.robot.ToString(),
                                   n.outing.ToString(), ByteaHex(n.landmarks_blob));
        }
        nodes.complete();
      }
      {
        pqxx::stream_to edges(txn, "edges",
                              std::vector<std::string>{"id", "from_id", "to_id", "kind", "tx", "ty",
                                                       "tz", "qw", "qx", "qy", "qz", "path_id"});
        for (const Edge& e : chain.edges) {
          // A chain holds metric edges only, so path_id is always NULL.
          const Eigen::Quaterniond q(e.from_T_to.linear());
          const Eigen::Vector3d& t = e.from_T_to.translation();
          edges << std::make_tuple(e.id.ToString(), e.from.ToString(), e.to.ToString(),
                                   static_cast<int>(e.kind), t.x(), t.y(), t.z(), q.w(), q.x(),
                                   q.y(), q.z(), nullptr);
        }
        edges.complete();
      }
      txn.commit();
    });
  }

  std::size_t ReadIndividual(const Uuid& start) override {
    return TranslatePqxx(context_ + " (individual read)", [&] {
      pqxx::nontransaction session(*conn_);
      std::size_t count = 0;
      Uuid current = start;
      std::vector<Edge> edges;
      while (true) {
        const pqxx::result node_rows = session.exec_prepared("find_node", current.ToString());
        if (node_rows.empty()) {
          throw Error(ErrorCode::kNotFound,
                      "raw postgresql baseline: no node " + current.ToString());
        }
        const Node node = NodeFromRow(node_rows[0]);
        ++count;
        const pqxx::result edge_rows = session.exec_prepared("edges_from", node.id.ToString());
        edges.clear();
        for (const pqxx::row& r : edge_rows) edges.push_back(EdgeFromRow(r, 0));
        if (edges.empty()) return count;
        current = edges.front().to;
      }
    });
  }

  std::size_t ReadBatch(const Uuid& start) override {
    return TranslatePqxx(context_ + " (batch read)", [&] {
      pqxx::nontransaction session(*conn_);
      const pqxx::result rows = session.exec_prepared("read_chain", start.ToString());
      std::vector<Node> nodes;
      std::vector<Edge> edges;
      nodes.reserve(rows.size());
      edges.reserve(rows.size());
      for (const pqxx::row& r : rows) {
        nodes.push_back(NodeFromRow(r));
        if (!r[5].is_null()) edges.push_back(EdgeFromRow(r, 5));
      }
      return WalkChain(start, nodes, edges);
    });
  }

 private:
  static void InsertNode(pqxx::transaction_base& t, const Node& n) {
    t.exec_prepared("insert_node", n.id.ToString(), n.stamp_ns, n.robot.ToString(),
                    n.outing.ToString(), pqxx::binarystring(n.landmarks_blob));
  }

  static void InsertEdge(pqxx::transaction_base& t, const Edge& e) {
    const Eigen::Quaterniond q(e.from_T_to.linear());
    const Eigen::Vector3d& t_m = e.from_T_to.translation();
    if (e.path.IsNil()) {
      t.exec_prepared("insert_edge", e.id.ToString(), e.from.ToString(), e.to.ToString(),
                      static_cast<int>(e.kind), t_m.x(), t_m.y(), t_m.z(), q.w(), q.x(), q.y(),
                      q.z(), nullptr);
    } else {
      t.exec_prepared("insert_edge", e.id.ToString(), e.from.ToString(), e.to.ToString(),
                      static_cast<int>(e.kind), t_m.x(), t_m.y(), t_m.z(), q.w(), q.x(), q.y(),
                      q.z(), e.path.ToString());
    }
  }

  std::string context_;
  std::unique_ptr<pqxx::connection> conn_;
};

// Runs one statement outside a transaction (CREATE/DROP DATABASE refuse to run inside one).
void ExecAutocommit(const std::string& uri, const std::string& sql) {
  TranslatePqxx("postgresql " + Redacted(uri) + ": " + sql, [&] {
    pqxx::connection conn(uri);
    pqxx::nontransaction session(conn);
    session.exec(sql);
  });
}

void RequirePlainIdentifier(const std::string& name) {
  const bool plain =
      !name.empty() &&
      name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") == std::string::npos;
  if (!plain) {
    throw Error(ErrorCode::kInvalidArgument, "not a plain database name: '" + name + "'");
  }
}

// The sensor index's bulk ingest written plainly: a file's row inserted when first met (its id
// kept in memory for the whole load), the rows COPYed straight into data, one transaction per
// call. No staging table, no conflict handling, no ids read back: what SensorIndex does beyond
// this is what its ingest costs over COPY.
class RawPostgresIngestImpl final : public RawPostgresIngest {
 public:
  RawPostgresIngestImpl(const std::string& uri, Durability durability)
      : context_("raw postgresql ingest " + Redacted(uri)),
        conn_(TranslatePqxx(context_, [&] { return std::make_unique<pqxx::connection>(uri); })) {
    TranslatePqxx(context_, [&] {
      pqxx::nontransaction session(*conn_);
      session.exec(durability == Durability::kSynchronous ? "SET synchronous_commit = on"
                                                          : "SET synchronous_commit = off");
    });
  }

  void Insert(std::span<const Datum> rows) override {
    TranslatePqxx(context_, [&] {
      pqxx::work txn(*conn_);
      std::vector<std::int64_t> file_ids;
      file_ids.reserve(rows.size());
      for (const Datum& d : rows) file_ids.push_back(FileId(txn, d.file));
      pqxx::stream_to data(txn, "data",
                           std::vector<std::string>{"platform", "sensor", "stamp_ns", "file_id",
                                                    "\"offset\"", "length", "type"});
      for (std::size_t i = 0; i < rows.size(); ++i) {
        const Datum& d = rows[i];
        data << std::make_tuple(d.platform, d.sensor, d.stamp_ns, file_ids[i],
                                static_cast<std::int64_t>(d.offset),
                                static_cast<std::int64_t>(d.length), d.type);
      }
      data.complete();
      txn.commit();
    });
  }

 private:
  std::int64_t FileId(pqxx::work& txn, const std::string& file) {
    auto it = file_ids_.find(file);
    if (it != file_ids_.end()) return it->second;
    const std::int64_t id =
        txn.exec_params1("INSERT INTO files (file) VALUES ($1) RETURNING file_id", file)[0]
            .as<std::int64_t>();
    file_ids_.emplace(file, id);
    return id;
  }

  std::string context_;
  std::unique_ptr<pqxx::connection> conn_;
  std::unordered_map<std::string, std::int64_t> file_ids_;
};

}  // namespace

std::unique_ptr<RawPostgresIngest> OpenRawPostgresIngest(const std::string& uri,
                                                         Durability durability) {
  return std::make_unique<RawPostgresIngestImpl>(uri, durability);
}

std::unique_ptr<ChainWorkload> OpenRawSqliteChain(const std::string& path, Durability durability) {
  return std::make_unique<RawSqliteChain>(path, durability);
}

std::unique_ptr<ChainWorkload> OpenRawPostgresChain(const std::string& uri, Durability durability) {
  return std::make_unique<RawPostgresChain>(uri, durability);
}

void TruncatePostgresGraphTables(const std::string& uri) {
  ExecAutocommit(uri, "TRUNCATE annotations, edges, nodes, paths");
}

void AnalyzePostgresGraphTables(const std::string& uri) {
  ExecAutocommit(uri, "ANALYZE annotations, edges, nodes, paths");
}

// "postgresql://u@h:5432/postgres?x=y" with "db" -> "postgresql://u@h:5432/db?x=y".
std::string UriWithDatabase(const std::string& uri, const std::string& database) {
  const std::size_t authority = uri.find("://");
  if (authority == std::string::npos) {
    throw Error(ErrorCode::kInvalidArgument, "not a postgresql:// URI: " + uri);
  }
  const std::size_t slash = uri.find_first_of("/?", authority + 3);
  if (slash == std::string::npos) return uri + "/" + database;
  if (uri[slash] == '?') return uri.substr(0, slash) + "/" + database + uri.substr(slash);
  const std::size_t query = uri.find('?', slash);
  return uri.substr(0, slash + 1) + database +
         (query == std::string::npos ? std::string() : uri.substr(query));
}

void CreatePostgresDatabase(const std::string& admin_uri, const std::string& name) {
  RequirePlainIdentifier(name);
  ExecAutocommit(admin_uri, "CREATE DATABASE " + name);
}

void DropPostgresDatabase(const std::string& admin_uri, const std::string& name) {
  RequirePlainIdentifier(name);
  // FORCE (PostgreSQL 13+) ends connections a failed run may have left behind.
  ExecAutocommit(admin_uri, "DROP DATABASE IF EXISTS " + name + " WITH (FORCE)");
}

}  // namespace fleetmap::bench
