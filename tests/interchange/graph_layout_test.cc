// The graph layout (fleetmap/interchange/graph_layout.h): poses composed from metric edges
// breadth first from each component's earliest node, checked against poses worked out by hand
// or from a survey.
#include "fleetmap/interchange/graph_layout.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "expect_error.h"
#include "export_test_map.h"
#include "numbered_uuid.h"
#include "surveyed_map.h"

namespace fleetmap {
namespace {

using testing::SurveyPose;

Node NodeAt(int number, std::int64_t stamp_ns) {
  return Node{NumberedUuid(number), stamp_ns, NumberedUuid(900), NumberedUuid(901), ""};
}

Edge Metric(int number, int from, int to, const Se3& from_T_to) {
  return Edge{NumberedUuid(number), NumberedUuid(from), NumberedUuid(to),
              EdgeKind::kMetric,    from_T_to,          Uuid()};
}

const LaidOutNode& Placed(const GraphLayout& layout, int number) {
  const std::optional<std::size_t> index = layout.IndexOf(NumberedUuid(number));
  if (!index) throw std::runtime_error("node " + std::to_string(number) + " not laid out");
  return layout.nodes()[*index];
}

// Exact equality: the layout composes the same products the test writes down.
void ExpectPose(const Se3& expected, const Se3& actual, double tolerance = 1e-12) {
  EXPECT_TRUE(Se3ApproxEqual(expected, actual, tolerance, tolerance))
      << "expected\n"
      << expected.matrix() << "\nactual\n"
      << actual.matrix();
}

TEST(GraphLayoutTest, AChainComposesItsEdgesForwardsAndBackwards) {
  const Se3 one_T_two = SurveyPose(0.5, {0, 0, 1}, {1, 0, 0});
  const Se3 three_T_two = SurveyPose(-0.3, {0, 1, 0}, {0, 2, 0});  // stored from the later node
  const Se3 three_T_four = SurveyPose(1.1, {1, 1, 0}, {0, 0, 3});
  // Read in an order that is neither the stamps' nor the ids'.
  const std::vector<Node> nodes = {NodeAt(3, 300), NodeAt(1, 100), NodeAt(4, 400), NodeAt(2, 200)};
  const std::vector<Edge> edges = {Metric(11, 1, 2, one_T_two), Metric(12, 3, 2, three_T_two),
                                   Metric(13, 3, 4, three_T_four)};
  const GraphLayout layout = GraphLayout::Compute(nodes, edges);

  ASSERT_EQ(layout.nodes().size(), 4u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(layout.nodes()[i].id, NumberedUuid(i + 1));
  ASSERT_EQ(layout.component_count(), 1u);
  EXPECT_EQ(layout.references(), std::vector<std::size_t>{0});
  EXPECT_TRUE(Placed(layout, 1).layout_T_node.matrix() == Se3::Identity().matrix());
  ExpectPose(one_T_two, Placed(layout, 2).layout_T_node);
  ExpectPose(one_T_two * three_T_two.inverse(), Placed(layout, 3).layout_T_node);
  ExpectPose(one_T_two * three_T_two.inverse() * three_T_four, Placed(layout, 4).layout_T_node);
  for (int n = 1; n <= 4; ++n) EXPECT_EQ(Placed(layout, n).component, 0);
}

// Another layout of the same map (a relaxation's) keeps every node's number, component, robot
// and outing and changes only poses; the references stay the frames, so moving one is refused,
// as is a pose count that is not the node count.
TEST(GraphLayoutTest, WithPosesKeepsTheNodesAndTheirFramesAndChangesOnlyPoses) {
  const std::vector<Node> nodes = {NodeAt(1, 100), NodeAt(2, 200), NodeAt(3, 300)};
  const std::vector<Edge> edges = {Metric(11, 1, 2, SurveyPose(0.5, {0, 0, 1}, {1, 0, 0}))};
  const GraphLayout layout = GraphLayout::Compute(nodes, edges);
  ASSERT_EQ(layout.component_count(), 2u);
  const Se3 moved = SurveyPose(0.2, {0, 1, 0}, {3, 0, 4});
  const GraphLayout other = layout.WithPoses({Se3::Identity(), moved, Se3::Identity()});
  ASSERT_EQ(other.nodes().size(), 3u);
  EXPECT_EQ(other.references(), layout.references());
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(other.nodes()[i].id, layout.nodes()[i].id);
    EXPECT_EQ(other.nodes()[i].component, layout.nodes()[i].component);
    EXPECT_EQ(other.nodes()[i].robot, NumberedUuid(900));
    EXPECT_EQ(other.nodes()[i].outing, NumberedUuid(901));
  }
  EXPECT_TRUE(Placed(other, 2).layout_T_node.matrix() == moved.matrix());
  EXPECT_EQ(other.IndexOf(NumberedUuid(3)), layout.IndexOf(NumberedUuid(3)));
  EXPECT_THROW(layout.WithPoses({Se3::Identity(), moved}), Error);
  EXPECT_THROW(layout.WithPoses({Se3::Identity(), moved, moved}), Error);  // node 3: a reference
}

// A loop whose closing edge disagrees with the rest: breadth first from node 1, node 4 is
// reached first across the closing edge (one hop, backwards) and node 3 through node 2 (two
// hops; node 2 is dequeued before node 4 because edge 21 < edge 24). Those poses stand.
TEST(GraphLayoutTest, AroundALoopTheFirstPoseReachedWins) {
  const Se3 one_T_two = SurveyPose(0.2, {0, 0, 1}, {1, 0, 0});
  const Se3 two_T_three = SurveyPose(0.4, {0, 0, 1}, {1, 0.5, 0});
  const Se3 three_T_four = SurveyPose(0.6, {0, 0, 1}, {1, 1, 0});
  const Se3 four_T_one = SurveyPose(-0.1, {1, 0, 0}, {-5, 9, 2});  // far from the chain's sum
  std::vector<Node> nodes = {NodeAt(1, 10), NodeAt(2, 20), NodeAt(3, 30), NodeAt(4, 40)};
  std::vector<Edge> edges = {Metric(21, 1, 2, one_T_two), Metric(22, 2, 3, two_T_three),
                             Metric(23, 3, 4, three_T_four), Metric(24, 4, 1, four_T_one)};
  const GraphLayout layout = GraphLayout::Compute(nodes, edges);
  ExpectPose(one_T_two, Placed(layout, 2).layout_T_node);
  ExpectPose(one_T_two * two_T_three, Placed(layout, 3).layout_T_node);
  ExpectPose(four_T_one.inverse(), Placed(layout, 4).layout_T_node);
  EXPECT_FALSE(Se3ApproxEqual(Placed(layout, 4).layout_T_node,
                              one_T_two * two_T_three * three_T_four, 1e-3, 1e-3));

  // The same graph read in any order lays out the same.
  std::mt19937 random(5);
  for (int shuffle = 0; shuffle < 5; ++shuffle) {
    std::shuffle(nodes.begin(), nodes.end(), random);
    std::shuffle(edges.begin(), edges.end(), random);
    const GraphLayout again = GraphLayout::Compute(nodes, edges);
    for (int n = 1; n <= 4; ++n) {
      EXPECT_TRUE(Placed(again, n).layout_T_node.matrix() ==
                  Placed(layout, n).layout_T_node.matrix())
          << "node " << n << " after shuffle " << shuffle;
    }
  }
}

TEST(GraphLayoutTest, EachComponentHasItsOwnFrameAndPathEdgesJoinNothing) {
  const testing::ExportTestMap test_map;
  GraphBatch map = test_map.map();
  // A path edge between the two robots' outings: it carries no pose and must not join them.
  map.edges.push_back(Edge{Uuid::Generate(), test_map.a_nodes.back(), test_map.b_nodes.front(),
                           EdgeKind::kPath, Se3::Identity(), map.paths[0].id});
  const GraphLayout layout = GraphLayout::Compute(map.nodes, map.edges);

  ASSERT_EQ(layout.component_count(), 3u);
  const std::vector<Uuid> numbered = test_map.NumberedIds();
  ASSERT_EQ(layout.nodes().size(), numbered.size());
  for (std::size_t i = 0; i < numbered.size(); ++i) {
    const LaidOutNode& placed = layout.nodes()[i];
    EXPECT_EQ(placed.id, numbered[i]);
    EXPECT_EQ(layout.IndexOf(placed.id), i);
    EXPECT_EQ(placed.component, test_map.component.at(placed.id)) << i;
    ExpectPose(test_map.ExpectedPose(placed.id), placed.layout_T_node, 1e-9);
  }
  const std::vector<std::size_t> references = {*layout.IndexOf(test_map.a_nodes.front()),
                                               *layout.IndexOf(test_map.b_nodes.front()),
                                               *layout.IndexOf(test_map.b_nodes.back())};
  EXPECT_EQ(layout.references(), references);
  EXPECT_FALSE(layout.IndexOf(Uuid::Generate()).has_value());
}

TEST(GraphLayoutTest, ALoneNodeIsAComponentAtTheOrigin) {
  const GraphLayout layout = GraphLayout::Compute({NodeAt(7, 5)}, {});
  ASSERT_EQ(layout.nodes().size(), 1u);
  EXPECT_EQ(layout.component_count(), 1u);
  EXPECT_EQ(layout.nodes()[0].component, 0);
  EXPECT_TRUE(layout.nodes()[0].layout_T_node.matrix() == Se3::Identity().matrix());
}

TEST(GraphLayoutTest, AnEmptyGraphHasNoComponents) {
  const GraphLayout layout = GraphLayout::Compute({}, {});
  EXPECT_TRUE(layout.nodes().empty());
  EXPECT_EQ(layout.component_count(), 0u);
  EXPECT_TRUE(layout.references().empty());
}

TEST(GraphLayoutTest, NodesWithTheSameStampAreNumberedByUuid) {
  const GraphLayout layout =
      GraphLayout::Compute({NodeAt(9, 50), NodeAt(3, 50), NodeAt(5, 10)},
                           {Metric(30, 9, 3, SurveyPose(0.1, {0, 0, 1}, {1, 2, 3}))});
  ASSERT_EQ(layout.nodes().size(), 3u);
  EXPECT_EQ(layout.nodes()[0].id, NumberedUuid(5));
  EXPECT_EQ(layout.nodes()[1].id, NumberedUuid(3));
  EXPECT_EQ(layout.nodes()[2].id, NumberedUuid(9));
  // Node 3 is the earlier of its component (same stamp, lower UUID): its frame is the layout's.
  EXPECT_EQ(layout.references(), (std::vector<std::size_t>{0, 1}));
  ExpectPose(SurveyPose(0.1, {0, 0, 1}, {1, 2, 3}).inverse(), Placed(layout, 9).layout_T_node);
}

TEST(GraphLayoutTest, RefusesANodeTwiceAndAnEdgeToNowhere) {
  ExpectError(
      ErrorCode::kInvalidArgument,
      [] {
        GraphLayout::Compute({NodeAt(1, 1), NodeAt(1, 2)}, {});
      },
      NumberedUuid(1).ToString());
  ExpectError(
      ErrorCode::kIntegrity,
      [] { GraphLayout::Compute({NodeAt(1, 1)}, {Metric(40, 1, 2, Se3::Identity())}); },
      NumberedUuid(40).ToString());
  // A path edge to nowhere too: the exports write every edge.
  const Edge path_edge{NumberedUuid(41), NumberedUuid(3), NumberedUuid(1),
                       EdgeKind::kPath,  Se3::Identity(), NumberedUuid(50)};
  ExpectError(
      ErrorCode::kIntegrity, [&] { GraphLayout::Compute({NodeAt(1, 1)}, {path_edge}); },
      NumberedUuid(3).ToString());
}

}  // namespace
}  // namespace fleetmap
