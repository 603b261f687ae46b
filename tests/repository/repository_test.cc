// The central repository (seed 004 §V) on both stores: pushes kept whole, MERGE into linear
// revisions, checkout, diff, revert and download, with robot maps built by the EBN builder on
// the two-condition corridor.
#include "fleetmap/repository/repository.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "corridor_robot_map.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/store_diagnosis.h"
#include "random_robot_map.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::PostgresBackend;
using testing::SqliteBackend;
using testing::StoreBackends;

// A robot's map of the given corridor outings (0: day, 1: night).
GraphBatch RobotMap(const std::vector<int>& conditions) {
  std::vector<CorridorOuting> outings;
  for (const int condition : conditions) outings.push_back({condition});
  return CorridorRobotMap(outings);
}

std::set<Uuid> NodeIds(const GraphBatch& map) {
  std::set<Uuid> ids;
  for (const Node& node : map.nodes) ids.insert(node.id);
  return ids;
}

template <typename Backend>
class RepositoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    repository_ = Open();
  }

  std::unique_ptr<Repository> Open(bool with_vocabulary = true) {
    RepositoryOptions options;
    if (with_vocabulary) options.vocabulary = SharedCorridorVocabulary();
    return Repository::Open(backend_->Uri(), options);
  }

  // Pushes and merges a robot map; returns the new revision.
  Revision PushAndMerge(const GraphBatch& map, const Uuid& submission = Uuid::Generate()) {
    repository_->Push(submission, robot_, "robot-1", map);
    return repository_->Merge(submission).revision;
  }

  std::optional<Backend> backend_;
  std::unique_ptr<Repository> repository_;
  const Uuid robot_ = Uuid::Generate();
};

TYPED_TEST_SUITE(RepositoryTest, StoreBackends, BackendNames);

TYPED_TEST(RepositoryTest, APushIsStoredWholeAndIdempotent) {
  const GraphBatch map = RobotMap({0});
  const Uuid id = Uuid::Generate();
  const Submission stored = this->repository_->Push(id, this->robot_, "robot-1", map);
  EXPECT_EQ(stored.state, SubmissionState::kQueued);
  EXPECT_EQ(stored.author, "robot-1");
  EXPECT_GT(stored.bytes, 0);
  const GraphBatch back = this->repository_->ReadSubmission(id);
  EXPECT_EQ(back.nodes, map.nodes);
  EXPECT_EQ(back.paths, map.paths);
  ASSERT_EQ(back.edges.size(), map.edges.size());
  for (std::size_t i = 0; i < map.edges.size(); ++i) {
    EXPECT_TRUE(SameEdgeContent(back.edges[i], map.edges[i]));
  }
  // The same push again (a retry): nothing changes.
  EXPECT_EQ(this->repository_->Push(id, this->robot_, "robot-1", map), stored);
  EXPECT_EQ(this->repository_->Submissions().size(), 1u);
  // Other content under the same id is refused.
  GraphBatch other = map;
  other.nodes.pop_back();
  EXPECT_THROW(this->repository_->Push(id, this->robot_, "robot-1", other), Error);
  EXPECT_EQ(this->repository_->ReadSubmission(id).nodes, map.nodes);
  EXPECT_EQ(this->repository_->Head(), 0);  // a push is not a merge
}

TYPED_TEST(RepositoryTest, BadPushesAreRefusedAndStoreNothing) {
  const GraphBatch map = RobotMap({0});
  const auto refused = [&](GraphBatch bad, ErrorCode code, const std::string& mention) {
    try {
      this->repository_->Push(Uuid::Generate(), this->robot_, "robot-1", bad);
      ADD_FAILURE() << "pushed: " << mention;
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), code) << error.what();
      EXPECT_NE(std::string(error.what()).find(mention), std::string::npos) << error.what();
    }
  };
  GraphBatch corrupt = map;
  corrupt.nodes[1].landmarks_blob = "not landmarks";
  refused(corrupt, ErrorCode::kCorrupt, corrupt.nodes[1].id.ToString());
  GraphBatch dangling = map;
  dangling.edges[0].to = Uuid::Generate();
  refused(dangling, ErrorCode::kIntegrity, dangling.edges[0].to.ToString());
  GraphBatch nil = map;
  nil.nodes[0].id = Uuid();
  refused(nil, ErrorCode::kInvalidArgument, "");
  EXPECT_THROW(this->repository_->Push(Uuid(), this->robot_, "robot-1", map), Error);
  EXPECT_TRUE(this->repository_->Submissions().empty());
}

TYPED_TEST(RepositoryTest, MergeMakesRevisionsAndTheSameSubmissionTwiceAddsNothing) {
  const GraphBatch day = RobotMap({0});
  const Uuid first = Uuid::Generate();
  this->repository_->Push(first, this->robot_, "robot-1", day);
  std::size_t progress_calls = 0;
  const MergeOutcome merged =
      this->repository_->Merge(first, [&](std::size_t, std::size_t) { ++progress_calls; });
  EXPECT_FALSE(merged.already_merged);
  EXPECT_EQ(merged.revision.number, 1);
  EXPECT_EQ(merged.revision.author, "robot-1");
  EXPECT_EQ(merged.revision.submission, first);
  EXPECT_EQ(merged.revision.nodes_added, static_cast<std::int64_t>(merged.report.nodes_added));
  EXPECT_GT(merged.report.nodes_added, 0u);
  EXPECT_EQ(progress_calls, merged.report.segments);
  EXPECT_NE(merged.revision.report.find("\"nodes_added\""), std::string::npos);
  EXPECT_EQ(this->repository_->versions().FindSubmission(first)->state, SubmissionState::kMerged);
  EXPECT_EQ(this->repository_->versions().FindSubmission(first)->revision, 1);

  // Merging the same submission again: no new revision.
  const MergeOutcome again = this->repository_->Merge(first);
  EXPECT_TRUE(again.already_merged);
  EXPECT_EQ(again.revision.number, 1);
  EXPECT_EQ(this->repository_->Head(), 1);

  // The same content pushed again under a new id: every node is a duplicate, nothing added.
  const Revision copy = this->PushAndMerge(day);
  EXPECT_EQ(copy.number, 2);
  EXPECT_EQ(copy.nodes_added, 0);
  EXPECT_EQ(copy.edges_added, 0);
  EXPECT_EQ(NodeIds(this->repository_->Checkout(2)), NodeIds(this->repository_->Checkout(1)));

  // A robot that drove the same corridor by day on its own: it localises, nothing is added.
  const Revision redundant = this->PushAndMerge(RobotMap({0}));
  EXPECT_EQ(redundant.nodes_added, 0);
  EXPECT_EQ(this->repository_->History().size(), 3u);
}

// A robot builds on nodes it pushed before their merge reached it: still queued, or merged and
// omitted. The server accepts such pushes, merges them after what they depend on, and carries
// their edges onto the omitted nodes' stand-ins.
TYPED_TEST(RepositoryTest, PushesMayBuildOnQueuedAndOmittedNodes) {
  Repository& repository = *this->repository_;
  const auto chain_from = [&](const Uuid& anchor, std::uint32_t seed) {
    return testing::RandomChainFrom(this->robot_, anchor, 5, seed);
  };
  const auto joins = [&](const Uuid& from, const Uuid& to) {
    for (const Edge& edge : repository.Checkout().edges) {
      if (edge.from == from && edge.to == to && edge.kind == EdgeKind::kMetric) return true;
    }
    return false;
  };

  // Built on a submission still queued: accepted; its merge waits for the first one.
  const GraphBatch day = RobotMap({0});
  const Uuid first = Uuid::Generate(), second = Uuid::Generate();
  repository.Push(first, this->robot_, "robot-1", day);
  const GraphBatch on_queued = chain_from(day.nodes.back().id, 1);
  EXPECT_EQ(repository.Push(second, this->robot_, "robot-1", on_queued).state,
            SubmissionState::kQueued);
  const MergeOutcome early = repository.Merge(second);
  ASSERT_TRUE(early.waits_for);
  EXPECT_EQ(*early.waits_for, first);
  EXPECT_EQ(repository.Head(), 0);
  EXPECT_EQ(repository.Merge(first).revision.number, 1);
  EXPECT_EQ(repository.Merge(second).revision.number, 2);
  EXPECT_TRUE(joins(day.nodes.back().id, on_queued.nodes.front().id));

  // The same corridor driven again by another robot: MERGE omits it, with stand-ins.
  const GraphBatch again = RobotMap({0});
  const Uuid third = Uuid::Generate();
  repository.Push(third, this->robot_, "robot-1", again);
  const MergeOutcome omitted = repository.Merge(third);
  EXPECT_GT(omitted.report.stand_ins, 0u);
  std::optional<NodeStandIn> anchor;
  for (const Node& node : again.nodes) {
    if (const auto found = repository.versions().FindStandIn(node.id)) {
      EXPECT_TRUE(NodeIds(repository.Checkout()).contains(found->stand_in));
      EXPECT_EQ(found->revision, omitted.revision.number);
      anchor = found;
    }
  }
  EXPECT_EQ(omitted.report.stand_ins + omitted.report.nodes_added, again.nodes.size())
      << "every submitted node is added or stood in for";
  ASSERT_TRUE(anchor);
  const GraphBatch on_omitted = chain_from(anchor->node, 2);
  const Uuid fourth = Uuid::Generate();
  repository.Push(fourth, this->robot_, "robot-1", on_omitted);
  const MergeOutcome carried = repository.Merge(fourth);
  EXPECT_EQ(carried.report.nodes_added, on_omitted.nodes.size());
  EXPECT_TRUE(joins(anchor->stand_in, on_omitted.nodes.front().id))
      << "the edge to the omitted node goes to its stand-in";

  // A node the server has never seen is still refused.
  GraphBatch unseen = chain_from(Uuid::Generate(), 3);
  EXPECT_THROW(repository.Push(Uuid::Generate(), this->robot_, "robot-1", unseen), Error);
}

TYPED_TEST(RepositoryTest, CheckoutDiffAndRevert) {
  const Revision day = this->PushAndMerge(RobotMap({0}));
  const Revision night = this->PushAndMerge(RobotMap({1}));
  ASSERT_EQ(day.number, 1);
  ASSERT_EQ(night.number, 2);
  ASSERT_GT(night.nodes_added, 0);
  const GraphBatch at1 = this->repository_->Checkout(1);
  const GraphBatch at2 = this->repository_->Checkout(2);
  EXPECT_EQ(static_cast<std::int64_t>(at2.nodes.size()),
            static_cast<std::int64_t>(at1.nodes.size()) + night.nodes_added);

  const RevisionChanges diff = this->repository_->Diff(1, 2);
  EXPECT_EQ(static_cast<std::int64_t>(diff.nodes_added.size()), night.nodes_added);
  EXPECT_TRUE(diff.nodes_removed.empty());
  std::set<Uuid> added(diff.nodes_added.begin(), diff.nodes_added.end());
  for (const Uuid& id : NodeIds(at1)) EXPECT_FALSE(added.contains(id));

  const Revision revert = this->repository_->Revert(2, "operator");
  EXPECT_EQ(revert.number, 3);
  EXPECT_EQ(revert.kind, RevisionKind::kRevert);
  EXPECT_EQ(revert.nodes_hidden, night.nodes_added);
  const GraphBatch at3 = this->repository_->Checkout();
  EXPECT_EQ(NodeIds(at3), NodeIds(at1));
  // No edge of the reverted map dangles.
  const std::set<Uuid> kept = NodeIds(at3);
  for (const Edge& edge : at3.edges) {
    EXPECT_TRUE(kept.contains(edge.from) && kept.contains(edge.to)) << edge.id.ToString();
  }
  // History is intact: revision 2 still checks out with the night nodes.
  EXPECT_EQ(NodeIds(this->repository_->Checkout(2)), NodeIds(at2));
  EXPECT_EQ(this->repository_->Diff(3, 2).nodes_added, diff.nodes_added);
  // A revert cannot be reverted, nor a revision twice.
  EXPECT_THROW(this->repository_->Revert(3, "operator"), Error);
  EXPECT_THROW(this->repository_->Revert(2, "operator"), Error);
  EXPECT_THROW(this->repository_->Checkout(7), Error);
}

TYPED_TEST(RepositoryTest, RevertedNodesAreNeverAddedTwice) {
  const GraphBatch night = RobotMap({1});
  this->PushAndMerge(RobotMap({0}));
  const Revision added = this->PushAndMerge(night);
  ASSERT_GT(added.nodes_added, 0);
  this->repository_->Revert(added.number, "operator");
  // The same nodes again: they are stored (hidden), so UUID dedup keeps them out, and the
  // merge still succeeds rather than colliding with the stored rows.
  const Revision again = this->PushAndMerge(night);
  EXPECT_EQ(again.nodes_added, 0);
  EXPECT_EQ(NodeIds(this->repository_->Checkout()), NodeIds(this->repository_->Checkout(1)));
}

// A robot re-drives known nodes (omitted, stood in for by nodes of revision 2),
// builds on the last, and before it syncs the operator reverts revision 2. Its push used to
// fail for ever ("ends at ..., in neither the submission nor the server"); now the edge is
// re-anchored through the hidden stand-in (or dropped when nothing visible joins it) and
// every node the robot built merges.
TYPED_TEST(RepositoryTest, APushBuiltOnAStandInThatARevertHidStillMerges) {
  Repository& repository = *this->repository_;
  this->PushAndMerge(RobotMap({0}));
  const Revision night = this->PushAndMerge(RobotMap({1}));
  ASSERT_GT(night.nodes_added, 0);
  const GraphBatch again = RobotMap({1});
  const Uuid redrive = Uuid::Generate();
  repository.Push(redrive, this->robot_, "robot-1", again);
  ASSERT_GT(repository.Merge(redrive).report.stand_ins, 0u);
  std::optional<NodeStandIn> anchor;
  for (const Node& node : again.nodes) {
    const std::optional<NodeStandIn> found = repository.versions().FindStandIn(node.id);
    if (found && repository.versions().VersionOf(found->stand_in)->added == night.number) {
      anchor = found;
    }
  }
  ASSERT_TRUE(anchor) << "no stand-in points into revision " << night.number;
  repository.Revert(night.number, "operator");

  const GraphBatch chain = testing::RandomChainFrom(this->robot_, anchor->node, 20, 7);
  const Uuid built = Uuid::Generate();
  repository.Push(built, this->robot_, "robot-1", chain);
  const MergeOutcome merged = repository.Merge(built);
  EXPECT_EQ(merged.report.nodes_added, 20u);
  const std::set<Uuid> head = NodeIds(repository.Checkout());
  for (const Node& node : chain.nodes) EXPECT_TRUE(head.contains(node.id));
  // Whatever the first node was joined to is visible at the head (no edge into a hidden node).
  for (const Edge& edge : repository.Checkout().edges) {
    EXPECT_TRUE(head.contains(edge.from) && head.contains(edge.to)) << edge.id.ToString();
  }
}

// A node pushed with a UUID the server holds with other content used to merge
// as a duplicate ("0 nodes added"), and the robot was then sent the other node as its own.
// Now the merge is refused, naming the node; the submission stays stored (failed), and the
// stored node and the head are as they were.
TYPED_TEST(RepositoryTest, ANodeWhoseUuidIsStoredWithOtherContentIsRefusedAndBothAreKept) {
  Repository& repository = *this->repository_;
  const GraphBatch map = RobotMap({0});
  this->PushAndMerge(map);
  const Node stored = repository.Checkout().nodes.front();
  GraphBatch colliding = testing::RandomRobotMap(this->robot_, 3, 21);
  const Uuid own = colliding.nodes.front().id;
  colliding.nodes.front().id = stored.id;  // the other robot's UUID, its own content
  for (Edge& edge : colliding.edges) {
    if (edge.from == own) edge.from = stored.id;
    if (edge.to == own) edge.to = stored.id;
  }
  const Uuid id = Uuid::Generate();
  repository.Push(id, this->robot_, "robot-1", colliding);
  const std::vector<Revision> before = repository.History();
  try {
    repository.Merge(id);
    ADD_FAILURE() << "a colliding UUID merged";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kConflict);
    EXPECT_NE(std::string(error.what()).find(stored.id.ToString()), std::string::npos);
    EXPECT_NE(std::string(error.what()).find("landmarks"), std::string::npos) << error.what();
  }
  EXPECT_EQ(repository.History(), before);
  const std::optional<Submission> refused = repository.versions().FindSubmission(id);
  ASSERT_TRUE(refused);
  EXPECT_EQ(refused->state, SubmissionState::kFailed);
  EXPECT_NE(refused->error.find(stored.id.ToString()), std::string::npos);
  EXPECT_EQ(repository.ReadSubmission(id).nodes.front(), colliding.nodes.front());
  for (const Node& node : repository.Checkout().nodes) {
    if (node.id == stored.id) {
      EXPECT_EQ(node, stored);
    }
  }
}

// `fleetmap doctor` (DiagnoseStore) said healthy of a head a hide had cut in
// two. A chain merged onto another chain; the first is reverted: the second is cut off.
TYPED_TEST(RepositoryTest, DoctorReportsPiecesAHideCutOff) {
  Repository& repository = *this->repository_;
  const GraphBatch day = RobotMap({0});
  this->PushAndMerge(day);
  const GraphBatch first = testing::RandomChainFrom(this->robot_, day.nodes.back().id, 5, 31);
  const Revision joined = this->PushAndMerge(first);
  const GraphBatch second = testing::RandomChainFrom(this->robot_, first.nodes.back().id, 5, 32);
  this->PushAndMerge(second);
  const std::unique_ptr<GraphStore> store = GraphStore::Open(this->backend_->Uri());
  const auto cut_off = [&] {
    for (const StoreProblem& problem : DiagnoseStore(*store, {})) {
      if (problem.check == "cut off") return problem.what;
    }
    return std::string();
  };
  EXPECT_EQ(cut_off(), "");
  const Revision revert = repository.Revert(joined.number, "operator");
  const std::string what = cut_off();
  EXPECT_NE(what.find("5 nodes"), std::string::npos) << what;
  EXPECT_NE(what.find("revision " + std::to_string(revert.number)), std::string::npos) << what;
}

TYPED_TEST(RepositoryTest, ACorruptStoredSubmissionFailsItsMergeAndChangesNothing) {
  this->PushAndMerge(RobotMap({0}));
  const Uuid id = Uuid::Generate();
  this->repository_->Push(id, this->robot_, "robot-1", RobotMap({1}));
  // Damage the stored chunks behind the repository's back (a disk fault).
  this->backend_->ExecRaw(
      std::string("UPDATE submission_chunks SET data = ") +
      (std::string(TypeParam::kName) == "Postgres" ? "'\\x00ff'::bytea" : "x'00ff'"));
  this->repository_ = this->Open();
  try {
    this->repository_->Merge(id);
    ADD_FAILURE() << "a corrupt submission merged";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kCorrupt) << error.what();
    EXPECT_NE(std::string(error.what()).find(id.ToString()), std::string::npos);
  }
  const std::optional<Submission> failed = this->repository_->versions().FindSubmission(id);
  ASSERT_TRUE(failed.has_value());
  EXPECT_EQ(failed->state, SubmissionState::kFailed);
  EXPECT_FALSE(failed->error.empty());
  EXPECT_EQ(this->repository_->Head(), 1);
}

TYPED_TEST(RepositoryTest, TheVocabularyIsTrainedOnceAndKeptWithTheMap) {
  this->repository_ = this->Open(/*with_vocabulary=*/false);
  const GraphBatch day = RobotMap({0});
  const GraphBatch night = RobotMap({1});
  this->PushAndMerge(day);
  const std::optional<std::string> stored =
      this->repository_->versions().FindSetting("appearance.vocabulary");
  ASSERT_TRUE(stored.has_value());
  // Another process opening the repository uses the stored words, not new ones.
  this->repository_ = this->Open(/*with_vocabulary=*/false);
  const Revision second = this->PushAndMerge(night);
  EXPECT_GT(second.nodes_added, 0);
  EXPECT_EQ(this->repository_->versions().FindSetting("appearance.vocabulary"), stored);
}

// A repository given its appearance index's vocabulary trains none and stores none; one
// without trains it at its first merge and keeps it.
TYPED_TEST(RepositoryTest, AGivenIndexVocabularyIsUsedInsteadOfTrainingOne) {
  const GraphBatch day = RobotMap({0});
  this->PushAndMerge(day);
  const std::optional<std::string> trained =
      this->repository_->versions().FindSetting("appearance.index_vocabulary");
  ASSERT_TRUE(trained.has_value());

  this->repository_.reset();
  this->backend_.emplace();  // a fresh store
  RepositoryOptions options;
  options.vocabulary = SharedCorridorVocabulary();
  options.index_vocabulary =
      std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Decode(*trained));
  this->repository_ = Repository::Open(this->backend_->Uri(), options);
  const Revision first = this->PushAndMerge(day);
  EXPECT_GT(first.nodes_added, 0);
  EXPECT_FALSE(this->repository_->versions().FindSetting("appearance.index_vocabulary"))
      << "the given words are used, not trained and stored";
  const Revision again = this->PushAndMerge(RobotMap({0}));
  EXPECT_LT(again.nodes_added, first.nodes_added) << "the day seen again localises";
}

TYPED_TEST(RepositoryTest, DownloadsAreIntegralSubsetsOfARevision) {
  this->PushAndMerge(RobotMap({0}));
  this->PushAndMerge(RobotMap({1}));
  const Download copy = this->repository_->SelectForDownload(ParseDownloadPolicy("copy"));
  EXPECT_EQ(copy.revision, 2);
  EXPECT_EQ(NodeIds(copy.map), NodeIds(this->repository_->Checkout(2)));
  for (const Node& node : copy.map.nodes) EXPECT_FALSE(node.landmarks_blob.empty());

  // The corridor's stamps are the first two minutes after midnight: a mission at 12:00 with a
  // one-hour window keeps nothing, one at 00:01 keeps everything it can.
  DownloadPolicy tod = ParseDownloadPolicy("tod");
  tod.mission_start_min = 720;
  tod.window_min = 60;
  EXPECT_TRUE(this->repository_->SelectForDownload(tod).map.nodes.empty());
  tod.mission_start_min = 1;
  const Download early = this->repository_->SelectForDownload(tod, 1);
  EXPECT_EQ(early.revision, 1);
  EXPECT_EQ(NodeIds(early.map), NodeIds(this->repository_->Checkout(1)));
  const std::set<Uuid> kept = NodeIds(early.map);
  for (const Edge& edge : early.map.edges) {
    EXPECT_TRUE(kept.contains(edge.from) && kept.contains(edge.to));
  }
  EXPECT_EQ(early.report.integrity.components_after, early.report.integrity.touched_components);
}

}  // namespace
}  // namespace fleetmap
