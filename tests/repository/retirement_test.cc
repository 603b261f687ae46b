// Retirement (retirement.h): the rules on hand-made maps, a property over random ones, and the
// use MERGE's replay records on both stores.
#include "fleetmap/repository/retirement.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "corridor_robot_map.h"
#include "expect_error.h"
#include "fleetmap/repository/repository.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;

constexpr std::int64_t kDay = kNanosecondsPerDay;

// A map drawn from known positions: outings of nodes along a line, edges from the true
// positions (so a pose composed along any way is exact).
class DrawnMap {
 public:
  // An outing of `count` nodes `spacing_m` apart from (x0, y), stamped `day`.
  std::vector<Uuid> Outing(double x0, double y, int count, std::int64_t day,
                           double spacing_m = 1.0) {
    const Uuid robot = Uuid::Generate(), outing = Uuid::Generate();
    std::vector<Uuid> ids;
    for (int i = 0; i < count; ++i) {
      Node node;
      node.id = Uuid::Generate();
      node.robot = robot;
      node.outing = outing;
      node.stamp_ns = day * kDay + i;
      input_.nodes.push_back(node);
      position_[node.id] = Eigen::Vector3d(x0 + i * spacing_m, y, 0.0);
      if (!ids.empty()) Link(ids.back(), node.id);
      ids.push_back(node.id);
    }
    return ids;
  }

  void Link(const Uuid& from, const Uuid& to) {
    Edge edge;
    edge.id = Uuid::Generate();
    edge.from = from;
    edge.to = to;
    edge.kind = EdgeKind::kMetric;
    edge.from_T_to = Se3::Identity();
    edge.from_T_to.translation() = position_.at(to) - position_.at(from);
    input_.edges.push_back(edge);
  }

  void Use(const Uuid& node, std::int64_t day) {
    NodeUsage& use = input_.usage[node];
    use.node = node;
    ++use.frames;
    use.last_ns = std::max(use.last_ns, day * kDay);
  }

  void UseAll(const std::vector<Uuid>& nodes, std::int64_t day) {
    for (const Uuid& node : nodes) Use(node, day);
  }

  RetirementInput& input() { return input_; }
  const Eigen::Vector3d& position(const Uuid& node) const { return position_.at(node); }

 private:
  RetirementInput input_;
  std::map<Uuid, Eigen::Vector3d> position_;
};

RetireOptions After(std::int64_t days) {
  RetireOptions options;
  options.retire_after_ns = days * kDay;
  return options;
}

std::set<Uuid> Retired(const RetirementPlan& plan) {
  std::set<Uuid> ids;
  for (const RetiredNode& node : plan.retire) ids.insert(node.node);
  return ids;
}

// An old experience of a road and the one that replaced it, linked at both ends: the old one
// goes whole, the new one stays, and each retired node names a holder of its place.
TEST(RetirementPlan, TheExperienceTheWorldLeftGoesWhereAnotherHoldsItsPlace) {
  DrawnMap map;
  const std::vector<Uuid> old_road = map.Outing(0.0, 0.0, 20, 0);
  const std::vector<Uuid> new_road = map.Outing(0.0, 1.5, 20, 10);
  map.Link(old_road.front(), new_road.front());
  map.Link(old_road.back(), new_road.back());
  map.UseAll(old_road, 2);
  map.UseAll(new_road, 30);
  const RetirementPlan plan = PlanRetirementOf(map.input(), After(14));
  EXPECT_EQ(plan.now_ns, 30 * kDay);  // the map's clock: the newest use
  EXPECT_EQ(plan.cutoff_ns, 16 * kDay);
  EXPECT_EQ(plan.visible_nodes, 40u);
  EXPECT_EQ(plan.candidates, 20u);
  EXPECT_EQ(Retired(plan), std::set<Uuid>(old_road.begin(), old_road.end()));
  const std::set<Uuid> kept(new_road.begin(), new_road.end());
  for (const RetiredNode& node : plan.retire) {
    EXPECT_TRUE(kept.contains(node.held_by));
    EXPECT_NEAR(node.held_by_m, (map.position(node.node) - map.position(node.held_by)).norm(),
                1e-9);
    EXPECT_LE(node.held_by_m, 8.0);
    EXPECT_EQ(node.last_used_ns, 2 * kDay);
    EXPECT_EQ(node.frames, 1);
  }
  // Used within the window, it all stays.
  map.UseAll(old_road, 20);
  EXPECT_TRUE(PlanRetirementOf(map.input(), After(14)).retire.empty());
}

TEST(RetirementPlan, NeverTheLastExperienceOfAPlace) {
  DrawnMap map;
  const std::vector<Uuid> road = map.Outing(0.0, 0.0, 10, 0);
  const std::vector<Uuid> elsewhere = map.Outing(100.0, 0.0, 10, 30);  // far on
  map.Link(road.back(), elsewhere.front());
  map.UseAll(elsewhere, 30);
  const RetirementPlan plan = PlanRetirementOf(map.input(), After(14));
  EXPECT_EQ(plan.candidates, 10u);
  EXPECT_EQ(plan.kept_last_of_place, 10u);
  EXPECT_TRUE(plan.retire.empty());
  // Another experience too far off does not hold it either; a place radius that reaches does.
  DrawnMap wide;
  const std::vector<Uuid> a = wide.Outing(0.0, 0.0, 5, 0);
  const std::vector<Uuid> b = wide.Outing(0.0, 12.0, 5, 30);
  wide.Link(a.front(), b.front());
  wide.UseAll(b, 30);
  EXPECT_TRUE(PlanRetirementOf(wide.input(), After(14)).retire.empty());
  RetireOptions reach = After(14);
  reach.place_radius_m = 15.0;
  EXPECT_EQ(PlanRetirementOf(wide.input(), reach).retire.size(), 5u);
}

// A node that is the only way between two parts of the map stays, however old.
TEST(RetirementPlan, NeverANodeWhoseGoingCutsTheMap) {
  DrawnMap map;
  const std::vector<Uuid> held = map.Outing(0.0, 0.0, 3, 30);
  const std::vector<Uuid> bridge = map.Outing(0.0, 1.0, 1, 0);
  const std::vector<Uuid> beyond = map.Outing(50.0, 0.0, 3, 30);
  map.Link(held[0], bridge[0]);
  map.Link(bridge[0], beyond[0]);
  map.UseAll(held, 30);
  map.UseAll(beyond, 30);
  const RetirementPlan plan = PlanRetirementOf(map.input(), After(14));
  EXPECT_EQ(plan.candidates, 1u);
  EXPECT_EQ(plan.kept_joins_map, 1u);
  EXPECT_TRUE(plan.retire.empty());
  // With another way round, it goes.
  map.Link(held[2], beyond[0]);
  EXPECT_EQ(Retired(PlanRetirementOf(map.input(), After(14))), std::set<Uuid>{bridge[0]});
}

TEST(RetirementPlan, NeverANodeAnUnmergedSubmissionNames) {
  DrawnMap map;
  const std::vector<Uuid> old_road = map.Outing(0.0, 0.0, 4, 0);
  const std::vector<Uuid> new_road = map.Outing(0.0, 1.0, 4, 30);
  map.Link(old_road.front(), new_road.front());
  map.Link(old_road.back(), new_road.back());
  map.UseAll(new_road, 30);
  map.input().named_by_submissions.insert(old_road[1]);
  const RetirementPlan plan = PlanRetirementOf(map.input(), After(14));
  EXPECT_EQ(plan.kept_for_submissions, 1u);
  EXPECT_FALSE(Retired(plan).contains(old_road[1]));
  // It stays joined to the map through one of its neighbours, which stays too.
  EXPECT_EQ(plan.kept_joins_map, 1u);
  EXPECT_EQ(plan.retire.size(), 2u);
}

TEST(RetirementPlan, TheClockCanBeGivenAndOptionsAreChecked) {
  DrawnMap map;
  const std::vector<Uuid> old_road = map.Outing(0.0, 0.0, 4, 0);
  const std::vector<Uuid> new_road = map.Outing(0.0, 1.0, 4, 5);
  map.Link(old_road.front(), new_road.front());
  map.UseAll(new_road, 5);
  EXPECT_TRUE(PlanRetirementOf(map.input(), After(14)).retire.empty());  // the map's day 5
  RetireOptions later = After(14);
  later.now_ns = 17 * kDay;  // the old road unused for 17 days, the new one for 12
  EXPECT_EQ(PlanRetirementOf(map.input(), later).retire.size(), 4u);
  for (auto bad : {After(0), After(-1)}) {
    ExpectError(ErrorCode::kInvalidArgument, [&] { PlanRetirementOf(map.input(), bad); });
  }
  RetireOptions no_place = After(14);
  no_place.place_radius_m = 0.0;
  ExpectError(ErrorCode::kInvalidArgument, [&] { PlanRetirementOf(map.input(), no_place); });
}

// Connected components of `nodes` by metric edges whose both ends are among them, as sets.
std::set<std::set<Uuid>> Components(const RetirementInput& input, const std::set<Uuid>& nodes) {
  std::map<Uuid, std::vector<Uuid>> adjacent;
  for (const Edge& edge : input.edges) {
    if (!nodes.contains(edge.from) || !nodes.contains(edge.to)) continue;
    adjacent[edge.from].push_back(edge.to);
    adjacent[edge.to].push_back(edge.from);
  }
  std::set<std::set<Uuid>> components;
  std::set<Uuid> seen;
  for (const Uuid& start : nodes) {
    if (!seen.insert(start).second) continue;
    std::set<Uuid> component{start};
    std::vector<Uuid> stack{start};
    while (!stack.empty()) {
      const Uuid here = stack.back();
      stack.pop_back();
      for (const Uuid& next : adjacent[here]) {
        if (seen.insert(next).second) {
          component.insert(next);
          stack.push_back(next);
        }
      }
    }
    components.insert(component);
  }
  return components;
}

// Whatever retirement hides: every node localised against within the window stays (so every
// place a robot localised in still has the experience it localised against); every node it
// hides has an experience of its place within the radius that stays; and what stays is joined
// as it was (no component of the map is cut in two).
TEST(RetirementPlan, PropertyWhatWasUsedStaysEveryPlaceKeepsOneAndNothingIsCut) {
  for (std::uint32_t seed = 1; seed <= 40; ++seed) {
    std::mt19937 random(seed);
    std::uniform_real_distribution<double> lateral(-3.0, 3.0), start(0.0, 60.0);
    std::uniform_int_distribution<int> length(3, 40), day(0, 40), outings(2, 8);
    std::bernoulli_distribution used(0.5), linked(0.3);
    DrawnMap map;
    std::vector<std::vector<Uuid>> all;
    const int n = outings(random);
    for (int o = 0; o < n; ++o) {
      all.push_back(map.Outing(start(random), lateral(random), length(random), day(random)));
    }
    // Links between outings where they pass close, as MERGE registers them, some of the time.
    for (std::size_t a = 0; a < all.size(); ++a) {
      for (std::size_t b = a + 1; b < all.size(); ++b) {
        for (const Uuid& x : all[a]) {
          for (const Uuid& y : all[b]) {
            if ((map.position(x) - map.position(y)).norm() < 2.0 && linked(random)) {
              map.Link(x, y);
            }
          }
        }
      }
    }
    for (const std::vector<Uuid>& outing : all) {
      for (const Uuid& node : outing) {
        if (used(random)) map.Use(node, day(random));
      }
    }
    RetireOptions options = After(std::uniform_int_distribution<int>(3, 20)(random));
    options.place_radius_m = 4.0;
    const RetirementInput& input = map.input();
    const RetirementPlan plan = PlanRetirementOf(input, options);
    const std::set<Uuid> retired = Retired(plan);
    std::set<Uuid> all_nodes, kept;
    for (const Node& node : input.nodes) {
      all_nodes.insert(node.id);
      if (!retired.contains(node.id)) kept.insert(node.id);
      const auto use = input.usage.find(node.id);
      const std::int64_t last =
          std::max(node.stamp_ns, use == input.usage.end() ? 0 : use->second.last_ns);
      if (last >= plan.cutoff_ns) {
        EXPECT_FALSE(retired.contains(node.id)) << "seed " << seed << ": used, yet retired";
      }
    }
    for (const RetiredNode& node : plan.retire) {
      EXPECT_TRUE(kept.contains(node.held_by)) << "seed " << seed;
      EXPECT_LE((map.position(node.node) - map.position(node.held_by)).norm(),
                options.place_radius_m + 1e-9)
          << "seed " << seed;
    }
    // Every component of the map keeps its surviving nodes joined.
    std::size_t survivors_split = 0;
    const std::set<std::set<Uuid>> after = Components(input, kept);
    for (const std::set<Uuid>& before : Components(input, all_nodes)) {
      std::set<const std::set<Uuid>*> pieces;
      for (const std::set<Uuid>& piece : after) {
        if (before.contains(*piece.begin())) pieces.insert(&piece);
      }
      if (pieces.size() > 1) ++survivors_split;
    }
    EXPECT_EQ(survivors_split, 0u) << "seed " << seed;
  }
}

// MERGE's replay records what it localised against, with the revision, on both stores.
template <typename Backend>
class RetirementRepositoryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    RepositoryOptions options;
    options.vocabulary = SharedCorridorVocabulary();
    repository_ = Repository::Open(backend_->Uri(), options);
  }

  std::optional<Backend> backend_;
  std::unique_ptr<Repository> repository_;
};

TYPED_TEST_SUITE(RetirementRepositoryTest, StoreBackends, BackendNames);

// The newest stamp a robot map carries: of a node or of its path's end.
std::int64_t NewestStamp(const GraphBatch& map) {
  std::int64_t newest = 0;
  for (const Node& node : map.nodes) newest = std::max(newest, node.stamp_ns);
  for (const Path& path : map.paths) newest = std::max(newest, path.end_ns);
  return newest;
}

TYPED_TEST(RetirementRepositoryTest, AMergeRecordsWhatTheRobotAndTheReplayLocalisedAgainst) {
  Repository& repository = *this->repository_;
  const Uuid robot = Uuid::Generate();
  const Uuid first = Uuid::Generate(), second = Uuid::Generate();
  const GraphBatch survey = CorridorRobotMap({{0}});
  repository.Push(first, robot, "robot-1", survey);
  repository.Merge(first);
  // The first merge replays against an empty map; what is used is the robot's own path
  // through what it built (its path memory), all of it in the map now.
  std::set<Uuid> map_nodes;
  for (const Node& node : repository.versions().NodesAt(1, false)) map_nodes.insert(node.id);
  for (const NodeUsage& use : repository.versions().UsageAt(1)) {
    EXPECT_TRUE(map_nodes.contains(use.node));
    EXPECT_LE(use.last_ns, NewestStamp(survey));
  }
  // The same corridor driven again by day: its frames localise against the survey's nodes.
  const GraphBatch again = CorridorRobotMap({{0}});
  repository.Push(second, robot, "robot-1", again);
  const MergeOutcome merged = repository.Merge(second);
  const std::vector<NodeUsage> before = repository.versions().UsageAt(1);
  const std::vector<NodeUsage> usage = repository.versions().UsageAt(merged.revision.number);
  std::map<Uuid, NodeUsage> earlier;
  for (const NodeUsage& use : before) earlier.emplace(use.node, use);
  std::int64_t survey_frames = 0;
  for (const NodeUsage& use : usage) {
    EXPECT_TRUE(map_nodes.contains(use.node) || !earlier.contains(use.node));
    EXPECT_GT(use.frames, 0);
    EXPECT_LE(use.last_ns, std::max(NewestStamp(survey), NewestStamp(again)));
    const auto was = earlier.find(use.node);
    if (map_nodes.contains(use.node)) {
      survey_frames += use.frames - (was == earlier.end() ? 0 : was->second.frames);
    }
  }
  // Most of a day outing re-driven by day localises against the survey (Np attempts a frame
  // at most): the second merge's use of the survey's nodes counts at least half its frames.
  EXPECT_GE(survey_frames, static_cast<std::int64_t>(again.nodes.size()) / 2);
  // Nothing is unused for a day on this map's clock: a retirement finds nothing to do.
  RetireOptions options;
  options.retire_after_ns = kDay;
  EXPECT_EQ(repository.Retire(options, "depot"), std::nullopt);
  EXPECT_EQ(repository.Head(), merged.revision.number);
}

}  // namespace
}  // namespace fleetmap
