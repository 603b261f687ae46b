// GraphML export (fleetmap/interchange/graphml_writer.h), parsed as XML by the test's own
// reader (xml_reader.h, graphml_reader.h): declared keys, every node and edge with its
// attributes, the layout's positions, and text escaped so that it reads back as written.
#include "fleetmap/interchange/graphml_writer.h"

#include <gtest/gtest.h>

#include <map>
#include <sstream>

#include "expect_error.h"
#include "export_test_map.h"
#include "graphml_reader.h"

namespace fleetmap {
namespace {

std::string Export(const GraphBatch& map, std::string_view description) {
  std::ostringstream out;
  WriteGraphMl(map, GraphLayout::Compute(map.nodes, map.edges), description, out);
  return out.str();
}

TEST(GraphMlWriterTest, NodesAndEdgesCarryTheirAttributesAndLayoutPositions) {
  const testing::ExportTestMap test_map;
  const GraphBatch& map = test_map.map();
  const testing::GraphMlGraph graph = testing::ReadGraphMl(Export(map, "revision 3"));

  EXPECT_EQ(graph.edgedefault, "directed");
  EXPECT_EQ(graph.description, "revision 3");
  const std::map<std::string, std::pair<std::string, std::string>> declared = {
      {"uuid", {"node", "string"}},   {"stamp_ns", {"node", "long"}},
      {"robot", {"node", "string"}},  {"outing", {"node", "string"}},
      {"landmarks", {"node", "int"}}, {"component", {"node", "int"}},
      {"x", {"node", "double"}},      {"y", {"node", "double"}},
      {"z", {"node", "double"}},      {"edge_uuid", {"edge", "string"}},
      {"kind", {"edge", "string"}},   {"path", {"edge", "string"}},
      {"tx", {"edge", "double"}},     {"ty", {"edge", "double"}},
      {"tz", {"edge", "double"}},     {"qw", {"edge", "double"}},
      {"qx", {"edge", "double"}},     {"qy", {"edge", "double"}},
      {"qz", {"edge", "double"}}};
  ASSERT_EQ(graph.keys.size(), declared.size());
  for (const auto& [id, key] : graph.keys) {
    const auto expected = declared.find(key.name);
    ASSERT_NE(expected, declared.end()) << key.name;
    EXPECT_EQ(key.domain, expected->second.first) << key.name;
    EXPECT_EQ(key.type, expected->second.second) << key.name;
  }

  // Nodes n0, n1, ... in (stamp, UUID) order.
  const std::vector<Uuid> numbered = test_map.NumberedIds();
  ASSERT_EQ(graph.nodes.size(), numbered.size());
  std::map<std::string, Uuid> uuid_of_node;
  for (std::size_t i = 0; i < numbered.size(); ++i) {
    const testing::GraphMlItem& node = graph.nodes[i];
    const Node& stored = *std::find_if(map.nodes.begin(), map.nodes.end(),
                                       [&](const Node& n) { return n.id == numbered[i]; });
    EXPECT_EQ(node.id, "n" + std::to_string(i));
    uuid_of_node[node.id] = numbered[i];
    EXPECT_EQ(node.Data("uuid"), stored.id.ToString());
    EXPECT_EQ(node.Data("stamp_ns"), std::to_string(stored.stamp_ns));
    EXPECT_EQ(node.Data("robot"), stored.robot.ToString());
    EXPECT_EQ(node.Data("outing"), stored.outing.ToString());
    EXPECT_EQ(node.Data("landmarks"),
              std::to_string(test_map.surveyed.landmarks.at(stored.id).size()));
    EXPECT_EQ(node.Data("component"), std::to_string(test_map.component.at(stored.id)));
    const Eigen::Vector3d position = test_map.ExpectedPose(stored.id).translation();
    EXPECT_NEAR(node.Number("x"), position.x(), 1e-9) << node.id;
    EXPECT_NEAR(node.Number("y"), position.y(), 1e-9) << node.id;
    EXPECT_NEAR(node.Number("z"), position.z(), 1e-9) << node.id;
  }

  // Every edge, metric and path, from its `from` node to its `to` node.
  ASSERT_EQ(graph.edges.size(), map.edges.size());
  std::map<std::string, const Edge*> stored_edges;
  for (const Edge& edge : map.edges) stored_edges[edge.id.ToString()] = &edge;
  std::set<std::string> edge_ids;
  for (const testing::GraphMlItem& edge : graph.edges) {
    EXPECT_TRUE(edge_ids.insert(edge.id).second) << edge.id;
    const auto found = stored_edges.find(edge.Data("edge_uuid"));
    ASSERT_NE(found, stored_edges.end()) << edge.Data("edge_uuid");
    const Edge& stored = *found->second;
    EXPECT_EQ(uuid_of_node.at(edge.source), stored.from);
    EXPECT_EQ(uuid_of_node.at(edge.target), stored.to);
    if (stored.kind == EdgeKind::kMetric) {
      EXPECT_EQ(edge.Data("kind"), "metric");
      EXPECT_FALSE(edge.data.contains("path"));
      const Eigen::Vector3d t(edge.Number("tx"), edge.Number("ty"), edge.Number("tz"));
      const Eigen::Quaterniond q(edge.Number("qw"), edge.Number("qx"), edge.Number("qy"),
                                 edge.Number("qz"));
      EXPECT_LT((t - stored.from_T_to.translation()).norm(), 1e-12);
      EXPECT_NEAR(q.norm(), 1.0, 1e-12);
      EXPECT_GE(q.w(), 0.0);
      EXPECT_LT(testing::AngleBetween(q, Eigen::Quaterniond(stored.from_T_to.rotation())), 1e-9);
    } else {
      EXPECT_EQ(edge.Data("kind"), "path");
      EXPECT_EQ(edge.Data("path"), stored.path.ToString());
      EXPECT_FALSE(edge.data.contains("tx"));
    }
    stored_edges.erase(found);
  }
  EXPECT_TRUE(stored_edges.empty());
}

TEST(GraphMlWriterTest, TextIsEscapedSoItReadsBackAsWritten) {
  const testing::ExportTestMap test_map;
  const std::string description =
      "postgresql://fleet@db/fleet?a=1&b=<2> \"quoted\" 'single' ]]> &amp;";
  const std::string text = Export(test_map.map(), description);
  EXPECT_EQ(testing::ReadGraphMl(text).description, description);
  EXPECT_EQ(text.find("&b"), std::string::npos);  // no bare ampersand went out
  // Control characters XML does not allow become spaces.
  EXPECT_EQ(testing::ReadGraphMl(Export(test_map.map(), "bell\a here")).description, "bell  here");
}

TEST(GraphMlWriterTest, AnEmptyMapIsAnEmptyGraph) {
  const testing::GraphMlGraph graph = testing::ReadGraphMl(Export(GraphBatch{}, ""));
  EXPECT_TRUE(graph.nodes.empty());
  EXPECT_TRUE(graph.edges.empty());
  EXPECT_EQ(graph.keys.size(), 19u);
}

TEST(GraphMlWriterTest, LandmarksThatDoNotDecodeAreNamedAndNothingIsWritten) {
  const testing::ExportTestMap test_map;
  GraphBatch map = test_map.map();
  map.nodes.back().landmarks_blob = "\x01\x02garbage";
  std::ostringstream out;
  const GraphLayout layout = GraphLayout::Compute(map.nodes, map.edges);
  ExpectError(
      ErrorCode::kCorrupt, [&] { WriteGraphMl(map, layout, "", out); },
      map.nodes.back().id.ToString());
  EXPECT_TRUE(out.str().empty());
}

// The test's reader must refuse what is not GraphML, or passing it would prove nothing.
TEST(GraphMlWriterTest, TheTestsReaderRefusesBrokenDocuments) {
  const std::string good = Export(testing::ExportTestMap().map(), "d");
  ASSERT_NO_THROW(testing::ReadGraphMl(good));
  const auto broken = [&](const std::string& from, const std::string& to) {
    std::string text = good;
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    EXPECT_THROW(testing::ReadGraphMl(text), std::runtime_error) << from << " -> " << to;
  };
  broken("</node>", "</nodes>");                                  // mismatched tag
  broken("<desc>d</desc>", "<desc>a & b</desc>");                 // bare ampersand
  broken("source=\"n0\"", "source=\"n999\"");                     // edge to no node
  broken("<data key=\"uuid\">", "<data key=\"nokey\">");          // undeclared key
  broken("<data key=\"stamp_ns\">", "<data key=\"stamp_ns\">x");  // not an integer
  broken("edgedefault=\"directed\"", "edgedefault=\"sideways\"");
  broken("</graphml>", "</graphml><graphml/>");  // two roots
}

}  // namespace
}  // namespace fleetmap
