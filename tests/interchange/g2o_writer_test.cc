// g2o export (fleetmap/interchange/g2o_writer.h), read back by the test's own g2o reader
// (g2o_reader.h): vertices numbered by (stamp, UUID) at the surveyed poses, a FIX per
// component, one edge per metric edge measuring from_T_to with the identity information matrix.
#include "fleetmap/interchange/g2o_writer.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <sstream>

#include "expect_error.h"
#include "export_test_map.h"
#include "g2o_reader.h"

namespace fleetmap {
namespace {

TEST(G2oWriterTest, VerticesEdgesAndFixesMatchTheSurvey) {
  const testing::ExportTestMap test_map;
  const GraphBatch& map = test_map.map();
  std::ostringstream out;
  const G2oCounts counts = WriteG2oPoseGraph(map, GraphLayout::Compute(map.nodes, map.edges), out);
  const testing::G2oGraph graph = testing::ReadG2o(out.str());

  const std::vector<Uuid> numbered = test_map.NumberedIds();
  ASSERT_EQ(graph.vertices.size(), numbered.size());
  EXPECT_EQ(counts.vertices, numbered.size());
  std::map<Uuid, long long> id_of;
  for (std::size_t i = 0; i < numbered.size(); ++i) {
    EXPECT_EQ(graph.vertex_order[i], static_cast<long long>(i));
    id_of[numbered[i]] = static_cast<long long>(i);
    const testing::G2oPose& vertex = graph.vertices.at(static_cast<long long>(i));
    const Se3 expected = test_map.ExpectedPose(numbered[i]);
    EXPECT_LT((vertex.translation - expected.translation()).norm(), 1e-9)
        << "vertex " << i << ": " << vertex.translation.transpose() << " vs "
        << expected.translation().transpose();
    EXPECT_NEAR(vertex.rotation.norm(), 1.0, 1e-12) << i;
    EXPECT_GE(vertex.rotation.w(), 0.0) << i;
    EXPECT_LT(testing::AngleBetween(vertex.rotation, Eigen::Quaterniond(expected.rotation())), 1e-9)
        << i;
  }

  // One FIX per component, at its first node.
  const std::set<long long> fixed = {id_of.at(test_map.a_nodes.front()),
                                     id_of.at(test_map.b_nodes.front()),
                                     id_of.at(test_map.b_nodes.back())};
  EXPECT_EQ(graph.fixed, fixed);
  EXPECT_EQ(counts.fixed, 3u);

  // Every metric edge and nothing else, measuring from_T_to, weighed by the identity.
  std::map<std::pair<long long, long long>, const Edge*> metric;
  for (const Edge& edge : map.edges) {
    if (edge.kind == EdgeKind::kMetric) metric[{id_of.at(edge.from), id_of.at(edge.to)}] = &edge;
  }
  ASSERT_EQ(graph.edges.size(), metric.size());
  EXPECT_EQ(counts.edges, metric.size());
  for (const testing::G2oEdge& edge : graph.edges) {
    const auto found = metric.find({edge.from, edge.to});
    ASSERT_NE(found, metric.end()) << edge.from << " -> " << edge.to;
    const Se3& from_T_to = found->second->from_T_to;
    EXPECT_LT((edge.measurement.translation - from_T_to.translation()).norm(), 1e-12);
    EXPECT_NEAR(edge.measurement.rotation.norm(), 1.0, 1e-12);
    EXPECT_LT(
        testing::AngleBetween(edge.measurement.rotation, Eigen::Quaterniond(from_T_to.rotation())),
        1e-9);
    EXPECT_TRUE(edge.information == (Eigen::Matrix<double, 6, 6>::Identity())) << edge.information;
    metric.erase(found);
  }
  EXPECT_TRUE(metric.empty());
}

TEST(G2oWriterTest, VertexPosesComposeAlongEveryEdgeOfALoopThatAgrees) {
  // The survey's loop (A4 -> A1) agrees with the chain, so each edge's measurement carries its
  // `from` vertex onto its `to` vertex: what an optimiser starting here would find at rest.
  const testing::ExportTestMap test_map;
  const GraphBatch& map = test_map.map();
  std::ostringstream out;
  WriteG2oPoseGraph(map, GraphLayout::Compute(map.nodes, map.edges), out);
  const testing::G2oGraph graph = testing::ReadG2o(out.str());
  const auto pose = [](const testing::G2oPose& p) {
    Se3 a_T_b = Se3::Identity();
    a_T_b.linear() = p.rotation.normalized().toRotationMatrix();
    a_T_b.translation() = p.translation;
    return a_T_b;
  };
  for (const testing::G2oEdge& edge : graph.edges) {
    const Se3 from = pose(graph.vertices.at(edge.from));
    const Se3 to = pose(graph.vertices.at(edge.to));
    EXPECT_TRUE(Se3ApproxEqual(from * pose(edge.measurement), to, 1e-9, 1e-9))
        << edge.from << " -> " << edge.to;
  }
}

TEST(G2oWriterTest, AnEmptyMapWritesNothing) {
  std::ostringstream out;
  const G2oCounts counts = WriteG2oPoseGraph(GraphBatch{}, GraphLayout::Compute({}, {}), out);
  EXPECT_EQ(out.str(), "");
  EXPECT_EQ(counts.vertices + counts.edges + counts.fixed, 0u);
}

TEST(G2oWriterTest, ALayoutOfAnotherMapIsRefused) {
  const testing::ExportTestMap test_map, other;
  std::ostringstream out;
  ExpectError(ErrorCode::kInvalidArgument, [&] {
    WriteG2oPoseGraph(test_map.map(), GraphLayout::Compute(other.map().nodes, {}), out);
  });
}

}  // namespace
}  // namespace fleetmap
