// The nightly dream (seed 004 §VI-E; nightly_dream.h) and promotion (Repository::Promote) on
// both stores: what a dream chooses to dream over, the candidate it leaves without touching
// the head, and the revision a promotion makes of it.
#include "fleetmap/server/nightly_dream.h"

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <set>

#include "corridor_robot_map.h"
#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/server/dream_candidates.h"
#include "fleetmap/server/repository.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;

template <typename Backend>
class NightlyDreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    RepositoryOptions options;
    options.vocabulary = SharedCorridorVocabulary();
    repository_ = Repository::Open(backend_->Uri(), options);
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

  const Revision promoted = repository.Promote(c.id, "operator");
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
}

TEST(DreamTime, ParsesHoursAndMinutesAndNamesWhatItRefuses) {
  EXPECT_EQ(ParseDreamTime("00:00"), 0);
  EXPECT_EQ(ParseDreamTime("02:30"), 150);
  EXPECT_EQ(ParseDreamTime("23:59"), 1439);
  for (const char* bad : {"24:00", "12:60", "2:30", "02-30", "", "aa:bb", "02:300"}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { ParseDreamTime(bad); }, "'" + std::string(bad) + "'");
  }
}

}  // namespace
}  // namespace fleetmap
