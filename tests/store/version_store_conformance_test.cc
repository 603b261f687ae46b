// One conformance suite for VersionStore, run on every backend (typed GoogleTest): what
// version_store.h promises (seed 004 §V: submissions kept whole, a linear history, checkout
// of any revision, reverts that hide and never delete) must hold on SQLite and on a real
// PostgreSQL server alike.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <tuple>
#include <type_traits>

#include "expect_error.h"
#include "fleetmap/core/error.h"
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

Edge UnitMetricEdge(const Uuid& from, const Uuid& to) {
  Se3 from_T_to = Se3::Identity();
  from_T_to.translation() = Eigen::Vector3d(1.0, 0.25, -0.5);
  return Edge{Uuid::Generate(), from, to, EdgeKind::kMetric, from_T_to, Uuid()};
}

Path MakePath(std::int64_t start_ns) {
  return Path{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(), start_ns, start_ns + 100};
}

// A chain n0 -> n1 -> ... of metric edges; stamps from first_stamp_ns on.
GraphBatch StampedChain(int n, std::int64_t first_stamp_ns) {
  GraphBatch batch;
  const Uuid robot = Uuid::Generate(), outing = Uuid::Generate();
  for (int i = 0; i < n; ++i) {
    batch.nodes.push_back(MakeNode(robot, outing, first_stamp_ns + i, "lm" + std::to_string(i)));
  }
  for (int i = 0; i + 1 < n; ++i) {
    batch.edges.push_back(UnitMetricEdge(batch.nodes[i].id, batch.nodes[i + 1].id));
  }
  return batch;
}

template <typename T>
std::vector<Uuid> SortedIds(const std::vector<T>& items) {
  std::vector<Uuid> ids = Ids(items);
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::vector<Uuid> Sorted(std::vector<Uuid> ids) {
  std::sort(ids.begin(), ids.end());
  return ids;
}

// StoreStats has no operator==; compare its fields.
auto Fields(const StoreStats& s) {
  return std::make_tuple(s.nodes, s.edges, s.paths, s.annotations, s.landmark_bytes,
                         s.annotation_payload_bytes);
}

Submission Header(const Uuid& robot = Uuid::Generate(), std::int64_t received_ns = 1000) {
  Submission s;
  s.id = Uuid::Generate();
  s.robot = robot;
  s.author = "robot-7";
  s.received_ns = received_ns;
  return s;
}

Revision Merge(RevisionNumber number, const std::string& report = "{}") {
  Revision r;
  r.number = number;
  r.created_ns = 5000 + number;
  r.author = "robot-7";
  r.kind = RevisionKind::kMerge;
  r.submission = Uuid::Generate();
  r.report = report;
  return r;
}

Revision RevertOf(RevisionNumber number, RevisionNumber reverted) {
  Revision r;
  r.number = number;
  r.created_ns = 9000 + number;
  r.author = "operator";
  r.kind = RevisionKind::kRevert;
  r.reverted = reverted;
  r.report = "bad merge";
  return r;
}

// A history with every kind of element and dependency, for the revert and checkout tests:
//   revision 0: base chain b0 -> b1 -> b2 (plain Put, outside version control)
//   revision 1: nodes n1 -> n2 (edge e12), edge eb (b0 -> n1), path p with edge pe (b0 -> b1)
//   then, outside version control, edge e0 (n1 -> b2): revision 0 although it touches n1
//   revision 2: node n3, edge e23 (n2 -> n3), edge eb12 (b1 -> b2), edge pe2 on p (b1 -> b2)
struct History {
  GraphBatch base;
  Node n1, n2, n3;
  Edge e12, eb, pe, e0, e23, eb12, pe2;
  Path p;
  Revision r1, r2;
};

template <typename Backend>
class VersionStoreConformance : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    store_ = GraphStore::Open(backend_->Uri());
  }

  VersionStore& versions() { return store_->versions(); }

  // Commits `additions` as the next revision, the way MERGE does: AppendRevision and Put in
  // one transaction.
  Revision Commit(const GraphBatch& additions) {
    auto txn = store_->Begin();
    const Revision recorded =
        versions().AppendRevision(Merge(versions().HeadRevision() + 1), additions);
    store_->Put(additions);
    txn.Commit();
    return recorded;
  }

  Revision Revert(RevisionNumber reverted) {
    return versions().AppendRevert(RevertOf(versions().HeadRevision() + 1, reverted));
  }

  // The history described at History.
  History MakeHistory() {
    History h;
    h.base = StampedChain(3, 100);
    store_->Put(h.base);
    const Node& b0 = h.base.nodes[0];
    const Node& b1 = h.base.nodes[1];
    const Node& b2 = h.base.nodes[2];
    const Uuid robot = Uuid::Generate(), outing = Uuid::Generate();
    h.n1 = MakeNode(robot, outing, 200, "n1 landmarks");
    h.n2 = MakeNode(robot, outing, 201, "n2");
    h.p = MakePath(50);
    h.e12 = UnitMetricEdge(h.n1.id, h.n2.id);
    h.eb = UnitMetricEdge(b0.id, h.n1.id);
    h.pe = PathEdge(b0.id, b1.id, h.p.id);
    h.r1 = Commit(GraphBatch{{h.p}, {h.n1, h.n2}, {h.e12, h.eb, h.pe}, {}});
    h.e0 = UnitMetricEdge(h.n1.id, b2.id);
    store_->PutEdge(h.e0);
    h.n3 = MakeNode(robot, outing, 150, "n3");
    h.e23 = UnitMetricEdge(h.n2.id, h.n3.id);
    h.eb12 = UnitMetricEdge(b1.id, b2.id);
    h.pe2 = PathEdge(b1.id, b2.id, h.p.id);
    h.r2 = Commit(GraphBatch{{}, {h.n3}, {h.e23, h.eb12, h.pe2}, {}});
    return h;
  }

  std::optional<Backend> backend_;
  std::unique_ptr<GraphStore> store_;
};

TYPED_TEST_SUITE(VersionStoreConformance, StoreBackends, BackendNames);

// --- Schema -------------------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, FreshStoreIsAtSchemaTwoWithEmptyHistory) {
  EXPECT_GE(GraphStore::LatestSchemaVersion(), 2);
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_EQ(this->versions().HeadRevision(), 0);
  EXPECT_TRUE(this->versions().ListRevisions().empty());
  EXPECT_TRUE(this->versions().ListSubmissions().empty());
  EXPECT_EQ(this->versions().FindRevision(1), std::nullopt);
}

// A store written before version control (schema 1) keeps its map, as revision 0.
TYPED_TEST(VersionStoreConformance, SchemaOneStoreMigratesWithItsMapAtRevisionZero) {
  const GraphBatch old = StampedChain(3, 0);
  this->store_->Put(old);
  this->store_.reset();
  // Back to schema 1: undo 0009 (retirements, node use), 0008 (edge covariances, a column of
  // edges), 0006 (claims: columns of submissions, dropped with it), 0005 (submission nodes,
  // stand-ins), 0004 (annotations on data: the payload tables, and the annotation table as schema 1
  // had it, empty here), 0003 (sensor index) and 0002 (versions).
  const bool sqlite = std::is_same_v<TypeParam, SqliteBackend>;
  this->backend_->ExecRaw(
      std::string("DROP TABLE retirements; DROP TABLE node_usage;"
                  " ALTER TABLE edges DROP COLUMN covariance;"
                  " DROP TABLE stand_ins; DROP TABLE submission_nodes;"
                  " DROP TABLE annotation_datum_link; DROP TABLE annotation_bbox2d;"
                  " DROP TABLE annotations;") +
      (sqlite ? "CREATE TABLE annotations (seq INTEGER PRIMARY KEY, id BLOB NOT NULL UNIQUE,"
                " node_id BLOB REFERENCES nodes (id), edge_id BLOB REFERENCES edges (id),"
                " parent_id BLOB REFERENCES annotations (id), type TEXT NOT NULL,"
                " payload BLOB NOT NULL, CHECK ((node_id IS NOT NULL) + (edge_id IS NOT NULL)"
                " + (parent_id IS NOT NULL) = 1));"
              : "CREATE TABLE annotations (id uuid PRIMARY KEY, node_id uuid REFERENCES nodes"
                " (id), edge_id uuid REFERENCES edges (id), parent_id uuid REFERENCES"
                " annotations (id), type text NOT NULL, payload bytea NOT NULL,"
                " CHECK (num_nonnulls(node_id, edge_id, parent_id) = 1));") +
      "DROP TABLE data; DROP TABLE files; DROP TABLE sensor_mounts; DROP TABLE sensors;"
      " DROP TABLE platforms;"
      " DROP TABLE settings; DROP TABLE element_versions; DROP TABLE submission_chunks;"
      " DROP TABLE submissions; DROP TABLE revisions; UPDATE fleetmap_schema SET version = 1");
  this->store_ = GraphStore::Open(this->backend_->Uri());
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_EQ(this->versions().HeadRevision(), 0);
  EXPECT_EQ(this->versions().NodesAt(0), old.nodes);
  EXPECT_EQ(this->versions().VersionOf(old.edges[1].id), (ElementVersion{0, std::nullopt}));
  EXPECT_EQ(this->Commit(StampedChain(2, 10)).number, 1);
}

// --- Submissions --------------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, BeginSubmissionStoresTheHeaderWithEmptyContent) {
  Submission header = Header();
  // Counts, digest and state come from the store, not from the header.
  header.chunk_count = 9;
  header.bytes = 99;
  header.digest = 7;
  header.state = SubmissionState::kMerged;
  header.revision = 4;
  header.error = "ignored";
  const Submission stored = this->versions().BeginSubmission(header);
  Submission expected;
  expected.id = header.id;
  expected.robot = header.robot;
  expected.author = header.author;
  expected.received_ns = header.received_ns;
  EXPECT_EQ(stored, expected);
  EXPECT_EQ(this->versions().FindSubmission(header.id), expected);
  EXPECT_EQ(this->versions().FindSubmission(Uuid::Generate()), std::nullopt);
}

TYPED_TEST(VersionStoreConformance, BeginSubmissionAgainResumesFromTheSameRobotOnly) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().PutSubmissionChunk(header.id, 0, "first");
  this->versions().PutSubmissionChunk(header.id, 1, "second");

  Submission again = header;
  again.author = "someone else";
  again.received_ns = 999999;
  const Submission resumed = this->versions().BeginSubmission(again);
  EXPECT_EQ(resumed.chunk_count, 2);  // the push carries on after chunk 1
  EXPECT_EQ(resumed.author, header.author);
  EXPECT_EQ(resumed.received_ns, header.received_ns);
  EXPECT_EQ(this->versions().FindSubmission(header.id), resumed);

  Submission thief = header;
  thief.robot = Uuid::Generate();
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().BeginSubmission(thief); }, header.id.ToString());
  EXPECT_EQ(this->versions().FindSubmission(header.id)->robot, header.robot);
}

TYPED_TEST(VersionStoreConformance, ChunksArriveInOrderAndReadBackExactly) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  const std::vector<std::string> chunks = {std::string("\0\x01\xff", 3), "", "a longer chunk"};
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    this->versions().PutSubmissionChunk(header.id, static_cast<std::int64_t>(i), chunks[i]);
  }
  const Submission stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.chunk_count, 3);
  EXPECT_EQ(stored.bytes, 3 + 0 + 14);
  EXPECT_EQ(stored.state, SubmissionState::kReceiving);
  for (std::size_t i = 0; i < chunks.size(); ++i) {
    EXPECT_EQ(this->versions().SubmissionChunk(header.id, static_cast<std::int64_t>(i)), chunks[i]);
  }
  ExpectError(
      ErrorCode::kNotFound, [&] { this->versions().SubmissionChunk(header.id, 3); },
      header.id.ToString());
}

TYPED_TEST(VersionStoreConformance, ResentChunkIsANoOpAndOtherBytesAConflict) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().PutSubmissionChunk(header.id, 0, "zero");
  this->versions().PutSubmissionChunk(header.id, 1, "one");
  this->versions().PutSubmissionChunk(header.id, 0, "zero");  // retry after a lost ack
  EXPECT_EQ(this->versions().FindSubmission(header.id)->chunk_count, 2);
  EXPECT_EQ(this->versions().FindSubmission(header.id)->bytes, 7);

  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().PutSubmissionChunk(header.id, 0, "ZERO"); },
      header.id.ToString());
  EXPECT_EQ(this->versions().SubmissionChunk(header.id, 0), "zero");
  EXPECT_EQ(this->versions().FindSubmission(header.id)->bytes, 7);
}

TYPED_TEST(VersionStoreConformance, ChunkSkippingAheadIsInvalid) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().PutSubmissionChunk(header.id, 0, "zero");
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { this->versions().PutSubmissionChunk(header.id, 2, "two"); }, header.id.ToString());
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { this->versions().PutSubmissionChunk(header.id, -1, "minus one"); });
  EXPECT_EQ(this->versions().FindSubmission(header.id)->chunk_count, 1);
  ExpectError(ErrorCode::kNotFound, [&] { this->versions().SubmissionChunk(header.id, 2); });
  this->versions().PutSubmissionChunk(header.id, 1, "one");  // the gap filled, it goes on
  EXPECT_EQ(this->versions().FindSubmission(header.id)->chunk_count, 2);
}

TYPED_TEST(VersionStoreConformance, UnknownSubmissionIsNotFound) {
  const Uuid unknown = Uuid::Generate();
  const std::string name = unknown.ToString();
  ExpectError(
      ErrorCode::kNotFound, [&] { this->versions().PutSubmissionChunk(unknown, 0, "x"); }, name);
  ExpectError(
      ErrorCode::kNotFound, [&] { this->versions().CompleteSubmission(unknown, 1); }, name);
  ExpectError(
      ErrorCode::kNotFound,
      [&] { this->versions().SetSubmissionState(unknown, SubmissionState::kFailed, 0, "x"); },
      name);
  ExpectError(
      ErrorCode::kNotFound, [&] { this->versions().SubmissionChunk(unknown, 0); }, name);
  EXPECT_EQ(this->versions().FindSubmission(unknown), std::nullopt);
  EXPECT_TRUE(this->versions().ListSubmissions().empty());  // nothing was created on the way
}

TYPED_TEST(VersionStoreConformance, CompleteQueuesOnceAndKeepsEveryDigestBit) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().PutSubmissionChunk(header.id, 0, "zero");
  this->versions().PutSubmissionChunk(header.id, 1, "one");
  const std::uint64_t digest = 0xfedcba9876543210ULL;  // above INT64_MAX
  this->versions().CompleteSubmission(header.id, digest);
  Submission stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.state, SubmissionState::kQueued);
  EXPECT_EQ(stored.digest, digest);

  this->versions().CompleteSubmission(header.id, digest);  // again: a no-op
  EXPECT_EQ(this->versions().FindSubmission(header.id), stored);
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().CompleteSubmission(header.id, digest + 1); },
      header.id.ToString());
  EXPECT_EQ(this->versions().FindSubmission(header.id)->digest, digest);

  // Complete means immutable: a repeat of a stored chunk is fine, anything else conflicts.
  this->versions().PutSubmissionChunk(header.id, 1, "one");
  ExpectError(ErrorCode::kConflict,
              [&] { this->versions().PutSubmissionChunk(header.id, 1, "uno"); });
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().PutSubmissionChunk(header.id, 2, "two"); },
      header.id.ToString());
  EXPECT_EQ(this->versions().FindSubmission(header.id), stored);

  const Submission max = Header();
  this->versions().BeginSubmission(max);
  this->versions().CompleteSubmission(max.id, ~0ULL);
  EXPECT_EQ(this->versions().FindSubmission(max.id)->digest, ~0ULL);
}

TYPED_TEST(VersionStoreConformance, SubmissionStateRecordsMergeOutcome) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { this->versions().SetSubmissionState(header.id, SubmissionState::kMerged, 1, ""); },
      header.id.ToString());
  this->versions().CompleteSubmission(header.id, 42);

  this->versions().SetSubmissionState(header.id, SubmissionState::kFailed, 0, "did not fit");
  Submission stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.state, SubmissionState::kFailed);
  EXPECT_EQ(stored.error, "did not fit");

  this->versions().SetSubmissionState(header.id, SubmissionState::kQueued, 0, "");  // retry
  stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.state, SubmissionState::kQueued);
  EXPECT_EQ(stored.error, "");

  this->versions().SetSubmissionState(header.id, SubmissionState::kMerged, 3, "");
  stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.state, SubmissionState::kMerged);
  EXPECT_EQ(stored.revision, 3);
  EXPECT_EQ(stored.digest, 42u);
  EXPECT_EQ(stored.chunk_count, 0);

  ExpectError(ErrorCode::kInvalidArgument, [&] {
    this->versions().SetSubmissionState(header.id, SubmissionState::kReceiving, 0, "");
  });
  EXPECT_EQ(this->versions().FindSubmission(header.id), stored);
}

TYPED_TEST(VersionStoreConformance, ListSubmissionsByReceivedThenId) {
  const Submission late = Header(Uuid::Generate(), 20);
  Submission early_a = Header(Uuid::Generate(), 10);
  Submission early_b = Header(Uuid::Generate(), 10);
  if (early_b.id < early_a.id) std::swap(early_a, early_b);
  for (const Submission& s : {late, early_b, early_a}) this->versions().BeginSubmission(s);
  const std::vector<Submission> listed = this->versions().ListSubmissions();
  ASSERT_EQ(listed.size(), 3u);
  EXPECT_EQ(listed[0].id, early_a.id);
  EXPECT_EQ(listed[1].id, early_b.id);
  EXPECT_EQ(listed[2].id, late.id);
}

// A transient failure is recorded with the submission while it stays queued.
TYPED_TEST(VersionStoreConformance, QueuedSubmissionKeepsItsLastTransientError) {
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().CompleteSubmission(header.id, 7);
  this->versions().SetSubmissionState(header.id, SubmissionState::kQueued, 0,
                                      "merge attempt 1 failed: database is locked");
  Submission stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.state, SubmissionState::kQueued);
  EXPECT_EQ(stored.error, "merge attempt 1 failed: database is locked");
  this->versions().SetSubmissionState(header.id, SubmissionState::kMerged, 2, "ignored");
  stored = *this->versions().FindSubmission(header.id);
  EXPECT_EQ(stored.error, "") << "a merged submission has no error";
}

// --- Claims: several fleetmapd on one store ------------------------------------

// `received_ns` apart, each complete (queued).
std::vector<Submission> QueueSubmissions(VersionStore& versions, int n) {
  std::vector<Submission> queued;
  for (int i = 0; i < n; ++i) {
    queued.push_back(versions.BeginSubmission(Header(Uuid::Generate(), 1000 + i)));
    versions.CompleteSubmission(queued.back().id, 7);
  }
  return queued;
}

constexpr std::chrono::milliseconds kLongLease{60'000};

TYPED_TEST(VersionStoreConformance, ClaimsGoOldestFirstEachToOneInstance) {
  const std::vector<Submission> queued = QueueSubmissions(this->versions(), 3);
  this->versions().BeginSubmission(Header(Uuid::Generate(), 1));  // still receiving
  const Submission merged = this->versions().BeginSubmission(Header(Uuid::Generate(), 2));
  this->versions().CompleteSubmission(merged.id, 7);
  this->versions().SetSubmissionState(merged.id, SubmissionState::kMerged, 1, "");

  const std::optional<Submission> a = this->versions().ClaimQueuedSubmission("a", kLongLease);
  const std::optional<Submission> b = this->versions().ClaimQueuedSubmission("b", kLongLease);
  const std::optional<Submission> c = this->versions().ClaimQueuedSubmission("c", kLongLease);
  ASSERT_TRUE(a && b && c);
  EXPECT_EQ(a->id, queued[0].id);
  EXPECT_EQ(b->id, queued[1].id);
  EXPECT_EQ(c->id, queued[2].id);
  EXPECT_EQ(a->state, SubmissionState::kQueued);
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("d", kLongLease), std::nullopt)
      << "receiving and merged submissions are never claimed, live claims are not shared";
  // An instance restarted under its name takes back what it held.
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("b", kLongLease)->id, queued[1].id);

  const std::optional<SubmissionClaim> claim = this->versions().FindClaim(queued[0].id);
  ASSERT_TRUE(claim);
  EXPECT_EQ(claim->instance, "a");
  EXPECT_GT(claim->lease_until_ns, 0);
  EXPECT_EQ(this->versions().FindClaim(merged.id), std::nullopt);
  ExpectError(ErrorCode::kNotFound, [&] { this->versions().FindClaim(Uuid::Generate()); });
}

TYPED_TEST(VersionStoreConformance, EndedLeaseIsTakenOverAndCannotBeRenewed) {
  const Submission queued = QueueSubmissions(this->versions(), 1)[0];
  // A lease of 400 ms, waits of 600 ms: each check after a renewal or claim runs well inside
  // the lease even on a loaded machine (50 ms once ran out between two statements in CI).
  constexpr std::chrono::milliseconds kShortLease(400), kPastLease(600);
  ASSERT_TRUE(this->versions().ClaimQueuedSubmission("slow", kShortLease));
  std::this_thread::sleep_for(kPastLease);
  // Ended, but nobody took it: its holder was slow, not replaced, and may renew it.
  EXPECT_TRUE(this->versions().RenewClaim(queued.id, "slow", kShortLease));
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("other", kLongLease), std::nullopt);
  std::this_thread::sleep_for(kPastLease);
  ASSERT_TRUE(this->versions().ClaimQueuedSubmission("dies", kShortLease));
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("other", kLongLease), std::nullopt);
  std::this_thread::sleep_for(kPastLease);

  const std::optional<Submission> taken =
      this->versions().ClaimQueuedSubmission("other", kLongLease);
  ASSERT_TRUE(taken);
  EXPECT_EQ(taken->id, queued.id);
  EXPECT_FALSE(this->versions().RenewClaim(queued.id, "dies", kLongLease))
      << "the instance whose lease ended must not go on to commit its merge";
  EXPECT_EQ(this->versions().FindClaim(queued.id)->instance, "other");
  const std::int64_t until = this->versions().FindClaim(queued.id)->lease_until_ns;
  EXPECT_TRUE(this->versions().RenewClaim(queued.id, "other", 2 * kLongLease));
  EXPECT_GT(this->versions().FindClaim(queued.id)->lease_until_ns, until);
}

TYPED_TEST(VersionStoreConformance, ReleasedClaimIsFreeAtOnceAndBadClaimsAreRefused) {
  const Submission queued = QueueSubmissions(this->versions(), 1)[0];
  ASSERT_TRUE(this->versions().ClaimQueuedSubmission("a", kLongLease));
  this->versions().ReleaseClaim(queued.id, "b");  // not b's: changes nothing
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("b", kLongLease), std::nullopt);
  this->versions().ReleaseClaim(queued.id, "a");
  EXPECT_EQ(this->versions().FindClaim(queued.id), std::nullopt);
  EXPECT_FALSE(this->versions().RenewClaim(queued.id, "a", kLongLease));
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("b", kLongLease)->id, queued.id);

  ExpectError(ErrorCode::kInvalidArgument,
              [&] { this->versions().ClaimQueuedSubmission("", kLongLease); });
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { this->versions().ClaimQueuedSubmission("a", std::chrono::milliseconds(0)); });
  EXPECT_EQ(this->versions().FindClaim(queued.id)->instance, "b")
      << "a refused claim changes nothing";
}

TYPED_TEST(VersionStoreConformance, ClaimPassesOverTheSubmissionsItIsToldToSkip) {
  const std::vector<Submission> queued = QueueSubmissions(this->versions(), 3);
  const std::optional<Submission> claimed =
      this->versions().ClaimQueuedSubmission("a", kLongLease, {queued[0].id, queued[2].id});
  ASSERT_TRUE(claimed);
  EXPECT_EQ(claimed->id, queued[1].id) << "the oldest not skipped";
  EXPECT_EQ(this->versions().FindClaim(queued[0].id), std::nullopt) << "a skipped one stays free";
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("b", kLongLease, {queued[0].id, queued[2].id}),
            std::nullopt)
      << "only skipped and held submissions are left";
  EXPECT_EQ(this->versions().ClaimQueuedSubmission("b", kLongLease, {})->id, queued[0].id);
}

// Instances claiming at once on their own connections: every submission claimed exactly once.
TYPED_TEST(VersionStoreConformance, InstancesClaimingAtOnceNeverShareASubmission) {
  constexpr int kSubmissions = 40, kInstances = 4;
  const std::vector<Submission> queued = QueueSubmissions(this->versions(), kSubmissions);
  std::vector<std::vector<Uuid>> claimed(kInstances);
  std::vector<std::string> errors(kInstances);
  std::vector<std::thread> instances;
  for (int i = 0; i < kInstances; ++i) {
    instances.emplace_back([&, i] {
      try {
        auto store = GraphStore::Open(this->backend_->Uri());
        const std::string name = "instance-" + std::to_string(i);
        while (auto s = store->versions().ClaimQueuedSubmission(name, kLongLease)) {
          claimed[i].push_back(s->id);
          // As a merge would: finish it, so this instance's next claim takes a new one.
          store->versions().SetSubmissionState(s->id, SubmissionState::kFailed, 0, "test");
        }
      } catch (const Error& e) {
        errors[i] = e.what();
      }
    });
  }
  for (std::thread& t : instances) t.join();
  std::vector<Uuid> all;
  for (int i = 0; i < kInstances; ++i) {
    EXPECT_EQ(errors[i], "") << "instance " << i;
    all.insert(all.end(), claimed[i].begin(), claimed[i].end());
  }
  EXPECT_EQ(Sorted(all), SortedIds(queued)) << "each submission claimed once, none left";
}

// --- What the server has seen of each node ------------------------------------------------

TYPED_TEST(VersionStoreConformance, SubmissionNodesTellWhichSubmissionsCarriedANode) {
  const Submission first = Header(Uuid::Generate(), 10), second = Header(Uuid::Generate(), 20);
  const Uuid shared = Uuid::Generate(), only_first = Uuid::Generate();
  for (const Submission& s : {second, first}) this->versions().BeginSubmission(s);
  this->versions().PutSubmissionNodes(first.id, {shared, only_first});
  this->versions().PutSubmissionNodes(second.id, {shared});
  this->versions().PutSubmissionNodes(second.id, {shared});  // a repeat is a no-op
  EXPECT_EQ(Ids(this->versions().SubmissionsWithNode(shared)),
            (std::vector<Uuid>{first.id, second.id}));
  EXPECT_EQ(Ids(this->versions().SubmissionsWithNode(only_first)), std::vector<Uuid>{first.id});
  EXPECT_TRUE(this->versions().SubmissionsWithNode(Uuid::Generate()).empty());
  ExpectError(ErrorCode::kNotFound,
              [&] { this->versions().PutSubmissionNodes(Uuid::Generate(), {shared}); });
}

TYPED_TEST(VersionStoreConformance, StandInsAreKeptWithTheirPoseAndFirstOneWins) {
  const GraphBatch map = StampedChain(2, 100);
  this->Commit(map);
  const Uuid omitted = Uuid::Generate();
  Se3 pose = Se3FromTranslationQuaternion(Eigen::Vector3d(1.5, -2.0, 0.25),
                                          Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized());
  const NodeStandIn stand_in{omitted, map.nodes[0].id, pose, 1};
  {
    auto txn = this->store_->Begin();
    this->versions().PutStandIns({stand_in});
    txn.Commit();
  }
  EXPECT_EQ(this->versions().FindStandIn(omitted), stand_in);
  // A later merge cannot move it: edges already carried onto the first stand-in stay right.
  this->versions().PutStandIns({NodeStandIn{omitted, map.nodes[1].id, Se3::Identity(), 1}});
  EXPECT_EQ(this->versions().FindStandIn(omitted), stand_in);
  EXPECT_EQ(this->versions().FindStandIn(Uuid::Generate()), std::nullopt);
}

TYPED_TEST(VersionStoreConformance, StandInsOfARevisionAreListedByOmittedNode) {
  const GraphBatch map = StampedChain(2, 100);
  this->Commit(map);
  std::vector<NodeStandIn> stand_ins;
  for (int i = 0; i < 3; ++i) {
    stand_ins.push_back(NodeStandIn{
        Uuid::Generate(), map.nodes[i % 2].id,
        Se3FromTranslationQuaternion(Eigen::Vector3d(i, 0.5, -1.0), Eigen::Quaterniond::Identity()),
        1});
  }
  {
    auto txn = this->store_->Begin();
    this->versions().PutStandIns(stand_ins);
    txn.Commit();
  }
  std::sort(stand_ins.begin(), stand_ins.end(),
            [](const NodeStandIn& a, const NodeStandIn& b) { return a.node < b.node; });
  EXPECT_EQ(this->versions().StandInsOf(1), stand_ins);
  EXPECT_TRUE(this->versions().StandInsOf(2).empty());
  EXPECT_TRUE(this->versions().StandInsOf(0).empty());
}

// --- Appending revisions ------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, AppendRevisionRecordsWhatItAdds) {
  GraphBatch additions = StampedChain(3, 100);
  const Path path = MakePath(10);
  additions.paths.push_back(path);
  additions.edges.push_back(PathEdge(additions.nodes[0].id, additions.nodes[2].id, path.id));
  additions.nodes.push_back(additions.nodes[1]);  // a repeat counts once, as Put stores it once
  additions.annotations.push_back(
      Annotation{Uuid::Generate(), AnnotationTarget::kNode, additions.nodes[0].id, {}, "t", "p"});

  Revision asked = Merge(1, R"({"segments": 2})");
  asked.nodes_added = 77;  // counts come from the additions, not from the caller
  asked.edges_hidden = 5;
  auto txn = this->store_->Begin();
  const Revision recorded = this->versions().AppendRevision(asked, additions);
  this->store_->Put(additions);
  txn.Commit();

  Revision expected = asked;
  expected.nodes_added = 3;
  expected.edges_added = 3;
  expected.paths_added = 1;
  expected.edges_hidden = 0;
  EXPECT_EQ(recorded, expected);
  EXPECT_EQ(this->versions().FindRevision(1), expected);
  EXPECT_EQ(this->versions().ListRevisions(), std::vector<Revision>{expected});
  EXPECT_EQ(this->versions().HeadRevision(), 1);
  for (const Uuid& id : {additions.nodes[0].id, additions.edges[2].id, path.id}) {
    EXPECT_EQ(this->versions().VersionOf(id), (ElementVersion{1, std::nullopt}));
  }
  EXPECT_EQ(this->versions().VersionOf(additions.annotations[0].id), std::nullopt)
      << "annotations are not versioned";
}

TYPED_TEST(VersionStoreConformance, AppendRevisionWithStaleNumberIsConflict) {
  this->Commit(StampedChain(2, 0));
  auto txn = this->store_->Begin();
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevision(Merge(1), StampedChain(2, 10)); },
      "revision 1");
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevision(Merge(3), StampedChain(2, 10)); },
      "revision 3");
  ExpectError(ErrorCode::kConflict,
              [&] { this->versions().AppendRevision(Merge(0), StampedChain(2, 10)); });
  txn.Rollback();
  EXPECT_EQ(this->versions().HeadRevision(), 1);
  EXPECT_EQ(this->versions().ListRevisions().size(), 1u);
}

TYPED_TEST(VersionStoreConformance, AppendRevisionNeedsATransactionAndAMerge) {
  const GraphBatch additions = StampedChain(2, 0);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->versions().AppendRevision(Merge(1), additions); },
      "Transaction");
  EXPECT_EQ(this->versions().HeadRevision(), 0);
  EXPECT_EQ(this->versions().VersionOf(additions.nodes[0].id), std::nullopt);

  auto txn = this->store_->Begin();
  Revision revert = Merge(1);
  revert.kind = RevisionKind::kRevert;
  ExpectError(ErrorCode::kInvalidArgument,
              [&] { this->versions().AppendRevision(revert, additions); });
  txn.Rollback();
  EXPECT_EQ(this->versions().HeadRevision(), 0);
}

TYPED_TEST(VersionStoreConformance, AppendRevisionRefusesAnElementAlreadyStored) {
  const GraphBatch old = StampedChain(2, 0);
  this->store_->Put(old);
  const Node fresh = MakeNode(Uuid::Generate(), Uuid::Generate(), 50);
  for (const GraphBatch& additions :
       {GraphBatch{{}, {fresh, old.nodes[1]}, {}, {}},
        GraphBatch{{}, {fresh}, {old.edges[0], UnitMetricEdge(fresh.id, old.nodes[0].id)}, {}}}) {
    const Uuid& stored = additions.edges.empty() ? old.nodes[1].id : old.edges[0].id;
    {
      auto txn = this->store_->Begin();
      ExpectError(
          ErrorCode::kConflict, [&] { this->versions().AppendRevision(Merge(1), additions); },
          stored.ToString());
    }  // rolled back
    EXPECT_EQ(this->versions().HeadRevision(), 0);
    EXPECT_TRUE(this->versions().ListRevisions().empty());
    EXPECT_EQ(this->store_->FindNode(fresh.id), std::nullopt);
    EXPECT_EQ(this->versions().VersionOf(stored), (ElementVersion{0, std::nullopt}));
  }
  // Putting first and appending after is the same mistake: the additions are stored by then.
  auto txn = this->store_->Begin();
  const GraphBatch late = StampedChain(2, 60);
  this->store_->Put(late);
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevision(Merge(1), late); },
      "already stored");
}

TYPED_TEST(VersionStoreConformance, RolledBackRevisionLeavesHeadAndMapUnchanged) {
  const GraphBatch base = StampedChain(2, 0);
  this->store_->Put(base);
  const StoreStats before = this->versions().StatsAt(0);
  const GraphBatch additions = StampedChain(4, 10);
  {
    auto txn = this->store_->Begin();
    EXPECT_EQ(this->versions().AppendRevision(Merge(1), additions).number, 1);
    this->store_->Put(additions);
    EXPECT_EQ(this->versions().HeadRevision(), 1);  // visible inside the transaction
    EXPECT_EQ(this->versions().NodesAt(1).size(), 6u);
    txn.Rollback();
  }
  EXPECT_EQ(this->versions().HeadRevision(), 0);
  EXPECT_EQ(this->versions().FindRevision(1), std::nullopt);
  EXPECT_EQ(this->store_->FindNode(additions.nodes[0].id), std::nullopt);
  EXPECT_EQ(this->versions().VersionOf(additions.nodes[0].id), std::nullopt);
  EXPECT_EQ(Fields(this->versions().StatsAt(0)), Fields(before));
  ExpectError(ErrorCode::kNotFound, [&] { this->versions().NodesAt(1); });
  // Number 1 is free again.
  EXPECT_EQ(this->Commit(additions).number, 1);
  EXPECT_EQ(this->versions().NodesAt(1).size(), 6u);
}

TYPED_TEST(VersionStoreConformance, TwoWritersRacingForOneNumberMakeOneRevision) {
  auto other = GraphStore::Open(this->backend_->Uri());
  const GraphBatch mine = StampedChain(3, 0), theirs = StampedChain(3, 10);
  auto txn = this->store_->Begin();
  this->versions().AppendRevision(Merge(1), mine);
  this->store_->Put(mine);
  std::optional<ErrorCode> their_error;
  std::thread writer([&] {
    try {
      auto their_txn = other->Begin();                     // SQLite: waits for our write lock
      other->versions().AppendRevision(Merge(1), theirs);  // PostgreSQL: waits for our row
      other->Put(theirs);
      their_txn.Commit();
    } catch (const Error& e) {
      their_error = e.code();
    }
  });
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  txn.Commit();
  writer.join();
  EXPECT_EQ(their_error, ErrorCode::kConflict);
  EXPECT_EQ(this->versions().ListRevisions().size(), 1u);
  EXPECT_EQ(SortedIds(this->versions().NodesAt(1)), SortedIds(mine.nodes));
  EXPECT_EQ(other->FindNode(theirs.nodes[0].id), std::nullopt);
}

// Seed 004 §V-A: MERGE adds whole submissions; a revision must stay cheap to check and to
// record however many elements it adds (one set-wise check on PostgreSQL).
TYPED_TEST(VersionStoreConformance, LargeRevisionIsCheckedAndRecordedWhole) {
  constexpr int kNodes = 100000;
  const GraphBatch first = StampedChain(kNodes, 0);
  const auto start = std::chrono::steady_clock::now();
  const Revision r1 = this->Commit(first);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  this->RecordProperty("append_and_put_seconds", std::to_string(seconds));
  EXPECT_EQ(r1.nodes_added, kNodes);
  EXPECT_EQ(r1.edges_added, kNodes - 1);
  EXPECT_LT(seconds, 120.0);

  // One stored node among many new ones is found and named.
  GraphBatch second = StampedChain(kNodes, kNodes);
  second.nodes[kNodes / 2] = first.nodes[kNodes / 3];
  second.edges.clear();
  auto txn = this->store_->Begin();
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevision(Merge(2), second); },
      first.nodes[kNodes / 3].id.ToString());
  txn.Rollback();
  const StoreStats at1 = this->versions().StatsAt(1);
  EXPECT_EQ(at1.nodes, kNodes);
  EXPECT_EQ(at1.edges, kNodes - 1);
  EXPECT_EQ(this->versions().StatsAt(0).nodes, 0);
}

// --- The map at a revision ----------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, MapAtEachRevision) {
  const History h = this->MakeHistory();
  const std::vector<Node>& base = h.base.nodes;
  const std::vector<Edge>& base_edges = h.base.edges;

  // Revision 0: the base chain, and e0: Put outside version control (after revision 1), it
  // counts as revision 0 like everything else outside, although its end n1 is not there yet.
  EXPECT_EQ(Ids(this->versions().NodesAt(0)), Ids(base));
  EXPECT_EQ(SortedIds(this->versions().EdgesAt(0)),
            Sorted({base_edges[0].id, base_edges[1].id, h.e0.id}));
  EXPECT_TRUE(this->versions().PathsAt(0).empty());

  // Revision 1 adds n1, n2 (stamps 200, 201: after the base).
  std::vector<Node> at1 = base;
  at1.push_back(h.n1);
  at1.push_back(h.n2);
  EXPECT_EQ(this->versions().NodesAt(1), at1);
  EXPECT_EQ(Ids(this->versions().EdgesAt(1)),
            Sorted({base_edges[0].id, base_edges[1].id, h.e0.id, h.e12.id, h.eb.id, h.pe.id}));
  EXPECT_EQ(this->versions().PathsAt(1), std::vector<Path>{h.p});

  // Revision 2 adds n3 (stamp 150: ordered between the base and n1).
  EXPECT_EQ(Ids(this->versions().NodesAt(2)),
            (std::vector<Uuid>{base[0].id, base[1].id, base[2].id, h.n3.id, h.n1.id, h.n2.id}));
  EXPECT_EQ(this->versions().EdgesAt(2).size(), 9u);
  const std::vector<Node> bare = this->versions().NodesAt(2, /*with_landmarks=*/false);
  ASSERT_EQ(bare.size(), 6u);
  EXPECT_TRUE(std::all_of(bare.begin(), bare.end(),
                          [](const Node& n) { return n.landmarks_blob.empty(); }));

  // Edges come back whole.
  const std::vector<Edge> edges = this->versions().EdgesAt(2);
  const auto pe2 =
      std::find_if(edges.begin(), edges.end(), [&](const Edge& e) { return e.id == h.pe2.id; });
  ASSERT_NE(pe2, edges.end());
  EXPECT_TRUE(SameEdgeContent(*pe2, h.pe2));

  const StoreStats s0 = this->versions().StatsAt(0), s2 = this->versions().StatsAt(2);
  EXPECT_EQ(s0.nodes, 3);
  EXPECT_EQ(s0.edges, 3);
  EXPECT_EQ(s0.paths, 0);
  EXPECT_EQ(s0.landmark_bytes, 9);  // "lm0" "lm1" "lm2"
  EXPECT_EQ(s2.nodes, 6);
  EXPECT_EQ(s2.edges, 9);
  EXPECT_EQ(s2.paths, 1);
  EXPECT_EQ(s2.landmark_bytes, 9 + 12 + 2 + 2);
  EXPECT_EQ(this->versions().StatsAt(1).nodes, 5);

  for (RevisionNumber bad : {RevisionNumber{-1}, RevisionNumber{3}}) {
    const std::string name = "revision " + std::to_string(bad);
    ExpectError(
        ErrorCode::kNotFound, [&] { this->versions().NodesAt(bad); }, name);
    ExpectError(
        ErrorCode::kNotFound, [&] { this->versions().EdgesAt(bad); }, name);
    ExpectError(
        ErrorCode::kNotFound, [&] { this->versions().PathsAt(bad); }, name);
    ExpectError(
        ErrorCode::kNotFound, [&] { this->versions().StatsAt(bad); }, name);
    ExpectError(
        ErrorCode::kNotFound, [&] { this->versions().Changes(0, bad); }, name);
  }
}

// A checkout gives each edge's covariance bit for bit, and none to an edge that had none.
TYPED_TEST(VersionStoreConformance, CheckoutKeepsEdgeCovariances) {
  GraphBatch old = StampedChain(3, 0);
  old.edges[0].covariance = SomeCovariance(0.25);
  this->store_->Put(old);
  GraphBatch added = StampedChain(4, 10);
  added.edges[1].covariance = SomeCovariance(4.5);
  const RevisionNumber r1 = this->Commit(added).number;
  std::map<Uuid, Edge> want;
  for (const GraphBatch* batch : {&old, &added}) {
    for (const Edge& edge : batch->edges) want.emplace(edge.id, edge);
  }
  for (const RevisionNumber r : {RevisionNumber{0}, r1}) {
    const std::vector<Edge> edges = this->versions().EdgesAt(r);
    EXPECT_EQ(edges.size(), r == 0 ? 2u : 5u);
    for (const Edge& edge : edges) {
      ASSERT_TRUE(want.contains(edge.id));
      const Edge& put = want.at(edge.id);
      ASSERT_EQ(edge.covariance.has_value(), put.covariance.has_value()) << edge.id.ToString();
      if (put.covariance) {
        EXPECT_TRUE(*edge.covariance == *put.covariance) << edge.id.ToString();
      }
    }
  }
}

// --- Reverts ------------------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, RevertHidesAdditionsAndEveryEdgeLeftDangling) {
  const History h = this->MakeHistory();
  const Revision r3 = this->Revert(1);

  EXPECT_EQ(r3.number, 3);
  EXPECT_EQ(r3.kind, RevisionKind::kRevert);
  EXPECT_EQ(r3.reverted, 1);
  EXPECT_EQ(r3.submission, Uuid());
  EXPECT_EQ(r3.nodes_hidden, 2);  // n1, n2
  EXPECT_EQ(r3.paths_hidden, 1);  // p
  // r1's e12, eb, pe; r2's e23 (touches n2) and pe2 (on p); revision 0's e0 (touches n1).
  EXPECT_EQ(r3.edges_hidden, 6);
  EXPECT_EQ(r3.nodes_added + r3.edges_added + r3.paths_added, 0);
  EXPECT_EQ(this->versions().FindRevision(3), r3);
  EXPECT_EQ(this->versions().HeadRevision(), 3);

  const std::vector<Node> nodes = this->versions().NodesAt(3);
  EXPECT_EQ(SortedIds(nodes),
            Sorted({h.base.nodes[0].id, h.base.nodes[1].id, h.base.nodes[2].id, h.n3.id}));
  const std::vector<Edge> edges = this->versions().EdgesAt(3);
  EXPECT_EQ(Ids(edges), Sorted({h.base.edges[0].id, h.base.edges[1].id, h.eb12.id}));
  EXPECT_TRUE(this->versions().PathsAt(3).empty());
  // No dangling edge: every end is a visible node.
  std::set<Uuid> visible;
  for (const Node& n : nodes) visible.insert(n.id);
  for (const Edge& e : edges) {
    EXPECT_TRUE(visible.count(e.from) && visible.count(e.to)) << e.id.ToString();
  }

  EXPECT_EQ(this->versions().VersionOf(h.n1.id), (ElementVersion{1, 3}));
  EXPECT_EQ(this->versions().VersionOf(h.e23.id), (ElementVersion{2, 3}));
  EXPECT_EQ(this->versions().VersionOf(h.e0.id), (ElementVersion{0, 3}));
  EXPECT_EQ(this->versions().VersionOf(h.n3.id), (ElementVersion{2, std::nullopt}));
  EXPECT_EQ(this->versions().VersionOf(h.base.edges[0].id), (ElementVersion{0, std::nullopt}));
  // Hiding deletes nothing.
  EXPECT_EQ(this->store_->GetNode(h.n1.id), h.n1);
  EXPECT_EQ(this->store_->Stats().edges, 9);
}

TYPED_TEST(VersionStoreConformance, CheckoutBeforeARevertStillShowsTheOldMap) {
  const History h = this->MakeHistory();
  const std::vector<Node> nodes2 = this->versions().NodesAt(2);
  const std::vector<Uuid> edges2 = Ids(this->versions().EdgesAt(2));
  const std::vector<Path> paths2 = this->versions().PathsAt(2);
  const StoreStats stats2 = this->versions().StatsAt(2), stats1 = this->versions().StatsAt(1);
  this->Revert(1);
  this->Commit(StampedChain(2, 500));  // and the history goes on
  EXPECT_EQ(this->versions().NodesAt(2), nodes2);
  EXPECT_EQ(Ids(this->versions().EdgesAt(2)), edges2);
  EXPECT_EQ(this->versions().PathsAt(2), paths2);
  EXPECT_EQ(Fields(this->versions().StatsAt(2)), Fields(stats2));
  EXPECT_EQ(Fields(this->versions().StatsAt(1)), Fields(stats1));
  EXPECT_EQ(this->versions().StatsAt(3).nodes, 4);
  EXPECT_EQ(this->versions().StatsAt(4).nodes, 6);
  // Reverting the later revision 2 still works and hides only what is still visible.
  const Revision r5 = this->Revert(2);
  EXPECT_EQ(r5.nodes_hidden, 1);  // n3
  EXPECT_EQ(r5.edges_hidden, 1);  // eb12 (e23 and pe2 are hidden by revision 3 already)
  EXPECT_EQ(this->versions().VersionOf(h.e23.id), (ElementVersion{2, 3}));
  EXPECT_EQ(this->versions().NodesAt(2), nodes2);
}

TYPED_TEST(VersionStoreConformance, RevertRefusesWhatCannotBeReverted) {
  this->MakeHistory();
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->versions().AppendRevert(RevertOf(3, 0)); },
      "revision 0");
  ExpectError(
      ErrorCode::kNotFound, [&] { this->versions().AppendRevert(RevertOf(3, 9)); }, "revision 9");
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevert(RevertOf(2, 1)); }, "revision 2");
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevert(RevertOf(5, 1)); }, "revision 5");
  EXPECT_EQ(this->versions().HeadRevision(), 2);

  this->Revert(1);
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRevert(RevertOf(4, 1)); }, "revision 1");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->versions().AppendRevert(RevertOf(4, 3)); },
      "revision 3");
  EXPECT_EQ(this->versions().HeadRevision(), 3);
  EXPECT_EQ(this->versions().ListRevisions().size(), 3u);
}

TYPED_TEST(VersionStoreConformance, RevertInsideARolledBackTransactionLeavesNoTrace) {
  const History h = this->MakeHistory();
  {
    auto txn = this->store_->Begin();
    EXPECT_EQ(this->Revert(1).nodes_hidden, 2);
    EXPECT_EQ(this->versions().VersionOf(h.n1.id), (ElementVersion{1, 3}));
  }
  EXPECT_EQ(this->versions().HeadRevision(), 2);
  EXPECT_EQ(this->versions().VersionOf(h.n1.id), (ElementVersion{1, std::nullopt}));
  EXPECT_EQ(this->versions().VersionOf(h.e0.id), (ElementVersion{0, std::nullopt}));
  EXPECT_EQ(this->versions().EdgesAt(2).size(), 9u);
  EXPECT_EQ(this->Revert(1).number, 3);  // and it can be done for real afterwards
}

// --- Changes and versions of elements -----------------------------------------------------

TYPED_TEST(VersionStoreConformance, ChangesInBothDirections) {
  const History h = this->MakeHistory();
  this->Revert(1);

  const RevisionChanges up = this->versions().Changes(0, 2);
  EXPECT_EQ(up.from, 0);
  EXPECT_EQ(up.to, 2);
  EXPECT_EQ(up.nodes_added, Sorted({h.n1.id, h.n2.id, h.n3.id}));
  EXPECT_EQ(up.edges_added, Sorted({h.e12.id, h.eb.id, h.pe.id, h.e23.id, h.eb12.id, h.pe2.id}));
  EXPECT_EQ(up.paths_added, std::vector<Uuid>{h.p.id});
  EXPECT_TRUE(up.nodes_removed.empty() && up.edges_removed.empty() && up.paths_removed.empty());

  const RevisionChanges down = this->versions().Changes(2, 0);
  EXPECT_EQ(down.from, 2);
  EXPECT_EQ(down.to, 0);
  EXPECT_EQ(down.nodes_removed, up.nodes_added);
  EXPECT_EQ(down.edges_removed, up.edges_added);
  EXPECT_EQ(down.paths_removed, up.paths_added);
  EXPECT_TRUE(down.nodes_added.empty() && down.edges_added.empty() && down.paths_added.empty());

  // The revert removes r1's additions, the edges they left dangling and the revision-0 e0.
  const RevisionChanges revert = this->versions().Changes(2, 3);
  EXPECT_EQ(revert.nodes_removed, Sorted({h.n1.id, h.n2.id}));
  EXPECT_EQ(revert.edges_removed,
            Sorted({h.e12.id, h.eb.id, h.pe.id, h.e23.id, h.pe2.id, h.e0.id}));
  EXPECT_EQ(revert.paths_removed, std::vector<Uuid>{h.p.id});
  EXPECT_TRUE(revert.nodes_added.empty() && revert.edges_added.empty());

  // From before revision 1 to after its revert: only revision 2's survivors were added, and
  // e0, visible at 0, is gone.
  const RevisionChanges across = this->versions().Changes(0, 3);
  EXPECT_EQ(across.nodes_added, std::vector<Uuid>{h.n3.id});
  EXPECT_EQ(across.edges_added, std::vector<Uuid>{h.eb12.id});
  EXPECT_TRUE(across.paths_added.empty());
  EXPECT_EQ(across.edges_removed, std::vector<Uuid>{h.e0.id});
  EXPECT_TRUE(across.nodes_removed.empty());

  const RevisionChanges none = this->versions().Changes(2, 2);
  EXPECT_TRUE(none.nodes_added.empty() && none.edges_added.empty() && none.paths_added.empty() &&
              none.nodes_removed.empty() && none.edges_removed.empty() &&
              none.paths_removed.empty());
}

TYPED_TEST(VersionStoreConformance, VersionOfUnknownAndUnversionedElements) {
  EXPECT_EQ(this->versions().VersionOf(Uuid::Generate()), std::nullopt);
  const GraphBatch plain = StampedChain(2, 0);
  this->store_->Put(plain);
  const Path path = MakePath(0);
  this->store_->PutPath(path);
  for (const Uuid& id : {plain.nodes[0].id, plain.edges[0].id, path.id}) {
    EXPECT_EQ(this->versions().VersionOf(id), (ElementVersion{0, std::nullopt}));
  }
  const GraphBatch versioned = StampedChain(2, 10);
  this->Commit(versioned);
  EXPECT_EQ(this->versions().VersionOf(versioned.edges[0].id), (ElementVersion{1, std::nullopt}));
}

// --- Retirements (experiences nobody uses, hidden so that a revert restores them) -----------

Revision Retirement(RevisionNumber number) {
  Revision r;
  r.number = number;
  r.created_ns = 8000 + number;
  r.author = "depot";
  r.kind = RevisionKind::kRetire;
  r.report = "{\"retired\": []}";
  return r;
}

TYPED_TEST(VersionStoreConformance, RetirementHidesAndItsRevertRestoresExactly) {
  const History h = this->MakeHistory();
  const std::vector<Node> before_nodes = this->versions().NodesAt(2);
  const std::vector<Edge> before_edges = this->versions().EdgesAt(2);
  const Revision r3 = this->versions().AppendRetirement(Retirement(3), {h.n2.id});
  EXPECT_EQ(r3.kind, RevisionKind::kRetire);
  EXPECT_EQ(RevisionKindName(r3.kind), "retire");
  EXPECT_EQ(r3.nodes_hidden, 1);
  EXPECT_EQ(r3.edges_hidden, 2);  // e12 and e23
  EXPECT_EQ(r3.nodes_added, 0);
  EXPECT_EQ(this->versions().FindRevision(3), r3);
  std::set<Uuid> visible;
  for (const Node& n : this->versions().NodesAt(3)) visible.insert(n.id);
  EXPECT_FALSE(visible.contains(h.n2.id));
  EXPECT_EQ(visible.size(), before_nodes.size() - 1);
  for (const Edge& e : this->versions().EdgesAt(3)) {
    EXPECT_TRUE(visible.count(e.from) && visible.count(e.to)) << e.id.ToString();
  }
  EXPECT_EQ(this->versions().StatsAt(3).nodes, static_cast<std::int64_t>(visible.size()));
  EXPECT_EQ(this->versions().StatsAt(3).edges, static_cast<std::int64_t>(before_edges.size()) - 2);
  // The past is untouched, and the change reads as a removal.
  EXPECT_EQ(this->versions().NodesAt(2), before_nodes);
  const RevisionChanges retired = this->versions().Changes(2, 3);
  EXPECT_EQ(retired.nodes_removed, std::vector<Uuid>{h.n2.id});
  EXPECT_EQ(retired.edges_removed, Sorted({h.e12.id, h.e23.id}));
  EXPECT_TRUE(retired.nodes_added.empty());
  EXPECT_EQ(this->versions().VersionOf(h.n2.id), (ElementVersion{1, 3}));

  const Revision r4 = this->Revert(3);
  EXPECT_EQ(r4.nodes_added, 1);
  EXPECT_EQ(r4.edges_added, 2);
  EXPECT_EQ(r4.nodes_hidden, 0);
  EXPECT_EQ(this->versions().FindRevision(4), r4);
  // Restored whole: the same nodes with the same landmarks, the same edges.
  EXPECT_EQ(this->versions().NodesAt(4), before_nodes);
  EXPECT_EQ(SortedIds(this->versions().EdgesAt(4)), SortedIds(before_edges));
  EXPECT_EQ(this->versions().NodesAt(3).size(), before_nodes.size() - 1);
  EXPECT_EQ(this->versions().Changes(3, 4).nodes_added, std::vector<Uuid>{h.n2.id});
  const RevisionChanges none = this->versions().Changes(2, 4);
  EXPECT_TRUE(none.nodes_added.empty() && none.nodes_removed.empty() && none.edges_added.empty() &&
              none.edges_removed.empty());
  EXPECT_EQ(this->versions().VersionOf(h.n2.id), (ElementVersion{1, std::nullopt}));
  ExpectError(
      ErrorCode::kConflict, [&] { this->Revert(3); }, "already reverted");

  // Retired again later, and that too checks out at each revision.
  const Revision r5 = this->versions().AppendRetirement(Retirement(5), {h.n2.id, h.n3.id});
  EXPECT_EQ(r5.nodes_hidden, 2);
  EXPECT_EQ(this->versions().NodesAt(4), before_nodes);
  EXPECT_EQ(this->versions().NodesAt(5).size(), before_nodes.size() - 2);
  EXPECT_EQ(this->versions().Changes(3, 5).nodes_removed, std::vector<Uuid>{h.n3.id});
}

TYPED_TEST(VersionStoreConformance, RetirementTakesOnlyWhatTheHeadShows) {
  const History h = this->MakeHistory();
  this->Revert(2);  // hides n3 and e23
  // n3 is hidden already and an unknown id is nothing: only n2 is retired.
  const Revision r4 =
      this->versions().AppendRetirement(Retirement(4), {h.n2.id, h.n3.id, Uuid::Generate()});
  EXPECT_EQ(r4.nodes_hidden, 1);
  EXPECT_EQ(r4.edges_hidden, 1);  // e12: e23 went with revision 2's revert
  // A revert of the merge that added n1 and n2 while n2 is retired: restoring the retirement
  // later does not bring n2 back, for the merge's revert hid it too.
  const Revision r5 = this->Revert(1);
  EXPECT_GE(r5.nodes_hidden, 1);
  const Revision r6 = this->Revert(4);
  EXPECT_EQ(r6.nodes_added, 0);
  std::set<Uuid> visible;
  for (const Node& n : this->versions().NodesAt(6)) visible.insert(n.id);
  EXPECT_FALSE(visible.contains(h.n1.id) || visible.contains(h.n2.id) || visible.contains(h.n3.id));
  EXPECT_EQ(this->versions().NodesAt(6), this->versions().NodesAt(5));
}

TYPED_TEST(VersionStoreConformance, RetirementRefusesOtherKindsAndStaleHeads) {
  this->MakeHistory();
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->versions().AppendRetirement(Merge(3), {}); },
      "retirements only");
  ExpectError(
      ErrorCode::kConflict, [&] { this->versions().AppendRetirement(Retirement(2), {}); },
      "the head is 2");
  EXPECT_EQ(this->versions().HeadRevision(), 2);
}

TYPED_TEST(VersionStoreConformance, NodeUsageSumsFramesAndKeepsTheNewestUse) {
  const History h = this->MakeHistory();
  this->versions().PutNodeUsage(1, {{h.n1.id, 4, 1000, UsageSource::kReplay}});
  this->versions().PutNodeUsage(
      2, {{h.n1.id, 2, 900, UsageSource::kReplay}, {h.n2.id, 1, 3000, UsageSource::kReplay}});
  // A repeat replaces what that revision measured.
  this->versions().PutNodeUsage(2, {{h.n1.id, 3, 950, UsageSource::kReplay}});
  EXPECT_EQ(this->versions().UsageAt(1),
            (std::vector<NodeUsage>{{h.n1.id, 4, 1000, UsageSource::kReplay}}));
  std::vector<NodeUsage> expected{{h.n1.id, 7, 1000, UsageSource::kReplay},
                                  {h.n2.id, 1, 3000, UsageSource::kReplay}};
  std::sort(expected.begin(), expected.end(),
            [](const NodeUsage& a, const NodeUsage& b) { return a.node < b.node; });
  EXPECT_EQ(this->versions().UsageAt(2), expected);
  EXPECT_TRUE(this->versions().UsageAt(0).empty());
  ExpectError(ErrorCode::kInvalidArgument, [&] {
    this->versions().PutNodeUsage(2, {{h.n3.id, -1, 5, UsageSource::kReplay}});
  });
  ExpectError(ErrorCode::kNotFound, [&] { this->versions().UsageAt(3); });
}

// --- Promotions (a dream's candidate made the map) ----------------------------------------

Revision Promotion(RevisionNumber number) {
  Revision r;
  r.number = number;
  r.created_ns = 7000 + number;
  r.author = "operator";
  r.kind = RevisionKind::kPromote;
  r.report = "{\"candidate\": \"c\"}";
  return r;
}

TYPED_TEST(VersionStoreConformance, PromotionAddsHidesAndLeavesNoDanglingEdge) {
  const History h = this->MakeHistory();
  // The candidate kept n1 but not n2 or n3, and placed a node of its own after n1.
  const Node n4 = MakeNode(h.n1.robot, h.n1.outing, 300, "n4");
  const Edge e14 = UnitMetricEdge(h.n1.id, n4.id);
  const GraphBatch additions{{}, {n4}, {e14}, {}};
  Revision r3;
  {
    auto txn = this->store_->Begin();
    r3 = this->versions().AppendPromotion(Promotion(3), additions, {h.n2.id, h.n3.id});
    this->store_->Put(additions);
    txn.Commit();
  }
  EXPECT_EQ(r3.kind, RevisionKind::kPromote);
  EXPECT_EQ(RevisionKindName(r3.kind), "promote");
  EXPECT_EQ(r3.nodes_added, 1);
  EXPECT_EQ(r3.edges_added, 1);
  EXPECT_EQ(r3.nodes_hidden, 2);
  EXPECT_EQ(r3.edges_hidden, 2);  // e12 (n1 -> n2) and e23 (n2 -> n3)
  EXPECT_EQ(this->versions().FindRevision(3), r3);
  EXPECT_EQ(SortedIds(this->versions().NodesAt(3)),
            Sorted({h.base.nodes[0].id, h.base.nodes[1].id, h.base.nodes[2].id, h.n1.id, n4.id}));
  std::set<Uuid> visible;
  for (const Node& n : this->versions().NodesAt(3)) visible.insert(n.id);
  for (const Edge& e : this->versions().EdgesAt(3)) {
    EXPECT_TRUE(visible.count(e.from) && visible.count(e.to)) << e.id.ToString();
  }
  // Earlier revisions check out as before; hiding deletes nothing.
  EXPECT_EQ(SortedIds(this->versions().NodesAt(2)),
            Sorted({h.base.nodes[0].id, h.base.nodes[1].id, h.base.nodes[2].id, h.n1.id, h.n2.id,
                    h.n3.id}));
  EXPECT_EQ(this->versions().VersionOf(h.n2.id), (ElementVersion{1, 3}));
  EXPECT_EQ(this->store_->GetNode(h.n3.id), h.n3);
  const RevisionChanges changes = this->versions().Changes(2, 3);
  EXPECT_EQ(changes.nodes_added, std::vector<Uuid>{n4.id});
  EXPECT_EQ(changes.nodes_removed, Sorted({h.n2.id, h.n3.id}));
}

TYPED_TEST(VersionStoreConformance, PromotionRefusesWhatItCannotRecord) {
  const History h = this->MakeHistory();
  const GraphBatch additions = StampedChain(2, 400);
  {
    auto txn = this->store_->Begin();
    // Another kind, a stale number, a node both added and hidden, an element already stored.
    ExpectError(
        ErrorCode::kInvalidArgument,
        [&] { this->versions().AppendPromotion(Merge(3), additions, {}); }, "promotions only");
    ExpectError(
        ErrorCode::kConflict,
        [&] { this->versions().AppendPromotion(Promotion(2), additions, {}); }, "the head is 2");
    ExpectError(
        ErrorCode::kInvalidArgument,
        [&] { this->versions().AppendPromotion(Promotion(3), additions, {additions.nodes[0].id}); },
        "both added and hidden");
    ExpectError(
        ErrorCode::kConflict,
        [&] {
          this->versions().AppendPromotion(Promotion(3), GraphBatch{{}, {h.n1}, {}, {}}, {});
        },
        "already stored");
  }
  // Outside a transaction, nothing is recorded.
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { this->versions().AppendPromotion(Promotion(3), additions, {}); }, "Transaction");
  EXPECT_EQ(this->versions().HeadRevision(), 2);
  EXPECT_EQ(this->versions().VersionOf(h.n2.id), (ElementVersion{1, std::nullopt}));
}

// A schema-6 store (before promotions and edge covariances) keeps its history, stand-ins and
// reverts through the migrations, and can then record a promotion.
TYPED_TEST(VersionStoreConformance, SchemaSixStoreMigratesWithItsHistoryIntact) {
  const History h = this->MakeHistory();
  const NodeStandIn stand_in{Uuid::Generate(), h.n1.id, Se3::Identity(), 1};
  {
    auto txn = this->store_->Begin();
    this->versions().PutStandIns({stand_in});
    txn.Commit();
  }
  this->Revert(2);
  const std::vector<Revision> revisions = this->versions().ListRevisions();
  this->store_.reset();
  this->backend_->ExecRaw(
      "DROP TABLE retirements; DROP TABLE node_usage; ALTER TABLE edges DROP COLUMN covariance;"
      " UPDATE fleetmap_schema SET version = 6");
  this->store_ = GraphStore::Open(this->backend_->Uri());
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_EQ(this->versions().ListRevisions(), revisions);
  EXPECT_EQ(this->versions().FindStandIn(stand_in.node), stand_in);
  // The revert is still recorded as one: reverting it again is refused.
  ExpectError(
      ErrorCode::kConflict, [&] { this->Revert(2); }, "already reverted");
  auto txn = this->store_->Begin();
  EXPECT_EQ(this->versions().AppendPromotion(Promotion(4), StampedChain(1, 900), {h.n1.id}).number,
            4);
  txn.Commit();
  EXPECT_EQ(this->versions().VersionOf(h.n1.id), (ElementVersion{1, 4}));
}

// --- Settings -----------------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, SettingsPutReplaceFind) {
  EXPECT_EQ(this->versions().FindSetting("vocabulary"), std::nullopt);
  const std::string binary("\0\x01\xfe\xff words", 10);
  this->versions().PutSetting("vocabulary", binary);
  this->versions().PutSetting("other", "x");
  EXPECT_EQ(this->versions().FindSetting("vocabulary"), binary);
  this->versions().PutSetting("vocabulary", "v2");
  EXPECT_EQ(this->versions().FindSetting("vocabulary"), "v2");
  EXPECT_EQ(this->versions().FindSetting("other"), "x");
  EXPECT_EQ(this->versions().FindSetting("Vocabulary"), std::nullopt);
}

TYPED_TEST(VersionStoreConformance, ReplaceSettingWritesOnlyOverTheValueExpected) {
  VersionStore& versions = this->versions();
  EXPECT_FALSE(versions.ReplaceSetting("channel", std::string("v1"), "v2")) << "not set";
  EXPECT_EQ(versions.FindSetting("channel"), std::nullopt);
  EXPECT_TRUE(versions.ReplaceSetting("channel", std::nullopt, "v1"));
  EXPECT_FALSE(versions.ReplaceSetting("channel", std::nullopt, "v0")) << "set already";
  const std::string binary("\0\x01\xfe\xff", 4);
  EXPECT_FALSE(versions.ReplaceSetting("channel", std::string("v0"), binary));
  EXPECT_EQ(versions.FindSetting("channel"), "v1");
  EXPECT_TRUE(versions.ReplaceSetting("channel", std::string("v1"), binary));
  EXPECT_TRUE(versions.ReplaceSetting("channel", binary, "v3"));
  EXPECT_EQ(versions.FindSetting("channel"), "v3");
  // Inside a Transaction it lands, or rolls back, with it.
  {
    GraphStore::Transaction transaction = this->store_->Begin();
    EXPECT_TRUE(versions.ReplaceSetting("channel", std::string("v3"), "v4"));
    transaction.Rollback();
  }
  EXPECT_EQ(versions.FindSetting("channel"), "v3");
}

// Writers on their own connections each read a counter, then replace it with one more, again
// when another replaced it first: no increment is lost, with or without a Transaction around
// the read and the replace.
TYPED_TEST(VersionStoreConformance, ReplaceSettingLosesNoConcurrentUpdate) {
  constexpr int kWriters = 4, kIncrements = 25;
  this->versions().PutSetting("counter", "0");
  std::vector<std::string> errors(kWriters);
  std::vector<std::thread> writers;
  for (int i = 0; i < kWriters; ++i) {
    writers.emplace_back([&, i] {
      try {
        auto store = GraphStore::Open(this->backend_->Uri());
        VersionStore& versions = store->versions();
        for (int n = 0; n < kIncrements; ++n) {
          for (bool done = false; !done;) {
            const bool in_transaction = (i + n) % 2 == 0;
            std::optional<GraphStore::Transaction> transaction;
            if (in_transaction) transaction.emplace(store->Begin());
            const std::string read = *versions.FindSetting("counter");
            done = versions.ReplaceSetting("counter", read, std::to_string(std::stoi(read) + 1));
            if (transaction) transaction->Commit();
          }
        }
      } catch (const Error& e) {
        errors[i] = e.what();
      }
    });
  }
  for (std::thread& writer : writers) writer.join();
  for (int i = 0; i < kWriters; ++i) EXPECT_EQ(errors[i], "") << "writer " << i;
  EXPECT_EQ(this->versions().FindSetting("counter"), std::to_string(kWriters * kIncrements));
}

// --- Durability ---------------------------------------------------------------------------

TYPED_TEST(VersionStoreConformance, ReopenedStoreKeepsEverything) {
  const History h = this->MakeHistory();
  this->Revert(1);
  const Submission header = Header();
  this->versions().BeginSubmission(header);
  this->versions().PutSubmissionChunk(header.id, 0, std::string("\0chunk", 6));
  this->versions().CompleteSubmission(header.id, 0x8000000000000001ULL);
  this->versions().SetSubmissionState(header.id, SubmissionState::kMerged, 2, "");
  this->versions().PutSetting("vocabulary", "words");

  const std::vector<Submission> submissions = this->versions().ListSubmissions();
  const std::vector<Revision> revisions = this->versions().ListRevisions();
  std::vector<std::vector<Node>> maps;
  for (RevisionNumber r = 0; r <= 3; ++r) maps.push_back(this->versions().NodesAt(r));
  const RevisionChanges changes = this->versions().Changes(0, 3);

  this->store_.reset();
  this->store_ = GraphStore::Open(this->backend_->Uri());
  EXPECT_EQ(this->store_->schema_version(), GraphStore::LatestSchemaVersion());
  EXPECT_EQ(this->versions().ListSubmissions(), submissions);
  EXPECT_EQ(this->versions().FindSubmission(header.id)->digest, 0x8000000000000001ULL);
  EXPECT_EQ(this->versions().SubmissionChunk(header.id, 0), std::string("\0chunk", 6));
  EXPECT_EQ(this->versions().ListRevisions(), revisions);
  EXPECT_EQ(this->versions().HeadRevision(), 3);
  for (RevisionNumber r = 0; r <= 3; ++r) {
    EXPECT_EQ(this->versions().NodesAt(r), maps[static_cast<std::size_t>(r)]) << "revision " << r;
  }
  EXPECT_EQ(this->versions().Changes(0, 3).edges_removed, changes.edges_removed);
  EXPECT_EQ(this->versions().VersionOf(h.e0.id), (ElementVersion{0, 3}));
  EXPECT_EQ(this->versions().FindSetting("vocabulary"), "words");
}

}  // namespace
}  // namespace fleetmap
