// The relaxed layout (relaxed_layout.h): a loop that drifted closes, a wrong match between
// outings does not bend the map, components keep their own frames, and one map relaxes to the
// same poses every time.
#include "fleetmap/relaxation/relaxed_layout.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

#include "fleetmap/core/se3.h"
#include "fleetmap/interchange/graph_layout.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

Se3 Pose(double x, double z, double yaw) {
  // Camera frames: y down, so a turn on the ground is a rotation about y.
  return Se3FromTranslationQuaternion(
      Eigen::Vector3d(x, 0.0, z),
      Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitY())));
}

struct Map {
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Se3> truth;  // by node, in the first node's frame
};

Node MakeNode(int number, int outing) {
  Node node;
  node.id = NumberedUuid(number);
  node.stamp_ns = number;
  node.robot = NumberedUuid(9000);
  node.outing = NumberedUuid(8000 + outing);
  return node;
}

Edge MakeEdge(int number, const Node& from, const Node& to, const Se3& from_T_to) {
  Edge edge;
  edge.id = NumberedUuid(number);
  edge.from = from.id;
  edge.to = to.id;
  edge.kind = EdgeKind::kMetric;
  edge.from_T_to = from_T_to;
  return edge;
}

// An outing of `count` nodes around a circle of 20 m, its odometry biased by `yaw_bias` radians
// a step (drift), and a second outing that revisits its first and last nodes' places, matched to
// both (edges between outings, measured without error).
// Nodes are numbered from `first` (their stamps too), edges from 100 * first.
Map DriftedLoop(int count, double yaw_bias, int first = 0) {
  Map map;
  const double radius = 20.0;
  const double step = 2.0 * M_PI / count;
  for (int i = 0; i < count; ++i) {
    map.nodes.push_back(MakeNode(first + i, 0));
    const double angle = step * i;
    const Se3 world_T_node =
        Pose(radius * std::sin(angle), radius * (1.0 - std::cos(angle)), -angle);
    map.truth.push_back(world_T_node);
  }
  for (int i = 0; i + 1 < count; ++i) {
    const Se3 measured = map.truth[i].inverse() * map.truth[i + 1] * Pose(0.0, 0.0, yaw_bias);
    map.edges.push_back(MakeEdge(100 * first + 1000 + i, map.nodes[i], map.nodes[i + 1], measured));
  }
  // The revisit: one node of outing 1 where the loop closes, matched to both ends.
  map.nodes.push_back(MakeNode(first + count, 1));
  map.truth.push_back(map.truth[0] * Pose(0.5, 0.0, 0.0));
  const Node& visitor = map.nodes.back();
  for (const int end : {0, count - 1}) {
    map.edges.push_back(MakeEdge(100 * first + 2000 + end, map.nodes[end], visitor,
                                 map.truth[end].inverse() * map.truth[count]));
  }
  return map;
}

double WorstError(const GraphLayout& layout, const Map& map) {
  double worst = 0.0;
  for (std::size_t i = 0; i < map.nodes.size(); ++i) {
    const std::size_t at = *layout.IndexOf(map.nodes[i].id);
    // Node 0 is the reference (earliest), and the truth is in its frame.
    const Eigen::Vector3d truth = (map.truth[0].inverse() * map.truth[i]).translation();
    worst = std::max(worst, (layout.nodes()[at].layout_T_node.translation() - truth).norm());
  }
  return worst;
}

TEST(RelaxedLayout, ALoopThatDriftedClosesAndComesNearerTheTruth) {
  const Map map = DriftedLoop(60, 0.004);
  const GraphLayout composed = GraphLayout::Compute(map.nodes, map.edges);
  RelaxationReport report;
  const GraphLayout relaxed = RelaxLayout(composed, map.edges, {}, &report);
  EXPECT_TRUE(report.failure.empty()) << report.failure;
  EXPECT_EQ(report.edges, map.edges.size());
  EXPECT_EQ(report.edges_between_outings, 2u);
  EXPECT_EQ(report.nodes, map.nodes.size());
  EXPECT_LT(report.final_cost, report.initial_cost);
  const double composed_error = WorstError(composed, map);
  const double relaxed_error = WorstError(relaxed, map);
  EXPECT_GT(composed_error, 1.0);  // the drift shows: the loop's ends are metres apart
  EXPECT_LT(relaxed_error, composed_error / 3.0) << composed_error;
  // Same nodes, numbers, components and references; the reference stays the frame.
  ASSERT_EQ(relaxed.nodes().size(), composed.nodes().size());
  for (std::size_t i = 0; i < relaxed.nodes().size(); ++i) {
    EXPECT_EQ(relaxed.nodes()[i].id, composed.nodes()[i].id);
    EXPECT_EQ(relaxed.nodes()[i].component, composed.nodes()[i].component);
  }
  EXPECT_EQ(relaxed.references(), composed.references());
  EXPECT_EQ(relaxed.nodes()[relaxed.references()[0]].layout_T_node.matrix(),
            Se3::Identity().matrix());
}

TEST(RelaxedLayout, AWrongMatchBetweenOutingsDoesNotBendTheMap) {
  Map map = DriftedLoop(60, 0.0);  // odometry exact: the truth is a solution
  // A wrong match: the visitor also "recognised" the place half the loop away, 40 m off.
  map.edges.push_back(MakeEdge(3000, map.nodes[30], map.nodes.back(), Pose(0.0, 0.0, 0.0)));
  const GraphLayout composed = GraphLayout::Compute(map.nodes, map.edges);
  RelaxationReport report;
  const GraphLayout relaxed = RelaxLayout(composed, map.edges, {}, &report);
  EXPECT_EQ(report.edges_between_outings, 3u);
  EXPECT_LT(WorstError(relaxed, map), 1.0);

  // The same wrong edge within one outing is trusted, and pulls the map out of shape: what the
  // robust loss is for.
  Map trusted = map;
  trusted.nodes.back().outing = trusted.nodes.front().outing;
  const GraphLayout bent =
      RelaxLayout(GraphLayout::Compute(trusted.nodes, trusted.edges), trusted.edges);
  EXPECT_GT(WorstError(bent, trusted), 3.0);
}

TEST(RelaxedLayout, ComponentsKeepTheirOwnFramesAndLoneNodesTheirPlace) {
  const Map first = DriftedLoop(30, 0.01);
  const Map second = DriftedLoop(30, -0.01, 100);
  Map both = first;
  both.nodes.insert(both.nodes.end(), second.nodes.begin(), second.nodes.end());
  both.edges.insert(both.edges.end(), second.edges.begin(), second.edges.end());
  both.nodes.push_back(MakeNode(400, 2));  // no edge at all
  const GraphLayout composed = GraphLayout::Compute(both.nodes, both.edges);
  ASSERT_EQ(composed.component_count(), 3u);
  RelaxationReport report;
  const GraphLayout relaxed = RelaxLayout(composed, both.edges, {}, &report);
  EXPECT_EQ(report.nodes, both.nodes.size() - 1);
  EXPECT_EQ(relaxed.references(), composed.references());
  for (const std::size_t reference : relaxed.references()) {
    EXPECT_EQ(relaxed.nodes()[reference].layout_T_node.matrix(), Se3::Identity().matrix());
  }
  // Each loop closes in its own frame, as if relaxed alone (to the solver's tolerance: the two
  // problems stop at different iterations).
  for (const Map* loop : {&first, &second}) {
    Map alone = *loop;
    const GraphLayout by_itself =
        RelaxLayout(GraphLayout::Compute(alone.nodes, alone.edges), alone.edges);
    for (const Node& node : alone.nodes) {
      const Se3& together = relaxed.nodes()[*relaxed.IndexOf(node.id)].layout_T_node;
      const Se3& apart = by_itself.nodes()[*by_itself.IndexOf(node.id)].layout_T_node;
      EXPECT_LT((together.translation() - apart.translation()).norm(), 1e-3);
    }
  }
  const std::size_t lone = *relaxed.IndexOf(NumberedUuid(400));
  EXPECT_EQ(relaxed.nodes()[lone].layout_T_node.matrix(), Se3::Identity().matrix());
}

TEST(RelaxedLayout, OneMapRelaxesToTheSamePosesEveryTime) {
  const Map map = DriftedLoop(80, 0.003);
  const GraphLayout composed = GraphLayout::Compute(map.nodes, map.edges);
  const GraphLayout once = RelaxLayout(composed, map.edges);
  // The edges in another order: the solve orders them itself.
  std::vector<Edge> reversed(map.edges.rbegin(), map.edges.rend());
  const GraphLayout again = RelaxLayout(GraphLayout::Compute(map.nodes, reversed), reversed);
  ASSERT_EQ(once.nodes().size(), again.nodes().size());
  for (std::size_t i = 0; i < once.nodes().size(); ++i) {
    EXPECT_EQ(once.nodes()[i].layout_T_node.matrix(), again.nodes()[i].layout_T_node.matrix()) << i;
  }
}

// A map larger than max_nodes is not relaxed (its solve would take too long where a picture is
// drawn): the composed layout comes back and the report says why.
TEST(RelaxedLayout, AMapBeyondMaxNodesStaysComposedAndSaysWhy) {
  const Map map = DriftedLoop(60, 0.004);
  const GraphLayout composed = GraphLayout::Compute(map.nodes, map.edges);
  RelaxationOptions options;
  options.max_nodes = 60;  // the loop has 61
  RelaxationReport report;
  const GraphLayout layout = RelaxLayout(composed, map.edges, options, &report);
  EXPECT_EQ(report.failure, "61 nodes, more than the 60 relaxed here");
  EXPECT_EQ(report.iterations, 0);
  for (std::size_t i = 0; i < layout.nodes().size(); ++i) {
    EXPECT_EQ(layout.nodes()[i].layout_T_node.matrix(), composed.nodes()[i].layout_T_node.matrix());
  }
  options.max_nodes = 61;
  RelaxLayout(composed, map.edges, options, &report);
  EXPECT_TRUE(report.failure.empty()) << report.failure;
  EXPECT_GT(report.iterations, 0);
}

TEST(RelaxedLayout, AnEdgeOfNoFinitePoseGivesTheComposedLayoutAndSaysWhy) {
  Map map = DriftedLoop(10, 0.0);
  map.edges.front().from_T_to.translation().x() = std::numeric_limits<double>::quiet_NaN();
  const GraphLayout composed = GraphLayout::Compute(map.nodes, map.edges);
  RelaxationReport report;
  const GraphLayout relaxed = RelaxLayout(composed, map.edges, {}, &report);
  EXPECT_FALSE(report.failure.empty());
  for (std::size_t i = 0; i < relaxed.nodes().size(); ++i) {
    const Eigen::Matrix4d a = relaxed.nodes()[i].layout_T_node.matrix();
    const Eigen::Matrix4d b = composed.nodes()[i].layout_T_node.matrix();
    EXPECT_TRUE(
        (a.array() == b.array() || (a.array() != a.array() && b.array() != b.array())).all());
  }
}

}  // namespace
}  // namespace fleetmap
