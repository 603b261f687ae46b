// One conformance suite, run on every GraphStore backend (typed GoogleTest): what
// graph_store.h promises must hold on SQLite and on a real PostgreSQL server alike.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <bit>
#include <chrono>
#include <cstdint>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <type_traits>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "graph_elements.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::PostgresBackend;
using testing::SqliteBackend;
using testing::StoreBackends;

Edge MetricEdge(const Uuid& from, const Uuid& to, double dx = 1.0) {
  Se3 from_T_to = Se3::Identity();
  from_T_to.translation() = Eigen::Vector3d(dx, 0.25, -0.5);
  from_T_to.linear() = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return Edge{Uuid::Generate(), from, to, EdgeKind::kMetric, from_T_to, Uuid()};
}

// A linear chain n0 -> n1 -> ... of metric edges `step_m` long.
GraphBatch Chain(int n, double step_m = 1.0, const Uuid& robot = Uuid::Generate()) {
  GraphBatch batch;
  const Uuid outing = Uuid::Generate();
  for (int i = 0; i < n; ++i) batch.nodes.push_back(MakeNode(robot, outing, 1000 + i));
  for (int i = 0; i + 1 < n; ++i) {
    batch.edges.push_back(MetricEdge(batch.nodes[i].id, batch.nodes[i + 1].id, step_m));
  }
  return batch;
}

// A store's bytes of a covariance, written out here on their own rather than through the
// stores' code: 21 little-endian IEEE doubles, the upper triangle row by row, as upper-case hex.
std::string CovarianceHex(const PoseCovariance& covariance) {
  static constexpr char kHex[] = "0123456789ABCDEF";
  std::string hex;
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) {
      const auto bits = std::bit_cast<std::uint64_t>(covariance(row, column));
      for (int byte = 0; byte < 8; ++byte) {
        hex += kHex[(bits >> (8 * byte + 4)) & 0xf];
        hex += kHex[(bits >> (8 * byte)) & 0xf];
      }
    }
  }
  return hex;
}

// SQL literals of a UUID and of a blob given in hex, in the dialect of `Backend`.
template <typename Backend>
std::string IdLiteral(const Uuid& id) {
  std::string text = id.ToString();
  if constexpr (std::is_same_v<Backend, SqliteBackend>) {
    text.erase(std::remove(text.begin(), text.end(), '-'), text.end());
    return "x'" + text + "'";
  } else {
    return "'" + text + "'";
  }
}
template <typename Backend>
std::string BlobLiteral(const std::string& hex) {
  if constexpr (std::is_same_v<Backend, SqliteBackend>) {
    return "x'" + hex + "'";
  } else {
    return "'\\x" + hex + "'::bytea";
  }
}

// The stored covariance of edge `id` in hex (upper case), empty for NULL.
template <typename Backend>
std::string StoredCovarianceHex(const Backend& backend, const Uuid& id) {
  const char* hex = std::is_same_v<Backend, SqliteBackend> ? "hex(covariance)"
                                                           : "upper(encode(covariance, 'hex'))";
  return backend.QueryText(std::string("SELECT ") + hex +
                           " FROM edges WHERE id = " + IdLiteral<Backend>(id));
}

// `got` carries exactly `want`'s covariance, or none when `want` has none.
void ExpectSameCovariance(const Edge& got, const Edge& want) {
  ASSERT_EQ(got.covariance.has_value(), want.covariance.has_value()) << got.id.ToString();
  if (want.covariance) {
    EXPECT_TRUE(*got.covariance == *want.covariance)
        << "edge " << got.id.ToString() << " read back\n"
        << *got.covariance << "\nnot\n"
        << *want.covariance;
  }
}

template <typename Backend>
class GraphStoreConformance : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    store_ = GraphStore::Open(backend_->Uri());
  }

  std::unique_ptr<GraphStore> Reopen(const StoreOptions& options = {}) {
    store_.reset();
    return GraphStore::Open(backend_->Uri(), options);
  }

  std::optional<Backend> backend_;
  std::unique_ptr<GraphStore> store_;
};

TYPED_TEST_SUITE(GraphStoreConformance, StoreBackends, BackendNames);

// --- Schema and migrations ----------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, OpenMigratesToLatestVersion) {
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_GE(GraphStore::LatestSchemaVersion(), 1);
  EXPECT_EQ(this->store_->Stats().nodes, 0);
}

TYPED_TEST(GraphStoreConformance, ReopenKeepsDataAndVersion) {
  const GraphBatch chain = Chain(5);
  this->store_->Put(chain);
  auto reopened = this->Reopen();
  EXPECT_EQ(reopened->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_EQ(reopened->GetNode(chain.nodes[3].id), chain.nodes[3]);
  EXPECT_EQ(reopened->Stats().edges, 4);
}

TYPED_TEST(GraphStoreConformance, RefusesSchemaNewerThanBinary) {
  this->store_.reset();
  this->backend_->ExecRaw("UPDATE fleetmap_schema SET version = " +
                          std::to_string(GraphStore::LatestSchemaVersion() + 1));
  ExpectError(
      ErrorCode::kSchemaTooNew, [&] { GraphStore::Open(this->backend_->Uri()); },
      "newer than this fleetmap");
}

// 4294967300 is 2^32 + 4: read through a cast to int it was this binary's own version 4, and the
// store opened. It must be refused as newer, and refusing must change nothing: on SQLite the
// store is in rollback-journal mode, as another program may leave it, so switching it to WAL (or
// creating the schema table) before the check would rewrite its bytes.
TYPED_TEST(GraphStoreConformance, RefusesA64BitSchemaVersionAndLeavesTheStoreUnchanged) {
  this->store_->Put(Chain(3));
  this->store_.reset();
  if constexpr (std::is_same_v<TypeParam, SqliteBackend>) {
    this->backend_->ExecRaw(
        "PRAGMA journal_mode=DELETE; UPDATE fleetmap_schema SET version = 4294967300");
  } else {
    this->backend_->ExecRaw(
        "ALTER TABLE fleetmap_schema ALTER COLUMN version TYPE bigint;"
        " UPDATE fleetmap_schema SET version = 4294967300");
  }
  const std::string before = this->backend_->StoredState();
  ExpectError(
      ErrorCode::kSchemaTooNew, [&] { GraphStore::Open(this->backend_->Uri()); },
      "schema version 4294967300");
  EXPECT_TRUE(this->backend_->StoredState() == before) << "refusing the store changed it";
}

TYPED_TEST(GraphStoreConformance, RefusesANegativeOrGarbageSchemaVersionAsCorrupt) {
  this->store_.reset();
  this->backend_->ExecRaw("UPDATE fleetmap_schema SET version = -1");
  ExpectError(
      ErrorCode::kCorrupt, [&] { GraphStore::Open(this->backend_->Uri()); }, "'-1'");
  if constexpr (std::is_same_v<TypeParam, PostgresBackend>) {
    this->backend_->ExecRaw("ALTER TABLE fleetmap_schema ALTER COLUMN version TYPE text");
  }
  this->backend_->ExecRaw("UPDATE fleetmap_schema SET version = 'four'");
  const std::string before = this->backend_->StoredState();
  ExpectError(
      ErrorCode::kCorrupt, [&] { GraphStore::Open(this->backend_->Uri()); }, "'four'");
  EXPECT_TRUE(this->backend_->StoredState() == before) << "refusing the store changed it";
}

// StoreOptions for a store that comes from elsewhere (a robot's map given to `fleetmap push`):
// create_if_missing = false and read_only. What is not a fleetmap store (a missing or empty
// SQLite file, an empty PostgreSQL database) is refused as such and left as it was; a store
// opened read-only reads and refuses every write.
TYPED_TEST(GraphStoreConformance, OpeningOnlyAnExistingStoreRefusesWhatIsNotOne) {
  StoreOptions existing;
  existing.create_if_missing = false;
  StoreOptions read_only;
  read_only.read_only = true;
  TypeParam empty;
  if constexpr (std::is_same_v<TypeParam, SqliteBackend>) {
    ExpectError(
        ErrorCode::kNotFound, [&] { GraphStore::Open(empty.Uri(), existing); }, "no such file");
    std::ofstream(empty.Uri().substr(std::string("sqlite:").size())).close();
  }
  const std::string before = empty.StoredState();
  for (const StoreOptions& options : {existing, read_only}) {
    ExpectError(
        ErrorCode::kNotFound, [&] { GraphStore::Open(empty.Uri(), options); },
        std::is_same_v<TypeParam, SqliteBackend> ? "is not a fleetmap map store (empty file)"
                                                 : "is not a fleetmap map store");
  }
  EXPECT_TRUE(empty.StoredState() == before) << "refusing the store changed it";

  const GraphBatch chain = Chain(4);
  this->store_->Put(chain);
  this->store_.reset();
  {
    auto reader = GraphStore::Open(this->backend_->Uri(), read_only);
    EXPECT_EQ(reader->schema_version(), GraphStore::LatestSchemaVersion());
    EXPECT_EQ(reader->ReadMap().nodes.size(), chain.nodes.size());
    const Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
    ExpectError(ErrorCode::kBackend, [&] { reader->PutNode(node); });
    ExpectError(ErrorCode::kBackend, [&] { reader->Put(Chain(2)); });
  }
  auto writer = GraphStore::Open(this->backend_->Uri(), existing);
  writer->Put(Chain(2));
  EXPECT_EQ(writer->Stats().nodes, 6);
  writer.reset();
  // An older schema would need migrating, which reading only must not do.
  this->backend_->ExecRaw("UPDATE fleetmap_schema SET version = 1");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { GraphStore::Open(this->backend_->Uri(), read_only); },
      "a read-only open does not migrate");
}

// --- Nodes --------------------------------------------------------------------------------

// A robot's working map changed in place (the agent's install): elements go by UUID, all or
// none; a node an edge still hangs from stays; a repository's versioned elements never go.
TYPED_TEST(GraphStoreConformance, EraseRemovesElementsAllOrNone) {
  GraphStore& store = *this->store_;
  const GraphBatch chain = Chain(4);
  store.Put(chain);
  const std::vector<Uuid> last_node = {chain.nodes[3].id};
  const std::vector<Uuid> last_edge = {chain.edges[2].id};
  // The node alone: an edge still names it, so nothing goes.
  ExpectError(ErrorCode::kIntegrity, [&] { store.Erase(last_node, {}, {}); });
  EXPECT_TRUE(store.FindNode(chain.nodes[3].id).has_value());
  // With its edge, both go; an unknown UUID is passed over.
  const std::vector<Uuid> with_unknown = {chain.nodes[3].id, Uuid::Generate()};
  store.Erase(with_unknown, last_edge, {});
  EXPECT_FALSE(store.FindNode(chain.nodes[3].id).has_value());
  EXPECT_EQ(store.Stats().nodes, 3);
  EXPECT_EQ(store.Stats().edges, 2);
  // Inside a transaction that rolls back, nothing goes.
  {
    GraphStore::Transaction transaction = store.Begin();
    const std::vector<Uuid> edges = {chain.edges[0].id, chain.edges[1].id};
    store.Erase({}, edges, {});
    transaction.Rollback();
  }
  EXPECT_EQ(store.Stats().edges, 2);
  // A repository's element (one a revision added) is refused.
  const GraphBatch versioned = Chain(2);
  {
    GraphStore::Transaction transaction = store.Begin();
    Revision merge;
    merge.number = store.versions().HeadRevision() + 1;
    merge.kind = RevisionKind::kMerge;
    merge.author = "test";
    merge.created_ns = 5000;
    merge.submission = Uuid::Generate();
    store.versions().AppendRevision(merge, versioned);
    store.Put(versioned);
    transaction.Commit();
  }
  const std::vector<Uuid> repository_edge = {versioned.edges[0].id};
  ExpectError(ErrorCode::kInvalidArgument, [&] { store.Erase({}, repository_edge, {}); });
  EXPECT_NO_THROW(store.GetEdge(versioned.edges[0].id));
}

TYPED_TEST(GraphStoreConformance, PutGetNode) {
  const Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), -42, std::string("\0\x01\xff", 3));
  this->store_->PutNode(node);
  EXPECT_EQ(this->store_->GetNode(node.id), node);
  EXPECT_EQ(this->store_->FindNode(node.id), node);
}

TYPED_TEST(GraphStoreConformance, UnknownNodeIsNotFound) {
  const Uuid unknown = Uuid::Generate();
  ExpectError(
      ErrorCode::kNotFound, [&] { this->store_->GetNode(unknown); }, unknown.ToString());
  EXPECT_EQ(this->store_->FindNode(unknown), std::nullopt);
  ExpectError(ErrorCode::kNotFound, [&] { this->store_->GetEdge(unknown); });
  ExpectError(ErrorCode::kNotFound, [&] { this->store_->GetPath(unknown); });
  ExpectError(ErrorCode::kNotFound, [&] { this->store_->GetAnnotation(unknown); });
}

TYPED_TEST(GraphStoreConformance, IdenticalNodeTwiceIsNoop) {
  const Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), 7);
  this->store_->PutNode(node);
  this->store_->PutNode(node);
  EXPECT_EQ(this->store_->Stats().nodes, 1);
}

TYPED_TEST(GraphStoreConformance, SameUuidDifferentContentIsConflict) {
  const Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), 7);
  this->store_->PutNode(node);
  Node changed = node;
  changed.landmarks_blob = "other landmarks";
  ExpectError(
      ErrorCode::kConflict, [&] { this->store_->PutNode(changed); }, node.id.ToString());
  EXPECT_EQ(this->store_->GetNode(node.id), node);  // the stored one is untouched
}

TYPED_TEST(GraphStoreConformance, LargeLandmarkBlobRoundTrips) {
  std::string blob(1 << 20, '\0');
  for (std::size_t i = 0; i < blob.size(); ++i) blob[i] = static_cast<char>(i * 31 % 251);
  const Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), 1, blob);
  this->store_->PutNode(node);
  EXPECT_EQ(this->store_->GetNode(node.id).landmarks_blob, blob);
  EXPECT_EQ(this->store_->Stats().landmark_bytes, static_cast<std::int64_t>(blob.size()));
}

// Landmarks of a stereo camera: the store keeps the blob's bytes, so the camera
// comes back with the points, bit for bit, on every read path; a blob of landmarks without one
// beside it comes back without one.
TYPED_TEST(GraphStoreConformance, StereoLandmarksRoundTrip) {
  Landmarks stereo;
  for (int i = 0; i < 50; ++i) {
    stereo.points_camera.emplace_back(0.25f * i - 6.f, 0.1f * i - 2.f, 3.f + 1.5f * i);
    Descriptor256 d{};
    for (std::size_t b = 0; b < d.size(); ++b) d[b] = static_cast<std::uint8_t>(i * 13 + b * 7);
    stereo.descriptors.push_back(d);
  }
  const Eigen::Quaternionf q(
      Eigen::AngleAxisf(0.02f, Eigen::Vector3f(0.3f, 1.f, -0.2f).normalized()));
  stereo.stereo = StereoCamera{.focal_px = 718.856f,
                               .baseline_m = 0.5371657f,
                               .rect_q_camera = {q.w(), q.x(), q.y(), q.z()}};
  Landmarks plain = stereo;
  plain.stereo.reset();
  const Uuid robot = Uuid::Generate(), outing = Uuid::Generate();
  const Node with_camera = MakeNode(robot, outing, 10, EncodeLandmarks(stereo));
  const Node without_camera = MakeNode(robot, outing, 11, EncodeLandmarks(plain));
  GraphBatch batch;
  batch.nodes = {with_camera, without_camera};
  this->store_->Put(batch);

  const auto expect_landmarks = [&](const Node& node) {
    const Landmarks expected = node.id == with_camera.id ? stereo : plain;
    const Landmarks decoded = DecodeLandmarks(node.landmarks_blob);
    EXPECT_EQ(decoded, expected) << node.id.ToString();
    EXPECT_EQ(decoded.stereo, expected.stereo) << node.id.ToString();
  };
  expect_landmarks(this->store_->GetNode(with_camera.id));
  expect_landmarks(this->store_->GetNode(without_camera.id));
  const std::vector<Uuid> ids = {with_camera.id, without_camera.id};
  for (const Node& node : this->store_->GetNodes(ids)) expect_landmarks(node);
  const GraphBatch map = this->Reopen()->ReadMap();
  ASSERT_EQ(map.nodes.size(), 2u);
  for (const Node& node : map.nodes) expect_landmarks(node);
}

TYPED_TEST(GraphStoreConformance, NilNodeIdIsInvalid) {
  Node node = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  node.id = Uuid();
  ExpectError(ErrorCode::kInvalidArgument, [&] { this->store_->PutNode(node); });
}

// --- Edges --------------------------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, MetricEdgeKeepsItsPose) {
  const GraphBatch chain = Chain(2);
  this->store_->Put(chain);
  const Edge stored = this->store_->GetEdge(chain.edges[0].id);
  EXPECT_TRUE(SameEdgeContent(stored, chain.edges[0]));
  EXPECT_TRUE(Se3ApproxEqual(stored.from_T_to, chain.edges[0].from_T_to, 1e-12, 1e-12));
  // Putting back what was read is a no-op, not a conflict.
  this->store_->PutEdge(stored);
  EXPECT_EQ(this->store_->Stats().edges, 1);
}

TYPED_TEST(GraphStoreConformance, PathEdgeNamesItsPath) {
  const GraphBatch chain = Chain(2);
  this->store_->Put(chain);
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 1, 2};
  this->store_->PutPath(path);
  const Edge edge = PathEdge(chain.nodes[0].id, chain.nodes[1].id, path.id);
  this->store_->PutEdge(edge);
  const Edge stored = this->store_->GetEdge(edge.id);
  EXPECT_EQ(stored.kind, EdgeKind::kPath);
  EXPECT_EQ(stored.path, path.id);
}

TYPED_TEST(GraphStoreConformance, EdgeWithMissingFromNodeIsRefused) {
  const Node to = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  this->store_->PutNode(to);
  const Uuid missing = Uuid::Generate();
  ExpectError(
      ErrorCode::kIntegrity, [&] { this->store_->PutEdge(MetricEdge(missing, to.id)); },
      missing.ToString());
  EXPECT_EQ(this->store_->Stats().edges, 0);
}

TYPED_TEST(GraphStoreConformance, EdgeWithMissingToNodeIsRefused) {
  const Node from = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  this->store_->PutNode(from);
  const Uuid missing = Uuid::Generate();
  ExpectError(
      ErrorCode::kIntegrity, [&] { this->store_->PutEdge(MetricEdge(from.id, missing)); },
      missing.ToString());
  EXPECT_EQ(this->store_->Stats().edges, 0);
}

TYPED_TEST(GraphStoreConformance, PathEdgeWithMissingPathIsRefused) {
  const GraphBatch chain = Chain(2);
  this->store_->Put(chain);
  const Uuid missing = Uuid::Generate();
  ExpectError(
      ErrorCode::kIntegrity,
      [&] { this->store_->PutEdge(PathEdge(chain.nodes[0].id, chain.nodes[1].id, missing)); },
      missing.ToString());
}

TYPED_TEST(GraphStoreConformance, EdgeConflictIsRefused) {
  const GraphBatch chain = Chain(3);
  this->store_->Put(chain);
  Edge changed = chain.edges[0];
  changed.to = chain.nodes[2].id;
  ExpectError(ErrorCode::kConflict, [&] { this->store_->PutEdge(changed); });
  Edge moved = chain.edges[0];
  moved.from_T_to.translation().x() += 0.01;
  ExpectError(ErrorCode::kConflict, [&] { this->store_->PutEdge(moved); });
  EXPECT_TRUE(SameEdgeContent(this->store_->GetEdge(chain.edges[0].id), chain.edges[0]));
}

TYPED_TEST(GraphStoreConformance, EdgesFromToAndTouching) {
  GraphBatch g = Chain(4);  // 0 -> 1 -> 2 -> 3
  g.edges.push_back(MetricEdge(g.nodes[0].id, g.nodes[2].id));
  this->store_->Put(g);
  EXPECT_EQ(this->store_->EdgesFrom(g.nodes[0].id).size(), 2u);
  EXPECT_EQ(this->store_->EdgesTo(g.nodes[2].id).size(), 2u);
  EXPECT_TRUE(this->store_->EdgesFrom(g.nodes[3].id).empty());
  const std::vector<Uuid> around{g.nodes[1].id, g.nodes[2].id};
  const std::vector<Edge> touching = this->store_->EdgesTouching(around);
  EXPECT_EQ(touching.size(), 4u);  // 0-1, 1-2, 2-3, 0-2: each once
  const std::vector<Edge> from0 = this->store_->EdgesFrom(g.nodes[0].id);
  EXPECT_LT(from0[0].id, from0[1].id);
}

TYPED_TEST(GraphStoreConformance, EdgesTouchingOfOneKind) {
  GraphBatch g = Chain(4);  // 0 -> 1 -> 2 -> 3, metric
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  g.paths.push_back(path);
  g.edges.push_back(PathEdge(g.nodes[1].id, g.nodes[3].id, path.id));
  g.edges.push_back(PathEdge(g.nodes[0].id, g.nodes[1].id, path.id));
  this->store_->Put(g);
  const std::vector<Uuid> around{g.nodes[1].id};
  EXPECT_EQ(this->store_->EdgesTouching(around).size(), 4u);
  const std::vector<Edge> metric = this->store_->EdgesTouching(around, EdgeKind::kMetric);
  ASSERT_EQ(metric.size(), 2u);  // 0-1 and 1-2
  for (const Edge& edge : metric) {
    EXPECT_EQ(edge.kind, EdgeKind::kMetric);
    EXPECT_TRUE(edge.from == g.nodes[1].id || edge.to == g.nodes[1].id);
  }
  const std::vector<Edge> paths = this->store_->EdgesTouching(around, EdgeKind::kPath);
  ASSERT_EQ(paths.size(), 2u);
  for (const Edge& edge : paths) EXPECT_EQ(edge.path, path.id);
  EXPECT_TRUE(
      this->store_->EdgesTouching(std::vector<Uuid>{g.nodes[2].id}, EdgeKind::kPath).empty());
}

// --- Edge covariances ---------------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, EdgeCovarianceRoundTripsExactlyOnEveryReadPath) {
  // 41 metric edges and a path edge: on SQLite a batch writes 32 in one statement and the rest
  // one by one, so both carry the column. Every other metric edge has a covariance.
  GraphBatch g = Chain(42);
  for (std::size_t i = 0; i < g.edges.size(); i += 2) {
    g.edges[i].covariance = SomeCovariance(1.0 + static_cast<double>(i));
  }
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  g.paths.push_back(path);
  g.edges.push_back(PathEdge(g.nodes[0].id, g.nodes[41].id, path.id));
  this->store_->Put(g);
  // One more, put on its own; it closes the chain into a loop.
  Edge single = MetricEdge(g.nodes[41].id, g.nodes[0].id);
  single.covariance = SomeCovariance(-3.5);
  this->store_->PutEdge(single);

  std::map<Uuid, Edge> want;
  for (const Edge& edge : g.edges) want.emplace(edge.id, edge);
  want.emplace(single.id, single);
  const auto expect_as_put = [&](const std::vector<Edge>& edges, const std::string& how) {
    SCOPED_TRACE(how);
    EXPECT_FALSE(edges.empty());
    for (const Edge& edge : edges) {
      ASSERT_TRUE(want.contains(edge.id)) << edge.id.ToString();
      EXPECT_TRUE(SameEdgeContent(edge, want.at(edge.id)));
      ExpectSameCovariance(edge, want.at(edge.id));
    }
  };
  std::vector<Edge> got;
  for (const auto& [id, edge] : want) got.push_back(this->store_->GetEdge(id));
  expect_as_put(got, "GetEdge");
  expect_as_put(this->store_->EdgesFrom(g.nodes[0].id), "EdgesFrom");
  expect_as_put(this->store_->EdgesTo(g.nodes[0].id), "EdgesTo");
  expect_as_put(this->store_->EdgesTouching(Ids(g.nodes)), "EdgesTouching");
  expect_as_put(this->store_->EdgesOfPath(path.id), "EdgesOfPath");
  const Subgraph chain = this->store_->ReadChain(g.nodes[0].id);
  EXPECT_EQ(chain.edges.size(), 42u);
  expect_as_put(chain.edges, "ReadChain");
  expect_as_put(this->store_->Neighbourhood({.centre = g.nodes[20].id, .max_hops = 3}).edges,
                "Neighbourhood");
  const GraphBatch map = this->store_->ReadMap();
  EXPECT_EQ(map.edges.size(), want.size());
  expect_as_put(map.edges, "ReadMap");

  // Putting back what was read is a no-op, one by one and as a batch.
  for (const Edge& edge : map.edges) this->store_->PutEdge(edge);
  this->store_->Put(map);
  EXPECT_EQ(this->store_->Stats().edges, static_cast<std::int64_t>(want.size()));
  expect_as_put(this->Reopen()->ReadMap().edges, "ReadMap after reopening");
}

TYPED_TEST(GraphStoreConformance, EdgeCovarianceIsPartOfTheEdgesContent) {
  GraphBatch g = Chain(40);  // a batch of it goes through SQLite's many-row statement
  g.edges[3].covariance = SomeCovariance(2.0);
  this->store_->Put(g);
  Edge scaled = g.edges[3];
  scaled.covariance = PoseCovariance(*scaled.covariance * 2.0);
  Edge dropped = g.edges[3];
  dropped.covariance.reset();
  Edge added = g.edges[4];
  added.covariance = SomeCovariance(5.0);
  for (const Edge& changed : {scaled, dropped, added}) {
    ExpectError(
        ErrorCode::kConflict, [&] { this->store_->PutEdge(changed); }, changed.id.ToString());
    GraphBatch again = g;
    for (Edge& edge : again.edges) {
      if (edge.id == changed.id) edge = changed;
    }
    ExpectError(
        ErrorCode::kConflict, [&] { this->store_->Put(again); }, changed.id.ToString());
  }
  // Within SameEdgeContent's tolerance it is the same edge: a no-op that keeps what is stored.
  Edge close = g.edges[3];
  PoseCovariance nudged = *close.covariance;
  nudged(2, 2) *= 1 + 1e-9;
  close.covariance = nudged;
  this->store_->PutEdge(close);
  GraphBatch again = g;
  again.edges[3] = close;
  this->store_->Put(again);
  EXPECT_EQ(this->store_->Stats().edges, 39);
  ExpectSameCovariance(this->store_->GetEdge(g.edges[3].id), g.edges[3]);
  ExpectSameCovariance(this->store_->GetEdge(g.edges[4].id), g.edges[4]);
}

// The column holds the documented bytes; the schema refuses a blob of another length or one on a
// path edge; and what gets past it anyway (another tool, a damaged file) reads back as corrupt,
// naming the edge, never as some other matrix.
TYPED_TEST(GraphStoreConformance, StoredCovarianceIsCheckedWhenRead) {
  GraphBatch g = Chain(3);
  g.edges[0].covariance = SomeCovariance();
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  g.paths.push_back(path);
  g.edges.push_back(PathEdge(g.nodes[0].id, g.nodes[2].id, path.id));
  this->store_->Put(g);
  const Edge& with = g.edges[0];
  const Edge& without = g.edges[1];
  const Edge& path_edge = g.edges[2];
  const TypeParam& backend = *this->backend_;
  EXPECT_EQ(StoredCovarianceHex(backend, with.id), CovarianceHex(*with.covariance));
  EXPECT_EQ(StoredCovarianceHex(backend, without.id), "");

  const std::string valid = CovarianceHex(SomeCovariance(7.0));
  const std::string short_blob = valid.substr(0, 2 * 160);
  const auto set = [&](const Uuid& id, const std::string& hex) {
    return "UPDATE edges SET covariance = " + BlobLiteral<TypeParam>(hex) +
           " WHERE id = " + IdLiteral<TypeParam>(id);
  };
  EXPECT_ANY_THROW(backend.ExecRaw(set(without.id, short_blob)));
  EXPECT_ANY_THROW(backend.ExecRaw(set(path_edge.id, valid)));

  // Negative definite: the right length, but no covariance.
  backend.ExecRaw(set(without.id, CovarianceHex(-SomeCovariance(3.0))));
  ExpectError(
      ErrorCode::kCorrupt, [&] { this->store_->GetEdge(without.id); }, without.id.ToString());
  ExpectError(
      ErrorCode::kCorrupt, [&] { this->store_->EdgesTo(without.to); }, without.id.ToString());
  backend.ExecRaw("UPDATE edges SET covariance = NULL WHERE id = " +
                  IdLiteral<TypeParam>(without.id));

  if constexpr (std::is_same_v<TypeParam, SqliteBackend>) {
    backend.ExecRaw("PRAGMA ignore_check_constraints = ON; " + set(with.id, short_blob));
  } else {
    backend.ExecRaw("ALTER TABLE edges DROP CONSTRAINT edges_covariance_check; " +
                    set(with.id, short_blob));
  }
  ExpectError(
      ErrorCode::kCorrupt, [&] { this->store_->GetEdge(with.id); }, with.id.ToString());
  ExpectError(
      ErrorCode::kCorrupt, [&] { this->store_->ReadChain(with.from); }, "160 bytes");
}

// A store from before covariances (schema 7) reads its edges as before, without one, and takes
// edges with one once migrated.
TYPED_TEST(GraphStoreConformance, SchemaSevenStoreMigratesWithItsEdges) {
  const GraphBatch chain = Chain(4);
  this->store_->Put(chain);
  this->store_.reset();
  this->backend_->ExecRaw(
      "DROP TABLE retirements; DROP TABLE node_usage; ALTER TABLE edges DROP COLUMN covariance;"
      " UPDATE fleetmap_schema SET version = 7");
  this->store_ = GraphStore::Open(this->backend_->Uri());
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  for (const Edge& edge : chain.edges) {
    const Edge stored = this->store_->GetEdge(edge.id);
    EXPECT_TRUE(SameEdgeContent(stored, edge));
    EXPECT_FALSE(stored.covariance.has_value());
  }
  EXPECT_EQ(this->store_->ReadChain(chain.nodes[0].id).edges.size(), 3u);
  Edge with = MetricEdge(chain.nodes[3].id, chain.nodes[0].id);
  with.covariance = SomeCovariance(0.5);
  this->store_->Put(GraphBatch{{}, {}, {with}, {}});
  ExpectSameCovariance(this->store_->GetEdge(with.id), with);
}

// --- Paths --------------------------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, PathsPutGetListAndConflict) {
  const Uuid robot = Uuid::Generate();
  const Path a{Uuid::Generate(), robot, Uuid::Generate(), 10, 20};
  const Path b{Uuid::Generate(), robot, Uuid::Generate(), 30, 40};
  const Path other{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 5, 6};
  this->store_->Put(GraphBatch{{a, b, other}, {}, {}, {}});
  EXPECT_EQ(this->store_->GetPath(a.id), a);
  EXPECT_EQ(Ids(this->store_->ListPaths({.robot = robot})), (std::vector<Uuid>{a.id, b.id}));
  EXPECT_EQ(this->store_->ListPaths({.outing = other.outing}).size(), 1u);
  EXPECT_EQ(this->store_->ListPaths({}).size(), 3u);
  this->store_->PutPath(a);
  Path changed = a;
  changed.end_ns = 99;
  ExpectError(ErrorCode::kConflict, [&] { this->store_->PutPath(changed); });
}

TYPED_TEST(GraphStoreConformance, EdgesOfPathInTimeOrder) {
  const GraphBatch chain = Chain(5);
  this->store_->Put(chain);
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 10};
  this->store_->PutPath(path);
  // Written out of order; read back ordered by the time of the node each edge reaches.
  std::vector<Edge> edges{PathEdge(chain.nodes[3].id, chain.nodes[4].id, path.id),
                          PathEdge(chain.nodes[0].id, chain.nodes[1].id, path.id),
                          PathEdge(chain.nodes[1].id, chain.nodes[3].id, path.id)};
  for (const Edge& e : edges) this->store_->PutEdge(e);
  EXPECT_EQ(Ids(this->store_->EdgesOfPath(path.id)),
            (std::vector<Uuid>{edges[1].id, edges[2].id, edges[0].id}));
  EXPECT_TRUE(this->store_->EdgesOfPath(Uuid::Generate()).empty());
}

// --- Annotations --------------------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, AnnotationsOnNodesEdgesAndAnnotations) {
  const GraphBatch chain = Chain(2);
  this->store_->Put(chain);
  const Annotation on_node{Uuid::Generate(), AnnotationTarget::kNode,    chain.nodes[0].id, Uuid(),
                           "image",          std::string("\x89PNG\0", 5)};
  const Annotation on_edge{
      Uuid::Generate(), AnnotationTarget::kEdge, chain.edges[0].id, Uuid(), "covariance", "6x6"};
  const Annotation child{
      Uuid::Generate(), AnnotationTarget::kNone, Uuid(), on_node.id, "car", "bbox"};
  const Annotation grandchild{Uuid::Generate(), AnnotationTarget::kNone, Uuid(),
                              child.id,         "registration",          "AB12 CDE"};
  this->store_->PutAnnotation(on_node);
  this->store_->PutAnnotation(on_edge);
  this->store_->PutAnnotation(child);
  this->store_->PutAnnotation(grandchild);
  EXPECT_EQ(this->store_->GetAnnotation(grandchild.id), grandchild);
  EXPECT_EQ(this->store_->AnnotationsOn(AnnotationTarget::kNode, chain.nodes[0].id),
            std::vector<Annotation>{on_node});
  EXPECT_EQ(this->store_->AnnotationsOn(AnnotationTarget::kEdge, chain.edges[0].id),
            std::vector<Annotation>{on_edge});
  EXPECT_EQ(this->store_->ChildAnnotations(on_node.id), std::vector<Annotation>{child});
  EXPECT_EQ(this->store_->ChildAnnotations(child.id), std::vector<Annotation>{grandchild});
  EXPECT_TRUE(this->store_->AnnotationsOn(AnnotationTarget::kNode, chain.nodes[1].id).empty());
}

TYPED_TEST(GraphStoreConformance, AnnotationOnMissingTargetIsRefused) {
  const Uuid missing = Uuid::Generate();
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->store_->PutAnnotation(
            {Uuid::Generate(), AnnotationTarget::kNode, missing, Uuid(), "t", ""});
      },
      missing.ToString());
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->store_->PutAnnotation(
            {Uuid::Generate(), AnnotationTarget::kEdge, missing, Uuid(), "t", ""});
      },
      missing.ToString());
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->store_->PutAnnotation(
            {Uuid::Generate(), AnnotationTarget::kNone, Uuid(), missing, "t", ""});
      },
      missing.ToString());
  EXPECT_EQ(this->store_->Stats().annotations, 0);
}

TYPED_TEST(GraphStoreConformance, AnnotationIdempotentAndConflict) {
  const GraphBatch chain = Chain(1);
  this->store_->Put(chain);
  const Annotation a{Uuid::Generate(), AnnotationTarget::kNode, chain.nodes[0].id, Uuid(), "t",
                     "payload"};
  this->store_->PutAnnotation(a);
  this->store_->PutAnnotation(a);
  Annotation changed = a;
  changed.payload = "other";
  ExpectError(ErrorCode::kConflict, [&] { this->store_->PutAnnotation(changed); });
  EXPECT_EQ(this->store_->Stats().annotations, 1);
  EXPECT_EQ(this->store_->Stats().annotation_payload_bytes, 7);
}

// --- Batches ------------------------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, BatchWritesEverythingInDependencyOrder) {
  GraphBatch g = Chain(20);
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  g.paths.push_back(path);
  g.edges.push_back(PathEdge(g.nodes[0].id, g.nodes[10].id, path.id));
  g.annotations.push_back(
      {Uuid::Generate(), AnnotationTarget::kEdge, g.edges.back().id, Uuid(), "t", "x"});
  this->store_->Put(g);
  const StoreStats stats = this->store_->Stats();
  EXPECT_EQ(stats.nodes, 20);
  EXPECT_EQ(stats.edges, 20);
  EXPECT_EQ(stats.paths, 1);
  EXPECT_EQ(stats.annotations, 1);
  EXPECT_EQ(this->store_->GetNodes(Ids(g.nodes)), g.nodes);
}

TYPED_TEST(GraphStoreConformance, BatchTwiceAddsNothing) {
  const GraphBatch g = Chain(50);
  this->store_->Put(g);
  this->store_->Put(g);
  EXPECT_EQ(this->store_->Stats().nodes, 50);
  EXPECT_EQ(this->store_->Stats().edges, 49);
  // Half old, half new: the old half is a no-op, the new half lands.
  GraphBatch overlapping = Chain(40);
  overlapping.nodes.insert(overlapping.nodes.end(), g.nodes.begin(), g.nodes.begin() + 40);
  overlapping.edges.insert(overlapping.edges.end(), g.edges.begin(), g.edges.begin() + 39);
  this->store_->Put(overlapping);
  EXPECT_EQ(this->store_->Stats().nodes, 90);
  EXPECT_EQ(this->store_->Stats().edges, 49 + 39);
}

TYPED_TEST(GraphStoreConformance, BatchWithConflictStoresNothing) {
  const Node stored = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  this->store_->PutNode(stored);
  GraphBatch g = Chain(70);  // long enough for multi-row statements; the clash sits inside one
  Node clash = stored;
  clash.stamp_ns = 2;
  g.nodes.insert(g.nodes.begin() + 5, clash);
  ExpectError(
      ErrorCode::kConflict, [&] { this->store_->Put(g); }, stored.id.ToString());
  EXPECT_EQ(this->store_->Stats().nodes, 1);
  EXPECT_EQ(this->store_->Stats().edges, 0);
}

TYPED_TEST(GraphStoreConformance, BatchWithDanglingEdgeStoresNothing) {
  GraphBatch g = Chain(70);
  const Uuid missing = Uuid::Generate();
  g.edges.insert(g.edges.begin() + 10, MetricEdge(g.nodes[5].id, missing));
  ExpectError(
      ErrorCode::kIntegrity, [&] { this->store_->Put(g); }, missing.ToString());
  EXPECT_EQ(this->store_->Stats().nodes, 0);
}

TYPED_TEST(GraphStoreConformance, GetNodesFollowsRequestOrderAndNamesMissing) {
  const GraphBatch g = Chain(10);
  this->store_->Put(g);
  std::vector<Uuid> ids{g.nodes[7].id, g.nodes[2].id, g.nodes[9].id};
  const std::vector<Node> got = this->store_->GetNodes(ids);
  EXPECT_EQ(Ids(got), ids);
  EXPECT_EQ(got, (std::vector<Node>{g.nodes[7], g.nodes[2], g.nodes[9]}));
  // A repeated id gets the whole node each time (found nodes are moved into place once).
  const std::vector<Node> twice = this->store_->GetNodes(
      std::vector<Uuid>{g.nodes[4].id, g.nodes[5].id, g.nodes[4].id, g.nodes[4].id});
  EXPECT_EQ(twice, (std::vector<Node>{g.nodes[4], g.nodes[5], g.nodes[4], g.nodes[4]}));
  const Uuid missing = Uuid::Generate();
  ids.push_back(missing);
  ExpectError(
      ErrorCode::kNotFound, [&] { this->store_->GetNodes(ids); }, missing.ToString());
}

// --- Chains and neighbourhoods ------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, ReadChainInOneCall) {
  const GraphBatch g = Chain(200);
  this->store_->Put(g);
  const Subgraph chain = this->store_->ReadChain(g.nodes[0].id);
  EXPECT_EQ(Ids(chain.nodes), Ids(g.nodes));
  EXPECT_EQ(chain.edges.size(), 199u);
  const Subgraph tail = this->store_->ReadChain(g.nodes[150].id);
  EXPECT_EQ(tail.nodes.size(), 50u);
  EXPECT_EQ(tail.nodes.front(), g.nodes[150]);
}

TYPED_TEST(GraphStoreConformance, ReadChainEndsAtCycleAndIgnoresPathEdges) {
  GraphBatch g = Chain(6);
  g.edges.push_back(MetricEdge(g.nodes[5].id, g.nodes[0].id));  // a loop, like a route
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  const Node elsewhere = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  g.paths.push_back(path);
  g.nodes.push_back(elsewhere);
  g.edges.push_back(PathEdge(g.nodes[2].id, elsewhere.id, path.id));
  this->store_->Put(g);
  const Subgraph chain = this->store_->ReadChain(g.nodes[0].id);
  EXPECT_EQ(chain.nodes.size(), 6u);
  EXPECT_EQ(chain.edges.size(), 6u);
  ExpectError(ErrorCode::kNotFound, [&] { this->store_->ReadChain(Uuid::Generate()); });
}

TYPED_TEST(GraphStoreConformance, ReadChainWithBranchWalksLowestEdgeUuidFirst) {
  GraphBatch g = Chain(3);  // 0 -> 1 -> 2
  const Node branch = MakeNode(Uuid::Generate(), Uuid::Generate(), 5);
  g.nodes.push_back(branch);
  Edge to_branch = MetricEdge(g.nodes[0].id, branch.id);
  to_branch.id = Uuid::Parse("00000000-0000-7000-8000-000000000000");  // lowest: walked first
  g.edges.push_back(to_branch);
  this->store_->Put(g);
  const Subgraph chain = this->store_->ReadChain(g.nodes[0].id);
  EXPECT_EQ(Ids(chain.nodes),
            (std::vector<Uuid>{g.nodes[0].id, branch.id, g.nodes[1].id, g.nodes[2].id}));
  EXPECT_EQ(chain.edges.size(), 3u);
}

TYPED_TEST(GraphStoreConformance, NeighbourhoodByHops) {
  const GraphBatch g = Chain(11);
  this->store_->Put(g);
  const Subgraph near = this->store_->Neighbourhood({.centre = g.nodes[5].id, .max_hops = 2});
  ASSERT_EQ(near.nodes.size(), 5u);  // nodes 3..7
  EXPECT_EQ(near.nodes.front().id, g.nodes[5].id);
  std::vector<Uuid> expected{g.nodes[3].id, g.nodes[4].id, g.nodes[5].id, g.nodes[6].id,
                             g.nodes[7].id};
  std::vector<Uuid> got = Ids(near.nodes);
  std::sort(expected.begin(), expected.end());
  std::sort(got.begin(), got.end());
  EXPECT_EQ(got, expected);
  EXPECT_EQ(near.edges.size(), 4u);
  EXPECT_EQ(this->store_->Neighbourhood({.centre = g.nodes[5].id, .max_hops = 0}).nodes.size(), 1u);
}

TYPED_TEST(GraphStoreConformance, NeighbourhoodByMetricRadius) {
  const GraphBatch g = Chain(11, /*step_m=*/2.0);  // each edge ~2.07 m (2, 0.25, -0.5)
  this->store_->Put(g);
  const Subgraph near = this->store_->Neighbourhood({.centre = g.nodes[0].id, .max_radius_m = 6.5});
  EXPECT_EQ(near.nodes.size(), 4u);  // 0 m, 2.07 m, 4.14 m, 6.22 m
  const Subgraph both =
      this->store_->Neighbourhood({.centre = g.nodes[0].id, .max_hops = 2, .max_radius_m = 6.5});
  EXPECT_EQ(both.nodes.size(), 3u);
}

TYPED_TEST(GraphStoreConformance, NeighbourhoodFollowsPathEdgesOnlyWhenAsked) {
  GraphBatch g = Chain(3);
  const Node far = MakeNode(Uuid::Generate(), Uuid::Generate(), 1);
  const Path path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), 0, 1};
  g.nodes.push_back(far);
  g.paths.push_back(path);
  g.edges.push_back(PathEdge(g.nodes[0].id, far.id, path.id));
  this->store_->Put(g);
  EXPECT_EQ(this->store_->Neighbourhood({.centre = g.nodes[0].id, .max_hops = 1}).nodes.size(), 2u);
  const Subgraph with_paths = this->store_->Neighbourhood(
      {.centre = g.nodes[0].id, .max_hops = 1, .follow_path_edges = true});
  EXPECT_EQ(with_paths.nodes.size(), 3u);
  ExpectError(ErrorCode::kNotFound,
              [&] { this->store_->Neighbourhood({.centre = Uuid::Generate()}); });
}

// --- Listing and statistics ---------------------------------------------------------------

TYPED_TEST(GraphStoreConformance, ListNodesByRobotOutingAndWindow) {
  const Uuid robot_a = Uuid::Generate(), robot_b = Uuid::Generate();
  const Uuid outing_1 = Uuid::Generate(), outing_2 = Uuid::Generate();
  GraphBatch g;
  for (int i = 0; i < 10; ++i) g.nodes.push_back(MakeNode(robot_a, outing_1, 100 + i));
  for (int i = 0; i < 5; ++i) g.nodes.push_back(MakeNode(robot_a, outing_2, 200 + i));
  for (int i = 0; i < 7; ++i) g.nodes.push_back(MakeNode(robot_b, Uuid::Generate(), 150 + i));
  this->store_->Put(g);
  EXPECT_EQ(this->store_->ListNodes({.robot = robot_a}).size(), 15u);
  EXPECT_EQ(this->store_->ListNodes({.outing = outing_2}).size(), 5u);
  const std::vector<Node> window = this->store_->ListNodes({.from_ns = 105, .to_ns = 152});
  EXPECT_EQ(window.size(), 5u + 2u);  // 105..109 of robot a, 150..151 of robot b
  EXPECT_TRUE(std::is_sorted(window.begin(), window.end(),
                             [](const Node& x, const Node& y) { return x.stamp_ns < y.stamp_ns; }));
  const std::vector<Node> lean =
      this->store_->ListNodes({.robot = robot_b, .from_ns = 150, .with_landmarks = false});
  ASSERT_EQ(lean.size(), 7u);
  EXPECT_TRUE(lean[0].landmarks_blob.empty());
}

TYPED_TEST(GraphStoreConformance, StatsCountEverything) {
  GraphBatch g = Chain(4);
  g.annotations.push_back(
      {Uuid::Generate(), AnnotationTarget::kNode, g.nodes[0].id, Uuid(), "t", "12345"});
  this->store_->Put(g);
  const StoreStats stats = this->store_->Stats();
  EXPECT_EQ(stats.nodes, 4);
  EXPECT_EQ(stats.edges, 3);
  EXPECT_EQ(stats.paths, 0);
  EXPECT_EQ(stats.annotations, 1);
  EXPECT_EQ(stats.landmark_bytes, 4 * 9);  // "landmarks"
  EXPECT_EQ(stats.annotation_payload_bytes, 5);
}

// --- Transactions and durability ----------------------------------------------------------

TYPED_TEST(GraphStoreConformance, TransactionCommitLandsTogether) {
  auto reader = GraphStore::Open(this->backend_->Uri());
  const GraphBatch g = Chain(3);
  auto txn = this->store_->Begin();
  for (const Node& n : g.nodes) this->store_->PutNode(n);
  this->store_->PutEdge(g.edges[0]);
  EXPECT_EQ(reader->Stats().nodes, 0);  // not visible before commit
  txn.Commit();
  EXPECT_EQ(reader->Stats().nodes, 3);
  EXPECT_EQ(reader->Stats().edges, 1);
}

TYPED_TEST(GraphStoreConformance, TransactionRollsBackWhenDropped) {
  const GraphBatch g = Chain(3);
  {
    auto txn = this->store_->Begin();
    this->store_->Put(g);
  }
  EXPECT_FALSE(this->store_->in_transaction());
  EXPECT_EQ(this->store_->Stats().nodes, 0);
  this->store_->Put(g);  // the store is usable afterwards
  EXPECT_EQ(this->store_->Stats().nodes, 3);
}

TYPED_TEST(GraphStoreConformance, FailedTransactionCannotCommit) {
  const GraphBatch g = Chain(2);
  auto txn = this->store_->Begin();
  this->store_->Put(g);
  EXPECT_THROW(this->store_->PutEdge(MetricEdge(g.nodes[0].id, Uuid::Generate())), Error);
  ExpectError(ErrorCode::kInvalidArgument, [&] { this->store_->PutNode(MakeNode({}, {}, 1)); });
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { txn.Commit(); }, "rolled back");
  EXPECT_EQ(this->store_->Stats().nodes, 0);
}

TYPED_TEST(GraphStoreConformance, NestedTransactionIsRefused) {
  auto txn = this->store_->Begin();
  ExpectError(ErrorCode::kInvalidArgument, [&] { this->store_->Begin(); });
  txn.Commit();
}

TYPED_TEST(GraphStoreConformance, BufferedModeStoresDurablyAcrossReopen) {
  auto buffered = this->Reopen({.durability = Durability::kBuffered});
  const GraphBatch g = Chain(100);
  for (const Node& n : g.nodes) buffered->PutNode(n);
  for (const Edge& e : g.edges) buffered->PutEdge(e);
  buffered.reset();
  auto synchronous = GraphStore::Open(this->backend_->Uri());
  EXPECT_EQ(synchronous->ReadChain(g.nodes[0].id).nodes.size(), 100u);
}

TYPED_TEST(GraphStoreConformance, TwoConnectionsWriteConcurrently) {
  auto other = GraphStore::Open(this->backend_->Uri());
  const GraphBatch a = Chain(200), b = Chain(200);
  std::thread writer([&] {
    for (const Node& n : b.nodes) other->PutNode(n);
  });
  for (const Node& n : a.nodes) this->store_->PutNode(n);
  writer.join();
  EXPECT_EQ(this->store_->Stats().nodes, 400);
}

// Seed 000 §6: crash safety. A child process writes one large batch and is killed with
// SIGKILL while inside it; the store must then open cleanly with the batch wholly present or
// wholly absent.
TYPED_TEST(GraphStoreConformance, KilledMidBatchLeavesAllOrNothing) {
  const std::string uri = this->backend_->Uri();
  int nodes = 20000;
  bool killed_inside = false;
  for (int attempt = 0; attempt < 4 && !killed_inside; ++attempt, nodes *= 2) {
    const Uuid robot = Uuid::Generate();
    int pipe_fds[2];
    ASSERT_EQ(pipe(pipe_fds), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      // The child shares nothing with the parent's connection; _exit skips destructors that
      // would close the parent's sockets.
      close(pipe_fds[0]);
      try {
        auto store = GraphStore::Open(uri);
        const GraphBatch batch = Chain(nodes, 1.0, robot);
        (void)!write(pipe_fds[1], "s", 1);  // about to start the batch
        store->Put(batch);
        (void)!write(pipe_fds[1], "d", 1);  // the batch committed
      } catch (...) {
        _exit(3);
      }
      _exit(0);
    }
    close(pipe_fds[1]);
    char c = 0;
    ASSERT_EQ(read(pipe_fds[0], &c, 1), 1);
    ASSERT_EQ(c, 's');
    std::this_thread::sleep_for(std::chrono::milliseconds(40));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    // Anything more on the pipe means the batch finished before the kill.
    fcntl(pipe_fds[0], F_SETFL, O_NONBLOCK);
    killed_inside = WIFSIGNALED(status) && read(pipe_fds[0], &c, 1) <= 0;
    close(pipe_fds[0]);

    this->store_.reset();
    auto store = GraphStore::Open(uri);  // opens cleanly after the kill
    const std::size_t present = store->ListNodes({.robot = robot, .with_landmarks = false}).size();
    EXPECT_TRUE(present == 0 || present == static_cast<std::size_t>(nodes))
        << present << " of " << nodes << " nodes survived a kill mid-batch";
    this->store_ = std::move(store);
  }
  EXPECT_TRUE(killed_inside) << "every batch finished before the kill; the test proved nothing";
}

}  // namespace
}  // namespace fleetmap
