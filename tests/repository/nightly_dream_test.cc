// The nightly dream (seed 004 §VI-E; nightly_dream.h) and promotion (Repository::Promote) on
// both stores: what a dream chooses to dream over, the candidate it leaves without touching
// the head, and the revision a promotion makes of it.
#include "fleetmap/repository/nightly_dream.h"

#include <gtest/gtest.h>

#include <latch>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "corridor_robot_map.h"
#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/repository/dream_candidates.h"
#include "fleetmap/repository/repository.h"
#include "random_robot_map.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;
using testing::WallNs;

template <typename Backend>
class NightlyDreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    repository_ = OpenAnother();
  }

  // The repository once more, on a connection of its own: what another `fleetmap promote`
  // process has.
  std::unique_ptr<Repository> OpenAnother() {
    RepositoryOptions options;
    options.vocabulary = SharedCorridorVocabulary();
    return Repository::Open(backend_->Uri(), options);
  }

  // Pushes and merges a robot's map of one corridor outing; returns the submission.
  Uuid PushAndMerge(int condition, double start_m) {
    const Uuid id = Uuid::Generate();
    const GraphBatch map = CorridorRobotMap({{condition, start_m}});
    for (const Node& node : map.nodes) pushed_[id].insert(node.id);
    repository_->Push(id, Uuid::Generate(), "robot-" + std::to_string(pushed_.size()), map);
    EXPECT_FALSE(repository_->Merge(id).already_merged);
    return id;
  }

  std::optional<Backend> backend_;
  std::unique_ptr<Repository> repository_;
  std::map<Uuid, std::set<Uuid>> pushed_;  // each submission's nodes
};

TYPED_TEST_SUITE(NightlyDreamTest, StoreBackends, BackendNames);

TYPED_TEST(NightlyDreamTest, DreamLeavesACandidateAndPromotionMakesItTheMap) {
  Repository& repository = *this->repository_;
  // Nothing merged yet: nothing to dream over.
  EXPECT_FALSE(RunNightlyDream(repository, {}).candidate);
  const Uuid day = this->PushAndMerge(0, 0.0);
  const Uuid night = this->PushAndMerge(1, 30.0);
  const Uuid day_far = this->PushAndMerge(0, 60.0);
  const Uuid held_out = this->PushAndMerge(1, 0.0);
  ASSERT_EQ(repository.Head(), 4);

  std::size_t progress_calls = 0;
  const NightlyDreamOutcome outcome =
      RunNightlyDream(repository, {}, [&](std::size_t done, std::size_t all) {
        ++progress_calls;
        EXPECT_LE(done, all);
      });
  ASSERT_TRUE(outcome.candidate) << outcome.skipped;
  const DreamCandidateRecord& c = *outcome.candidate;
  EXPECT_GT(progress_calls, 0u);
  // The rule: the newest is held out, the others are the groups, merged into the map before
  // the first of them.
  EXPECT_EQ(c.held_out, held_out);
  EXPECT_EQ(c.merged_order, (std::vector<Uuid>{day, night, day_far}));
  EXPECT_EQ(std::set<Uuid>(c.groups.begin(), c.groups.end()),
            (std::set<Uuid>{day, night, day_far}));
  EXPECT_EQ(c.base_revision, 0);
  EXPECT_EQ(c.dreamed_at_head, 4);
  EXPECT_EQ(c.orders, 6u);                    // 3!
  ASSERT_TRUE(c.merged_order_score);          // every order was explored, the server's among them
  EXPECT_LE(c.score, *c.merged_order_score);  // the best is no worse than the one merged
  EXPECT_GT(c.held_out_frames, 0u);
  EXPECT_GE(c.p_gap_exceeds, 0.0);
  EXPECT_LE(c.p_gap_exceeds, 1.0);
  EXPECT_FALSE(c.held_out_rule.empty());
  // The head did not move; the candidate is listed and its content reads back: the groups'
  // nodes only (the base was empty), the held-out submission's none.
  EXPECT_EQ(repository.Head(), 4);
  DreamCandidates candidates(repository.versions());
  ASSERT_EQ(candidates.List().size(), 1u);
  EXPECT_EQ(candidates.Find(c.id), c);
  const GraphBatch content = candidates.Content(c);
  EXPECT_EQ(static_cast<std::int64_t>(content.nodes.size()), c.nodes);
  EXPECT_GT(c.nodes, 0);
  for (const Node& node : content.nodes) {
    EXPECT_TRUE(this->pushed_[day].contains(node.id) || this->pushed_[night].contains(node.id) ||
                this->pushed_[day_far].contains(node.id))
        << node.id.ToString();
  }
  // Nothing new since: the next dream is skipped, and says why.
  const NightlyDreamOutcome again = RunNightlyDream(repository, {});
  EXPECT_FALSE(again.candidate);
  EXPECT_NE(again.skipped.find("needs two"), std::string::npos) << again.skipped;

  // A candidate that only ties the order merged is promoted only when forced;
  // this test is about what a promotion does.
  if (c.score >= *c.merged_order_score) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { repository.Promote(c.id, "operator"); }, "--force");
  }
  const Revision promoted = repository.Promote(c.id, "operator", /*force=*/true);
  EXPECT_EQ(promoted.number, 5);
  EXPECT_EQ(promoted.kind, RevisionKind::kPromote);
  EXPECT_EQ(promoted.author, "operator");
  // The report states the held-out score.
  const DreamCandidateRecord reported = DreamCandidateFromJson(promoted.report);
  EXPECT_EQ(reported.id, c.id);
  EXPECT_EQ(reported.score, c.score);
  EXPECT_EQ(reported.p_gap_exceeds, c.p_gap_exceeds);
  EXPECT_EQ(reported.promoted_as, 5);
  EXPECT_EQ(repository.History().back(), promoted);
  // The map at the promotion: every candidate node, the held-out submission's merge intact, no
  // other node of the groups, and no edge dangling.
  std::set<Uuid> visible;
  for (const Node& node : repository.versions().NodesAt(5, false)) visible.insert(node.id);
  for (const Node& node : content.nodes) EXPECT_TRUE(visible.contains(node.id));
  for (const Uuid& node : repository.Diff(3, 4).nodes_added) EXPECT_TRUE(visible.contains(node));
  for (const Uuid& group : {day, night, day_far}) {
    for (const Uuid& node : this->pushed_[group]) {
      if (visible.contains(node)) {
        EXPECT_TRUE(std::any_of(content.nodes.begin(), content.nodes.end(),
                                [&](const Node& n) { return n.id == node; }));
      }
    }
  }
  for (const Edge& edge : repository.versions().EdgesAt(5)) {
    EXPECT_TRUE(visible.contains(edge.from) && visible.contains(edge.to)) << edge.id.ToString();
  }
  EXPECT_EQ(candidates.Find(c.id)->promoted_as, 5);

  // Once only; an unknown candidate is named; a promotion is not reverted.
  ExpectError(
      ErrorCode::kConflict, [&] { repository.Promote(c.id, "operator"); }, "revision 5");
  const Uuid unknown = Uuid::Generate();
  ExpectError(
      ErrorCode::kNotFound, [&] { repository.Promote(unknown, "operator"); }, unknown.ToString());
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { repository.Revert(5, "operator"); }, "promotion");
  EXPECT_EQ(repository.Head(), 5);

  // The held-out submission is merged in the next dream: it is a group, the newest judges.
  const Uuid next = this->PushAndMerge(0, 20.0);
  const NightlyDreamOutcome second = RunNightlyDream(repository, {});
  ASSERT_TRUE(second.candidate) << second.skipped;
  EXPECT_EQ(second.candidate->held_out, next);
  EXPECT_EQ(second.candidate->groups, std::vector<Uuid>{held_out});
  EXPECT_EQ(candidates.List().front().id, second.candidate->id);  // newest first
}

// The nodes of the head joined to `start` by metric edges: the piece a localiser reaches.
std::set<Uuid> HeadPieceOf(Repository& repository, const Uuid& start) {
  const GraphBatch head = repository.Checkout();
  std::map<Uuid, std::vector<Uuid>> adjacent;
  for (const Edge& edge : head.edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    adjacent[edge.from].push_back(edge.to);
    adjacent[edge.to].push_back(edge.from);
  }
  std::set<Uuid> piece{start};
  std::vector<Uuid> stack{start};
  while (!stack.empty()) {
    const Uuid at = stack.back();
    stack.pop_back();
    for (const Uuid& next : adjacent[at]) {
      if (piece.insert(next).second) stack.push_back(next);
    }
  }
  return piece;
}

// After a dream, robots build on nodes its candidate does without: one
// merges a chain hanging from such a node before the promotion, another re-drives a dreamed
// group (omitted: stand-ins into the nodes the promotion hides) and builds on it after. The
// promotion keeps what the merged chain hangs from (it is not cut off the map), and the later push
// still merges, whole.
TYPED_TEST(NightlyDreamTest,
           PromotionKeepsWhatLaterMergesHangFromAndPushesBuiltOnHiddenNodesMerge) {
  Repository& repository = *this->repository_;
  const Uuid day = this->PushAndMerge(0, 0.0);
  const Uuid night = this->PushAndMerge(1, 30.0);
  const Uuid day_far = this->PushAndMerge(0, 60.0);
  // A candidate that does without the night group's nodes (as an order that merged the night
  // where the days already localise would), better than the merged order.
  const Submission night_merge = *repository.versions().FindSubmission(night);
  const std::vector<Uuid> doomed =
      repository.Diff(night_merge.revision - 1, night_merge.revision).nodes_added;
  const std::set<Uuid> doomed_set(doomed.begin(), doomed.end());
  GraphBatch content = repository.Checkout();
  std::erase_if(content.nodes, [&](const Node& n) { return doomed_set.contains(n.id); });
  std::erase_if(content.edges, [&](const Edge& e) {
    return doomed_set.contains(e.from) || doomed_set.contains(e.to);
  });
  DreamCandidateRecord record;
  record.created_ns = 1;
  record.dreamed_at_head = repository.Head();
  record.groups = record.merged_order = {day, night, day_far};
  record.orders = 6;
  record.score = 0.1;
  record.merged_order_score = 0.5;
  const DreamCandidateRecord c = DreamCandidates(repository.versions()).Put(record, content);
  ASSERT_FALSE(doomed.empty());

  // A chain merged after the dream, hanging from a doomed node.
  const Uuid robot = Uuid::Generate();
  const GraphBatch chain = testing::RandomChainFrom(robot, doomed.back(), 20, 11);
  const Uuid chained = Uuid::Generate();
  repository.Push(chained, robot, "robot-chain", chain);
  ASSERT_EQ(repository.Merge(chained).report.nodes_added, 20u);
  const std::size_t piece_before = HeadPieceOf(repository, chain.nodes.front().id).size();
  ASSERT_GT(piece_before, chain.nodes.size());

  // A re-drive of the night group: its nodes stood in for by the group's.
  const GraphBatch redrive = CorridorRobotMap({{1, 30.0}});
  const Uuid redriven = Uuid::Generate();
  repository.Push(redriven, robot, "robot-chain", redrive);
  ASSERT_GT(repository.Merge(redriven).report.stand_ins, 0u);
  std::optional<NodeStandIn> anchor;
  for (const Node& node : redrive.nodes) {
    if (const auto found = repository.versions().FindStandIn(node.id)) anchor = found;
  }
  ASSERT_TRUE(anchor);

  const Revision promoted = repository.Promote(c.id, "operator");
  std::set<Uuid> visible;
  for (const Node& node : repository.versions().NodesAt(promoted.number, false)) {
    visible.insert(node.id);
  }
  for (const Node& node : chain.nodes) EXPECT_TRUE(visible.contains(node.id));
  EXPECT_TRUE(visible.contains(doomed.back())) << "the node the chain hangs from is kept";
  EXPECT_GT(HeadPieceOf(repository, chain.nodes.front().id).size(), chain.nodes.size())
      << "the promotion cut the chain off the map";

  // Built on the re-driven nodes, pushed after the promotion: merges whole.
  const GraphBatch more = testing::RandomChainFrom(robot, anchor->node, 20, 12);
  const Uuid later = Uuid::Generate();
  repository.Push(later, robot, "robot-chain", more);
  EXPECT_EQ(repository.Merge(later).report.nodes_added, 20u);
}

TYPED_TEST(NightlyDreamTest, ADamagedCandidateIsRefusedAndTheMapStays) {
  Repository& repository = *this->repository_;
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(1, 0.0);
  NightlyDreamOptions options;
  options.max_groups = 1;
  const NightlyDreamOutcome outcome = RunNightlyDream(repository, options);
  ASSERT_TRUE(outcome.candidate) << outcome.skipped;
  const DreamCandidateRecord& c = *outcome.candidate;
  EXPECT_EQ(c.orders, 1u);
  // Its first chunk overwritten behind the API's back.
  repository.versions().PutSetting("dream-content/" + c.id.ToString() + "/000000000000",
                                   "not a map chunk");
  const std::vector<Node> before = repository.versions().NodesAt(2, false);
  ExpectError(
      ErrorCode::kCorrupt, [&] { repository.Promote(c.id, "operator"); }, c.id.ToString());
  EXPECT_EQ(repository.Head(), 2);
  EXPECT_EQ(repository.versions().NodesAt(2, false), before);
  EXPECT_EQ(DreamCandidates(repository.versions()).Find(c.id)->promoted_as, 0);
  // And a record that is not one.
  repository.versions().PutSetting("dream-candidate/" + c.id.ToString(), "{\"id\": 3}");
  ExpectError(
      ErrorCode::kCorrupt, [&] { repository.Promote(c.id, "operator"); }, "dream candidate record");
  ExpectError(ErrorCode::kInvalidArgument, [&] {
    NightlyDreamOptions none;
    none.max_groups = 0;
    RunNightlyDream(repository, none);
  });
  // The limit of every dream (dream_plan.h), not one of its own.
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] {
        NightlyDreamOptions too_many;
        too_many.max_groups = kMaxDreamGroups + 1;
        RunNightlyDream(repository, too_many);
      },
      "1 to " + std::to_string(kMaxDreamGroups));
}

// A candidate that only ties the order the server merged (here the only
// order: one group) is not promoted, and the error gives both scores; --force promotes it. A
// candidate whose dream did not score the merged order is not known to beat it: refused the
// same way. One that beats it is promoted as before.
TYPED_TEST(NightlyDreamTest, ACandidateThatDoesNotBeatTheMergedOrderIsPromotedOnlyWithForce) {
  Repository& repository = *this->repository_;
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(1, 0.0);
  NightlyDreamOptions options;
  options.max_groups = 1;
  const NightlyDreamOutcome outcome = RunNightlyDream(repository, options);
  ASSERT_TRUE(outcome.candidate) << outcome.skipped;
  const DreamCandidateRecord& tie = *outcome.candidate;
  ASSERT_TRUE(tie.merged_order_score);
  ASSERT_EQ(tie.score, *tie.merged_order_score) << "one order: the merged one";
  char scores[64];
  std::snprintf(scores, sizeof scores, "%.6f vs %.6f", tie.score, *tie.merged_order_score);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { repository.Promote(tie.id, "operator"); },
      "does not beat the order the server merged");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { repository.Promote(tie.id, "operator"); }, scores);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { repository.Promote(tie.id, "operator"); }, "--force");
  EXPECT_EQ(repository.Head(), 2);
  DreamCandidates candidates(repository.versions());
  EXPECT_EQ(candidates.Find(tie.id)->promoted_as, 0);

  // The same content, recorded as a dream that did not score the merged order, and as one
  // that beat it.
  const GraphBatch content = candidates.Content(tie);
  DreamCandidateRecord unscored = tie;
  unscored.id = Uuid();
  unscored.merged_order_score.reset();
  unscored = candidates.Put(unscored, content);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { repository.Promote(unscored.id, "operator"); },
      "did not score the order the server merged");
  DreamCandidateRecord better = tie;
  better.id = Uuid();
  better.merged_order_score = tie.score + 0.25;
  better = candidates.Put(better, content);
  EXPECT_EQ(repository.Head(), 2);

  const Revision forced = repository.Promote(tie.id, "operator", /*force=*/true);
  EXPECT_EQ(forced.number, 3);
  EXPECT_EQ(forced.kind, RevisionKind::kPromote);
  EXPECT_EQ(candidates.Find(tie.id)->promoted_as, 3);
  EXPECT_EQ(repository.Promote(better.id, "operator").number, 4);
}

// Promotes of one candidate from several connections at once: exactly one makes a revision; each
// other is told the candidate is promoted already, as that revision, and makes none (not even
// an empty one). A few rounds, a new candidate each, since a race need not show every time.
TYPED_TEST(NightlyDreamTest, ConcurrentPromotesOfOneCandidateMakeOneRevision) {
  Repository& repository = *this->repository_;
  const Uuid day = this->PushAndMerge(0, 0.0);
  const Uuid night = this->PushAndMerge(1, 30.0);
  constexpr int kPromoters = 3;
  constexpr int kRounds = 3;
  std::vector<std::unique_ptr<Repository>> repositories;
  for (int i = 0; i < kPromoters; ++i) repositories.push_back(this->OpenAnother());

  for (int round = 0; round < kRounds; ++round) {
    SCOPED_TRACE("round " + std::to_string(round));
    DreamCandidateRecord record;
    record.created_ns = 1 + round;
    record.dreamed_at_head = repository.Head();
    record.groups = record.merged_order = {day, night};
    record.orders = 2;
    record.score = 0.1;
    record.merged_order_score = 0.5;
    const DreamCandidateRecord c =
        DreamCandidates(repository.versions()).Put(record, repository.Checkout());

    std::mutex mutex;
    std::vector<Revision> made;
    std::vector<Error> refused;
    std::latch start(kPromoters);
    std::vector<std::thread> promoters;
    for (int i = 0; i < kPromoters; ++i) {
      promoters.emplace_back([&, i] {
        Repository& mine = *repositories[static_cast<std::size_t>(i)];
        start.arrive_and_wait();
        try {
          const Revision revision = mine.Promote(c.id, "operator-" + std::to_string(i));
          const std::lock_guard<std::mutex> lock(mutex);
          made.push_back(revision);
        } catch (const Error& error) {
          const std::lock_guard<std::mutex> lock(mutex);
          refused.push_back(error);
        }
      });
    }
    for (std::thread& promoter : promoters) promoter.join();

    ASSERT_EQ(made.size(), 1u) << "promotes that made a revision";
    const RevisionNumber winner = made[0].number;
    for (const Error& error : refused) {
      EXPECT_EQ(error.code(), ErrorCode::kConflict) << error.what();
      EXPECT_NE(
          std::string(error.what()).find("promoted already, as revision " + std::to_string(winner)),
          std::string::npos)
          << error.what();
    }
    std::size_t promotions = 0;
    for (const Revision& revision : repository.History()) {
      if (revision.kind == RevisionKind::kPromote &&
          DreamCandidateFromJson(revision.report).id == c.id) {
        ++promotions;
      }
    }
    EXPECT_EQ(promotions, 1u);
    EXPECT_EQ(repository.Head(), winner);
    EXPECT_EQ(DreamCandidates(repository.versions()).Find(c.id)->promoted_as, winner);
  }
}

// The UTC second of the day of `ns` (nanoseconds since the epoch).
int SecondOfDay(std::int64_t ns) {
  return static_cast<int>((ns / 1'000'000'000) % (24 * 60 * 60));
}

// Which scheduled dream fleetmapd missed, told from the store at any
// `now`: none before any dream; none when a dream finished after the last scheduled time; the
// last scheduled time when the last dream finished before it; and a dream cut off half-way
// (here abandoned from its progress callback, as a kill leaves it) until one finishes.
TYPED_TEST(NightlyDreamTest, AMissedDreamIsToldFromTheStore) {
  Repository& repository = *this->repository_;
  constexpr std::int64_t kHourNs = 3'600'000'000'000;
  const std::int64_t now = WallNs();
  EXPECT_FALSE(FindMissedDream(repository, now, SecondOfDay(now + 2 * kHourNs)));
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(1, 0.0);
  NightlyDreamOptions options;
  options.max_groups = 1;
  ASSERT_TRUE(RunNightlyDream(repository, options).candidate);
  const std::int64_t done = WallNs();
  // Scheduled two hours ahead: yesterday's time passed before the dream, nothing missed; three
  // hours on, today's time has passed since it.
  const int later = SecondOfDay(done + 2 * kHourNs);
  EXPECT_FALSE(FindMissedDream(repository, done, later));
  const std::optional<MissedDream> missed = FindMissedDream(repository, done + 3 * kHourNs, later);
  ASSERT_TRUE(missed);
  EXPECT_GT(missed->scheduled_ns, done);
  EXPECT_LE(missed->scheduled_ns, done + 3 * kHourNs);
  EXPECT_NE(missed->why.find("finished"), std::string::npos) << missed->why;

  // A dream cut off half-way: missed whenever the schedule is, until a dream finishes.
  this->PushAndMerge(0, 30.0);
  EXPECT_ANY_THROW(RunNightlyDream(
      repository, options, [](std::size_t, std::size_t) { throw std::runtime_error("killed"); }));
  const std::int64_t cut = WallNs();
  for (const int minute : {later, SecondOfDay(cut), SecondOfDay(cut + kHourNs)}) {
    const std::optional<MissedDream> again = FindMissedDream(repository, cut, minute);
    ASSERT_TRUE(again) << minute;
    EXPECT_NE(again->why.find("did not finish"), std::string::npos) << again->why;
  }
  ASSERT_TRUE(RunNightlyDream(repository, options).candidate);
  EXPECT_FALSE(FindMissedDream(repository, WallNs(), later));
}

}  // namespace
}  // namespace fleetmap
