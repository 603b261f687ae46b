// GraphStore: the experience graph in a relational database (seed 000 §4.3.1 GraphDB,
// §5.2, §6.1). One interface, two backends that pass one conformance suite:
//   sqlite:PATH            embedded; the robot's map and a single-machine server
//   postgresql://...       central, many concurrent writers (libpqxx)
//
// Contract, for every backend:
// - Open applies the numbered forward-only schema migrations and records the version; a
//   database whose version is newer than this binary is refused with Error(kSchemaTooNew).
// - Put* of an element whose UUID is already stored with identical content is a no-op; with
//   different content it throws Error(kConflict) and stores nothing.
// - An edge whose endpoint node (or whose path) is not stored, and an annotation whose
//   target or parent is not stored, are refused with Error(kIntegrity).
// - Get* of an unknown UUID throws Error(kNotFound); Find* returns nullopt.
// - Reads give back what was put, an edge's covariance bit for bit. A stored edge whose pose is
//   not SE(3) or whose covariance is not a valid one (a database changed behind the store's
//   back) reads as Error(kCorrupt) naming the edge.
// - Every write outside a Transaction is atomic by itself; Put(GraphBatch) is atomic as a
//   whole (all of it or none of it, also when the process is killed mid-batch).
// - Any other failure of the database becomes Error(kBackend) with the statement's context.
//
// Threading: a GraphStore is one connection. Use it from one thread at a time; open one per
// thread for concurrency (PostgreSQL serves many; SQLite serialises writers via WAL locks).
#pragma once

#include <cstdint>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"

namespace fleetmap {

class VersionStore;
class SensorIndex;
class AnnotationStore;
class StoreHealth;

// Seed 000 §6.1: synchronous flushes every commit to stable storage (SQLite WAL with
// synchronous=FULL; PostgreSQL synchronous_commit=on). Buffered leaves writes to the OS
// (SQLite synchronous=OFF; PostgreSQL synchronous_commit=off): a killed process loses
// nothing committed, a power cut may lose the last commits but never corrupts the store.
// kSynchronous: every commit is on disk when it returns. kBuffered: commits reach the OS at
// once and the disk when it flushes (safe against a killed process, not a power cut).
// kScratch: a SQLite file that is not live yet and is thrown away if anything fails before
// its owner fsyncs and renames it into place (the agent's map.db.new): a rollback journal in
// memory instead of the write-ahead log, so each page is written once instead of twice, and
// no syncing. PostgreSQL treats it as kBuffered.
enum class Durability { kSynchronous, kBuffered, kScratch };

struct StoreOptions {
  Durability durability = Durability::kSynchronous;
  // How long a statement waits for a lock another writer holds before it fails with
  // Error(kBackend): SQLite's busy timeout, PostgreSQL's lock_timeout.
  std::int64_t busy_timeout_ms = 10'000;
  // false: the store must already be a fleetmap store (its fleetmap_schema table present). A
  // missing SQLite file, an empty one, or a database without the table is refused with
  // Error(kNotFound) ("... is not a fleetmap map store (empty file)") and left as it was,
  // instead of becoming a new, empty, migrated store. For maps that come from elsewhere.
  bool create_if_missing = true;
  // true: open for reading only, never creating or migrating (implies create_if_missing =
  // false). SQLite opens the file with SQLITE_OPEN_READONLY; PostgreSQL sets
  // default_transaction_read_only. A store at an older schema version is refused with
  // Error(kInvalidArgument) (it would need migrating); every write fails with Error(kBackend).
  bool read_only = false;
};

// Which nodes ListNodes returns. Unset fields do not filter; the time window is
// [from_ns, to_ns). Results are ordered by stamp_ns, then id. Robot and outing are indexed
// together with the stamp; a window alone scans the nodes (no index on the stamp by itself:
// it would slow every load, and time-of-day selection works modulo 24 h, which no index on
// the stamp serves).
struct NodeFilter {
  std::optional<Uuid> robot{};
  std::optional<Uuid> outing{};
  std::optional<std::int64_t> from_ns{};
  std::optional<std::int64_t> to_ns{};
  bool with_landmarks = true;  // false leaves landmarks_blob empty (cheaper listings)
};

struct PathFilter {
  std::optional<Uuid> robot{};
  std::optional<Uuid> outing{};
};

// Breadth-first neighbourhood of a node. Edges are followed in both directions. A node is
// included when it is within max_hops edges AND within max_radius_m of summed metric-edge
// translation along the shortest such route. Path edges carry no metric distance; they are
// followed only when follow_path_edges is set (and then count as 0 m).
struct NeighbourhoodQuery {
  Uuid centre{};
  int max_hops = std::numeric_limits<int>::max();
  double max_radius_m = std::numeric_limits<double>::infinity();
  bool follow_path_edges = false;
};

// Counts and payload bytes of what is stored.
struct StoreStats {
  std::int64_t nodes = 0;
  std::int64_t edges = 0;
  std::int64_t paths = 0;
  std::int64_t annotations = 0;
  std::int64_t landmark_bytes = 0;            // sum of node landmark blobs
  std::int64_t annotation_payload_bytes = 0;  // sum of annotation payloads
};

class GraphStore : public GraphReader, public GraphWriter {
 public:
  // Opens (creating if needed, unless options say otherwise) the store named by uri and
  // migrates it to the latest schema. The recorded schema version is checked before anything
  // is written, so a refused store is left byte for byte as it was. Throws
  // Error(kInvalidArgument) for an unknown scheme, Error(kSchemaTooNew) for a version newer
  // than this binary, Error(kCorrupt) for a version that is negative or not a number (or a
  // file that is not a database), Error(kNotFound) for a store that options require to exist,
  // or Error(kBackend) when the database cannot be opened.
  static std::unique_ptr<GraphStore> Open(std::string_view uri, const StoreOptions& options = {});

  // The highest schema version this binary knows (the same number for every backend).
  static int LatestSchemaVersion();

  virtual ~GraphStore();
  GraphStore(const GraphStore&) = delete;
  GraphStore& operator=(const GraphStore&) = delete;

  // The URI the store was opened with, password removed.
  virtual std::string uri() const = 0;
  virtual int schema_version() = 0;

  // RAII transaction: everything written between Begin() and Commit() lands together. The
  // destructor rolls back if Commit() was not reached. After an Error thrown by any call
  // inside it, the transaction can only roll back: Commit() throws Error(kInvalidArgument).
  // REQUIRES: no other Transaction open on this store (no nesting).
  class Transaction {
   public:
    Transaction(Transaction&& other) noexcept;
    Transaction& operator=(Transaction&&) = delete;
    ~Transaction();
    void Commit();
    void Rollback();

   private:
    friend class GraphStore;
    explicit Transaction(GraphStore* store) : store_(store) {}
    GraphStore* store_;
  };
  Transaction Begin();
  bool in_transaction() const { return txn_state_ != TxnState::kNone; }

  // Writes (see the contract above).
  void PutNode(const Node& node);
  void PutEdge(const Edge& edge);
  void PutPath(const Path& path);
  void PutAnnotation(const Annotation& annotation);
  void Put(const GraphBatch& batch) override;
  // Removes elements by UUID, all of them or none (also when the process is killed): for a
  // robot's working map, which an install changes in place. A repository's elements are never
  // removed (revisions hide them): a store with a revision refuses with
  // Error(kInvalidArgument). An edge left on a node or path that goes is refused with
  // Error(kIntegrity). UUIDs not stored are ignored.
  void Erase(std::span<const Uuid> nodes, std::span<const Uuid> edges, std::span<const Uuid> paths);

  // Reads by UUID.
  Node GetNode(const Uuid& id);
  std::optional<Node> FindNode(const Uuid& id);
  Edge GetEdge(const Uuid& id);
  Path GetPath(const Uuid& id);
  Annotation GetAnnotation(const Uuid& id);
  // Batch read in one call; the result follows the order of ids. Throws Error(kNotFound)
  // naming the first missing UUID.
  std::vector<Node> GetNodes(std::span<const Uuid> ids);

  // Edges leaving / entering one node, ordered by edge UUID.
  std::vector<Edge> EdgesFrom(const Uuid& node);
  std::vector<Edge> EdgesTo(const Uuid& node);
  // Every edge with an endpoint in `nodes`, in one round trip, each edge once; with `kind`, only
  // the edges of that kind (a place revisited every day gathers a path edge per visit, which a
  // search along metric edges would otherwise read and drop).
  std::vector<Edge> EdgesTouching(std::span<const Uuid> nodes,
                                  std::optional<EdgeKind> kind = std::nullopt);
  // The edges of one path, ordered by the stamp of their `to` node.
  std::vector<Edge> EdgesOfPath(const Uuid& path);

  // Annotations on a node or an edge, and the children of an annotation; ordered by UUID.
  // Annotations on a datum, typed payloads and compound queries: annotations() below.
  std::vector<Annotation> AnnotationsOn(AnnotationTarget kind, const Uuid& target);
  std::vector<Annotation> ChildAnnotations(const Uuid& parent);

  // The whole chain that starts at `start`, following outgoing metric edges, read in one
  // call (seed 000 Fig. 7, batch). Nodes come in chain order; where a node has several
  // outgoing metric edges the walk takes the lowest edge UUID and the others' targets come
  // after. A cycle ends the walk at the first repeated node. Throws Error(kNotFound) for an
  // unknown start.
  Subgraph ReadChain(const Uuid& start);

  // Breadth-first neighbourhood (seed 000 §7: EBN loads the nodes near the robot), one round
  // trip per BFS level. Nodes come ordered by hops from the centre, the centre first.
  Subgraph Neighbourhood(const NeighbourhoodQuery& query);

  std::vector<Node> ListNodes(const NodeFilter& filter);
  // The whole map the store holds: every node (with landmarks, ordered as ListNodes), every
  // edge touching them and every path; not the annotations. What a robot pushes.
  GraphBatch ReadMap() override;
  std::vector<Path> ListPaths(const PathFilter& filter);
  StoreStats Stats();

  // The versioning tables of this store (version_store.h): submissions, revisions, and which
  // revision added and hid each element. Same connection, so it shares Transactions.
  virtual VersionStore& versions() = 0;

  // The SQL index of raw sensor data (sensor_index.h, seed 000 §4.1): platforms, sensors,
  // mounts and the Data relation. Same connection, so it shares Transactions.
  virtual SensorIndex& sensors() = 0;

  // The annotation layer over this store (annotation_store.h): annotations on data of the
  // sensor index, typed payload tables, compound queries. Same connection and Transactions.
  virtual AnnotationStore& annotations() = 0;

  // What the engine says about the store (store_health.h): size on disk, its own integrity
  // check, references that do not resolve. Same connection; only reads.
  virtual StoreHealth& health() = 0;

 protected:
  GraphStore() = default;

  // Backend primitives. Called with in_transaction() telling whether an explicit
  // Transaction is open (autocommit otherwise). They throw fleetmap::Error only.
  virtual void DoBegin() = 0;
  virtual void DoCommit() = 0;
  virtual void DoRollback() = 0;
  virtual void DoPutNode(const Node& node) = 0;
  virtual void DoPutEdge(const Edge& edge) = 0;
  virtual void DoPutPath(const Path& path) = 0;
  virtual void DoPutAnnotation(const Annotation& annotation) = 0;
  virtual void DoPut(const GraphBatch& batch) = 0;
  virtual void DoErase(std::span<const Uuid> nodes, std::span<const Uuid> edges,
                       std::span<const Uuid> paths) = 0;
  virtual std::optional<Node> DoFindNode(const Uuid& id) = 0;
  // Whether a node with this id is stored, read off the id index alone: a reference check
  // must not read the node's landmarks (kilobytes each, 2 per edge checked).
  virtual bool DoNodeStored(const Uuid& id) = 0;
  virtual std::optional<Edge> DoFindEdge(const Uuid& id) = 0;
  virtual std::optional<Path> DoFindPath(const Uuid& id) = 0;
  virtual std::optional<Annotation> DoFindAnnotation(const Uuid& id) = 0;
  // Returns the stored nodes among ids, in any order (missing ones simply absent).
  virtual std::vector<Node> DoGetNodes(std::span<const Uuid> ids) = 0;
  virtual std::vector<Edge> DoEdgesFrom(const Uuid& node) = 0;
  virtual std::vector<Edge> DoEdgesTo(const Uuid& node) = 0;
  virtual std::vector<Edge> DoEdgesTouching(std::span<const Uuid> nodes,
                                            std::optional<EdgeKind> kind) = 0;
  virtual std::vector<Edge> DoEdgesOfPath(const Uuid& path) = 0;
  virtual std::vector<Annotation> DoAnnotationsOn(AnnotationTarget kind, const Uuid& target) = 0;
  virtual std::vector<Annotation> DoChildAnnotations(const Uuid& parent) = 0;
  // Whether the sensor index holds the datum (for annotations on a datum).
  virtual bool DoDatumStored(std::int64_t data_id) = 0;
  // Nodes reachable from start over outgoing metric edges (start included) and the metric
  // edges among them, in any order; one query.
  virtual Subgraph DoReadChainUnordered(const Uuid& start) = 0;
  virtual std::vector<Node> DoListNodes(const NodeFilter& filter) = 0;
  virtual std::vector<Path> DoListPaths(const PathFilter& filter) = 0;
  virtual StoreStats DoStats() = 0;

  // For a backend whose constraint refused an edge or an annotation: a message naming the
  // reference that is not stored, or nullopt when all exist (the backend's own message then
  // stands). REQUIRES: the connection can still run queries.
  std::optional<std::string> MissingReference(const Edge& edge);
  std::optional<std::string> MissingReference(const Annotation& annotation);
  // The first reference of a batch (edge endpoints and paths, annotation targets and parents)
  // that is neither in the batch itself nor stored, as a message; nullopt when all resolve.
  // For backends that check a bulk load set-wise instead of row by row.
  std::optional<std::string> MissingReferenceInBatch(const GraphBatch& batch);

 private:
  enum class TxnState { kNone, kOpen, kFailed };
  // Runs a primitive; an Error inside an explicit transaction marks it failed.
  template <typename Fn>
  auto Guarded(Fn&& fn) -> decltype(fn());

  TxnState txn_state_ = TxnState::kNone;
};

}  // namespace fleetmap
