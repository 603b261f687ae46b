// The single-agent EBN builder (seed 002 §III–§IV) on a small corridor scene with two
// appearance conditions, writing through a real SQLite store.
#include "fleetmap/ebn/experience_builder.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <filesystem>
#include <random>
#include <tuple>
#include <unordered_map>

#include "corridor_scene.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_ranking.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

struct OutingSummary {
  int frames = 0, localised = 0, created = 0, attempts = 0;
  double worst_gap_m = 0.0;
};

OutingSummary Drive(ExperienceBuilder& builder, const std::vector<Frame>& frames) {
  OutingStart start;
  start.robot = Uuid::Generate();
  start.outing = Uuid::Generate();
  builder.StartOuting(start);
  OutingSummary summary;
  for (const Frame& frame : frames) {
    const FrameReport report = builder.Process(frame);
    ++summary.frames;
    summary.localised += report.successes > 0 ? 1 : 0;
    summary.created += report.created_experience ? 1 : 0;
    summary.attempts += report.attempts;
    summary.worst_gap_m = std::max(summary.worst_gap_m, report.distance_since_success_m);
    EXPECT_LE(report.attempts, builder.options().cores * builder.options().rounds +
                                   builder.options().relocalisation_candidates);
  }
  builder.FinishOuting();
  return summary;
}

class ExperienceBuilderTest : public ::testing::Test {
 protected:
  void SetUp() override { store_ = GraphStore::Open("sqlite:" + (dir_ / "map.db").string()); }

  static const Corridor& corridor() { return SharedCorridor(); }
  static std::shared_ptr<const AppearanceVocabulary> vocabulary() {
    return SharedCorridorVocabulary();
  }

  ScratchDir dir_{"fleetmap-builder"};
  std::unique_ptr<GraphStore> store_;  // closed before dir_ goes
};

TEST_F(ExperienceBuilderTest, FirstOutingSavesExperiencesOnlyWhereNothingLocalises) {
  ExperienceMap map(vocabulary());
  DistanceRanking policy;
  ExperienceBuilder builder(store_.get(), map, policy, {});
  const std::vector<Frame> frames = corridor().Outing(0);
  const OutingSummary summary = Drive(builder, frames);
  // Each frame is compared with experiences a metre or more away, which share most landmarks
  // with it; only where none exists yet is a node saved. The first frame has nothing.
  EXPECT_GE(summary.created, 1);
  EXPECT_LT(summary.created, summary.frames / 2) << "localises against its own fresh nodes";
  const StoreStats stats = store_->Stats();
  EXPECT_EQ(stats.nodes, summary.created);
  EXPECT_EQ(static_cast<std::size_t>(stats.nodes), map.size());
  EXPECT_EQ(stats.paths, 1);
}

TEST_F(ExperienceBuilderTest, SameConditionLocalisesNewConditionBranchesAndRejoins) {
  ExperienceMap map(vocabulary());
  DistanceRanking policy;
  ExperienceBuilder builder(store_.get(), map, policy, {});
  const OutingSummary day1 = Drive(builder, corridor().Outing(0));
  const OutingSummary day2 = Drive(builder, corridor().Outing(0));
  EXPECT_EQ(day2.created, 0) << "the day map localises the second day";
  EXPECT_EQ(day2.localised, day2.frames);
  EXPECT_EQ(day2.worst_gap_m, 0.0);

  const OutingSummary night = Drive(builder, corridor().Outing(1));
  EXPECT_GT(night.created, 0) << "night shares no landmark with day";
  EXPECT_LT(night.localised, night.frames);
  const std::size_t nodes_after_night = map.size();
  const OutingSummary night2 = Drive(builder, corridor().Outing(1));
  EXPECT_EQ(night2.created, 0) << "the night experiences serve the next night";
  EXPECT_EQ(map.size(), nodes_after_night);

  // The store holds exactly the working map, and reloading it gives the same graph.
  const ExperienceMap reloaded = ExperienceMap::Load(*store_, vocabulary());
  EXPECT_EQ(reloaded.size(), map.size());
  EXPECT_EQ(reloaded.metric_edge_count(), map.metric_edge_count());
  EXPECT_EQ(store_->Stats().paths, 4);
  EXPECT_EQ(day1.created + night.created, static_cast<int>(map.size()));
}

TEST_F(ExperienceBuilderTest, LocaliseOnlyNeverWritesAndRelocalisesWhenLost) {
  ExperienceMap map(vocabulary());
  DistanceRanking build_policy;
  ExperienceBuilder builder(store_.get(), map, build_policy, {});
  Drive(builder, corridor().Outing(0));
  const StoreStats before = store_->Stats();
  const std::size_t nodes_before = map.size();

  DistanceRanking policy;
  ExperienceBuilder localiser(nullptr, map, policy, {.localise_only = true});
  // Starting 40 m down the corridor, lost: only the appearance index can find the place.
  const OutingSummary day = Drive(localiser, corridor().Outing(0, 40.0));
  EXPECT_EQ(day.localised, day.frames);
  EXPECT_EQ(day.created, 0);

  const OutingSummary night = Drive(localiser, corridor().Outing(1));
  EXPECT_EQ(night.localised, 0);
  EXPECT_EQ(night.created, 0);
  EXPECT_NEAR(night.worst_gap_m, Corridor::kLength_m, 1e-9) << "ground truth, not frames";

  EXPECT_EQ(map.size(), nodes_before);
  const StoreStats after = store_->Stats();
  EXPECT_EQ(after.nodes, before.nodes);
  EXPECT_EQ(after.edges, before.edges);
}

TEST_F(ExperienceBuilderTest, PathRankingLearnsPathsFromTheBuild) {
  ExperienceMap map(vocabulary());
  PathRanking policy(PathMemory{}, {});
  ExperienceBuilder builder(store_.get(), map, policy, {.cores = 2});
  Drive(builder, corridor().Outing(0));
  Drive(builder, corridor().Outing(1));
  // Every path edge the builder wrote reached the policy's memory, and the store's copy loads
  // into the same memory.
  EXPECT_EQ(policy.memory().path_count(), 2u);
  const PathMemory loaded = PathMemory::Load(*store_);
  EXPECT_EQ(loaded.path_count(), 2u);
  EXPECT_EQ(loaded.node_count(), policy.memory().node_count());
}

TEST_F(ExperienceBuilderTest, AddsANodeOnFailureAndAPathEdgeWhenTheMatchedNodeChanges) {
  ExperienceMap map(vocabulary());
  DistanceRanking policy;
  ExperienceBuilder builder(store_.get(), map, policy, {});
  Drive(builder, corridor().Outing(0));
  const Uuid dock = map.at(0).node.id;
  const StoreStats before = store_->Stats();

  // Day again from the dock: every frame localises, nothing is added, and each change of the
  // node the robot is localised in is one edge of this outing's path.
  const Uuid day_path = Uuid::Generate();
  builder.StartOuting({Uuid::Generate(), Uuid::Generate(), day_path, dock});
  Uuid previous = dock;
  int changes = 0;
  for (const Frame& frame : corridor().Outing(0)) {
    const FrameReport report = builder.Process(frame);
    ASSERT_GT(report.successes, 0);
    ASSERT_FALSE(report.created_experience);
    if (report.reference != previous) ++changes;
    previous = report.reference;
  }
  builder.FinishOuting();
  EXPECT_EQ(store_->Stats().nodes, before.nodes);
  ASSERT_GT(changes, 0);
  const std::vector<Edge> path_edges = store_->EdgesOfPath(day_path);
  EXPECT_EQ(static_cast<int>(path_edges.size()), changes);
  for (const Edge& edge : path_edges) {
    EXPECT_EQ(edge.kind, EdgeKind::kPath);
    EXPECT_EQ(edge.path, day_path);
    EXPECT_TRUE(store_->FindNode(edge.from).has_value());
    EXPECT_TRUE(store_->FindNode(edge.to).has_value());
  }

  // Night from the dock: the first frame fails against every day node, so it becomes a new
  // node, hung off the dock by a metric edge, and the night path steps onto it.
  const Uuid night_path = Uuid::Generate();
  builder.StartOuting({Uuid::Generate(), Uuid::Generate(), night_path, dock});
  const FrameReport first = builder.Process(corridor().Outing(1).front());
  EXPECT_EQ(first.successes, 0);
  EXPECT_TRUE(first.created_experience);
  builder.FinishOuting();
  EXPECT_EQ(store_->Stats().nodes, before.nodes + 1);
  ASSERT_TRUE(store_->FindNode(first.reference).has_value());
  int metric_from_dock = 0, path_from_dock = 0;
  for (const Edge& edge : store_->EdgesTo(first.reference)) {
    EXPECT_EQ(edge.from, dock);
    metric_from_dock += edge.kind == EdgeKind::kMetric ? 1 : 0;
    path_from_dock += edge.kind == EdgeKind::kPath && edge.path == night_path ? 1 : 0;
  }
  EXPECT_EQ(metric_from_dock, 1);
  EXPECT_EQ(path_from_dock, 1);
}

// The map as its structure: nodes keyed by (outing, stamp), edges by their ends' keys. UUIDs
// of new nodes and edges are random, so two builds are compared through these.
struct MapShape {
  std::vector<std::tuple<Uuid, std::int64_t, std::string>> nodes;
  std::vector<std::tuple<std::int64_t, std::int64_t, int, bool>> edges;  // stamps, kind, path
  bool operator==(const MapShape&) const = default;
};

MapShape ShapeOf(GraphStore& store) {
  MapShape shape;
  std::unordered_map<Uuid, std::int64_t> stamp_of;
  std::vector<Uuid> ids;
  for (const Node& node : store.ListNodes({})) {
    shape.nodes.emplace_back(node.outing, node.stamp_ns, node.landmarks_blob);
    stamp_of[node.id] = node.stamp_ns;
    ids.push_back(node.id);
  }
  for (const Edge& edge : store.EdgesTouching(ids)) {
    shape.edges.emplace_back(stamp_of.at(edge.from), stamp_of.at(edge.to),
                             static_cast<int>(edge.kind), !edge.path.IsNil());
  }
  std::sort(shape.nodes.begin(), shape.nodes.end());
  std::sort(shape.edges.begin(), shape.edges.end());
  return shape;
}

TEST_F(ExperienceBuilderTest, SameFramesSameMap) {
  const Uuid robot = Uuid::Generate();
  const std::array<Uuid, 3> outings = {Uuid::Generate(), Uuid::Generate(), Uuid::Generate()};
  const auto build = [&](GraphStore& store) {
    ExperienceMap map(vocabulary());
    DistanceRanking policy;
    ExperienceBuilder builder(&store, map, policy, {.cores = 2});
    for (std::size_t i = 0; i < outings.size(); ++i) {
      OutingStart start;
      start.robot = robot;
      start.outing = outings[i];
      builder.StartOuting(start);
      for (const Frame& frame : corridor().Outing(static_cast<int>(i % 2))) builder.Process(frame);
      builder.FinishOuting();
    }
    return ShapeOf(store);
  };
  const MapShape first = build(*store_);
  const std::unique_ptr<GraphStore> other =
      GraphStore::Open("sqlite:" + (dir_ / "other.db").string());
  const MapShape second = build(*other);
  ASSERT_FALSE(first.nodes.empty());
  EXPECT_EQ(first.nodes.size(), second.nodes.size());
  EXPECT_EQ(first.edges.size(), second.edges.size());
  EXPECT_TRUE(first == second) << "same frames, same seed: the same experiences and edges";
}

TEST_F(ExperienceBuilderTest, RejectsBadOptionsAndMissingStore) {
  ExperienceMap map(vocabulary());
  DistanceRanking policy;
  EXPECT_THROW(ExperienceBuilder(store_.get(), map, policy, {.cores = 0}), Error);
  EXPECT_THROW(ExperienceBuilder(store_.get(), map, policy, {.rounds = 0}), Error);
  EXPECT_THROW(ExperienceBuilder(nullptr, map, policy, {}), Error);
  ExperienceBuilder builder(store_.get(), map, policy, {});
  EXPECT_THROW(builder.Process(Frame{}), Error);
}

}  // namespace
}  // namespace fleetmap
