// Dreaming (seed 004 §VI-E): groups merged in every order as a prefix tree of real merges, each
// candidate map scored, the best kept.
#include "fleetmap/map_management/dreaming.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <set>

#include "corridor_robot_map.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// A robot's map of one corridor outing (0: day, 1: night), from `start_m` metres.
GraphBatch GroupMap(int condition, double start_m = 0.0) {
  return CorridorRobotMap({{condition, start_m}});
}

TEST(Dreaming, EveryOrderRunsOnSharedPrefixesAndTheBestIsKept) {
  // Two day maps (the second of only the corridor's far half) and a night map.
  const std::vector<GraphBatch> groups = {GroupMap(0), GroupMap(1), GroupMap(0, 60.0)};
  std::set<std::vector<int>> scored;
  // Score: fewer nodes is better, so the orders differ by what MERGE kept.
  const DreamScorer scorer = [&](const DreamCandidate& candidate) {
    EXPECT_EQ(candidate.order->size(), 3u);
    EXPECT_TRUE(scored.insert(*candidate.order).second) << "an order scored twice";
    EXPECT_EQ(candidate.map->size(), candidate.content->nodes.size());
    return static_cast<double>(candidate.content->nodes.size());
  };
  std::size_t progress_calls = 0;
  const DreamResult result = Dream(groups, GraphBatch{}, SharedCorridorVocabulary(), scorer, {},
                                   [&](std::size_t done, std::size_t all) {
                                     ++progress_calls;
                                     EXPECT_LE(done, all);
                                   });
  EXPECT_EQ(scored.size(), 6u);  // 3!
  ASSERT_EQ(result.orders.size(), 6u);
  EXPECT_EQ(progress_calls, result.plan.steps.size());
  // The prefix tree: 3 + 6 + 6 steps, merges into a parent 6 + 6 = 12, where Eq. 8 counts
  // k!(k - 1) = 12 as well for k = 3; the first three merge into the empty base.
  EXPECT_EQ(result.merge_seconds.size(), result.plan.merges);
  EXPECT_EQ(result.first_merge_seconds.size(), 3u);
  EXPECT_EQ(result.copy_seconds.size(), result.plan.copies);
  // The best is the lowest score, and its content is that order's whole map.
  const auto best =
      std::min_element(result.orders.begin(), result.orders.end(),
                       [](const auto& a, const auto& b) { return a.score < b.score; });
  EXPECT_EQ(result.best, static_cast<std::size_t>(best - result.orders.begin()));
  EXPECT_EQ(result.best_content.nodes.size(), result.orders[result.best].nodes);
  // Whatever the order, the night map is new to every day map: each candidate holds it.
  std::set<Uuid> best_nodes;
  for (const Node& node : result.best_content.nodes) best_nodes.insert(node.id);
  std::size_t night_kept = 0;
  for (const Node& node : groups[1].nodes) night_kept += best_nodes.contains(node.id) ? 1 : 0;
  EXPECT_GE(night_kept, groups[1].nodes.size() / 2);
  // The far-half day map is redundant beside the whole day map in either order: merged first,
  // the half stays and the whole adds only its near half (the stretch across the half's start
  // is added from its first frame that did not localise: merge.cc Decide); merged after, the
  // half is omitted. So no order holds much more than the whole day map and the night map.
  for (const DreamOrderResult& order : result.orders) {
    EXPECT_LE(order.nodes,
              groups[0].nodes.size() + groups[1].nodes.size() + groups[2].nodes.size() / 5)
        << "order " << order.order[0] << order.order[1] << order.order[2];
  }
}

TEST(Dreaming, ASampleOfOrdersAndBadArguments) {
  const std::vector<GraphBatch> groups = {GroupMap(0), GroupMap(1), GroupMap(0, 60.0)};
  const DreamScorer count = [](const DreamCandidate& c) {
    return static_cast<double>(c.map->size());
  };
  DreamOptions options;
  options.max_orders = 2;
  const DreamResult sample =
      Dream(groups, GraphBatch{}, SharedCorridorVocabulary(), count, options);
  EXPECT_EQ(sample.orders.size(), 2u);
  EXPECT_THROW(Dream(groups, GraphBatch{}, nullptr, count), Error);
  EXPECT_THROW(Dream(groups, GraphBatch{}, SharedCorridorVocabulary(), DreamScorer{}), Error);
  EXPECT_THROW(Dream({}, GraphBatch{}, SharedCorridorVocabulary(), count), Error);
  // A group whose content MERGE refuses is named.
  std::vector<GraphBatch> bad = groups;
  bad[1].nodes.front().landmarks_blob = "not landmarks";
  try {
    Dream(bad, GraphBatch{}, SharedCorridorVocabulary(), count);
    ADD_FAILURE() << "a corrupt group was dreamt";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kCorrupt);
    EXPECT_NE(std::string(error.what()).find("group 1"), std::string::npos) << error.what();
  }
}

// A robot builds on what it pushed before: its second group has an edge into its first. An order
// that merges the second first finds that end in neither the map nor the group; the dream used
// to fail whole ("group 1: merge: edge ... in neither the submission nor the server", seen in
// the fleet soak). That order now merges without the edge, and every order is scored.
TEST(Dreaming, AGroupBuiltOnAnotherGroupDreamsInEveryOrder) {
  const GraphBatch first = GroupMap(0);
  GraphBatch second = GroupMap(1, 30.0);
  Edge onto_first;
  onto_first.id = Uuid::Generate();
  onto_first.from = first.nodes.back().id;
  onto_first.to = second.nodes.front().id;
  onto_first.kind = EdgeKind::kMetric;
  second.edges.push_back(onto_first);
  const std::vector<GraphBatch> groups = {first, second};
  const DreamScorer count = [](const DreamCandidate& c) {
    return static_cast<double>(c.map->size());
  };
  const DreamResult result = Dream(groups, GraphBatch{}, SharedCorridorVocabulary(), count);
  EXPECT_EQ(result.orders.size(), 2u);
}

}  // namespace
}  // namespace fleetmap
