#include "fleetmap/interchange/graphml_writer.h"

#include <array>
#include <string>
#include <vector>

#include "export_inputs.h"
#include "export_text.h"
#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

using interchange_internal::AppendNumber;

struct KeyDeclaration {
  const char* domain;  // GraphML's `for`: node or edge
  const char* name;    // its id and attr.name
  const char* type;    // attr.type
};

constexpr std::array<KeyDeclaration, 19> kKeys{{
    {"node", "uuid", "string"},      {"node", "stamp_ns", "long"}, {"node", "robot", "string"},
    {"node", "outing", "string"},    {"node", "landmarks", "int"}, {"node", "component", "int"},
    {"node", "x", "double"},         {"node", "y", "double"},      {"node", "z", "double"},
    {"edge", "edge_uuid", "string"}, {"edge", "kind", "string"},   {"edge", "path", "string"},
    {"edge", "tx", "double"},        {"edge", "ty", "double"},     {"edge", "tz", "double"},
    {"edge", "qw", "double"},        {"edge", "qx", "double"},     {"edge", "qy", "double"},
    {"edge", "qz", "double"},
}};

void AppendData(std::string& out, std::string_view key, std::string_view value) {
  out += "      <data key=\"";
  out += key;
  out += "\">";
  AppendMarkupEscaped(out, value);
  out += "</data>\n";
}

void AppendNumberData(std::string& out, std::string_view key, double value) {
  std::string text;
  AppendNumber(text, value);
  AppendData(out, key, text);
}

}  // namespace

void WriteGraphMl(const GraphBatch& map, const GraphLayout& layout, std::string_view description,
                  std::ostream& out) {
  const std::vector<const Node*> nodes = interchange_internal::NodesInLayoutOrder(map, layout);
  const std::vector<interchange_internal::OrderedEdge> edges =
      interchange_internal::EdgesInLayoutOrder(map, layout, /*metric_only=*/false);
  // Every blob is decoded before the first byte goes out, so a corrupt one leaves no output.
  std::vector<std::size_t> landmark_counts;
  landmark_counts.reserve(nodes.size());
  for (const Node* node : nodes) {
    landmark_counts.push_back(interchange_internal::LandmarksOf(*node).size());
  }

  std::string text =
      "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
      "<graphml xmlns=\"http://graphml.graphdrawing.org/xmlns\"\n"
      "    xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
      "    xsi:schemaLocation=\"http://graphml.graphdrawing.org/xmlns "
      "http://graphml.graphdrawing.org/xmlns/1.0/graphml.xsd\">\n";
  for (const KeyDeclaration& key : kKeys) {
    text += "  <key id=\"" + std::string(key.name) + "\" for=\"" + key.domain + "\" attr.name=\"" +
            key.name + "\" attr.type=\"" + key.type + "\"/>\n";
  }
  text += "  <graph id=\"map\" edgedefault=\"directed\">\n";
  if (!description.empty()) {
    text += "    <desc>";
    AppendMarkupEscaped(text, description);
    text += "</desc>\n";
  }
  out << text;

  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Node& node = *nodes[i];
    const LaidOutNode& placed = layout.nodes()[i];
    text = "    <node id=\"n" + std::to_string(i) + "\">\n";
    AppendData(text, "uuid", node.id.ToString());
    AppendData(text, "stamp_ns", std::to_string(node.stamp_ns));
    AppendData(text, "robot", node.robot.ToString());
    AppendData(text, "outing", node.outing.ToString());
    AppendData(text, "landmarks", std::to_string(landmark_counts[i]));
    AppendData(text, "component", std::to_string(placed.component));
    const Eigen::Vector3d& position = placed.layout_T_node.translation();
    AppendNumberData(text, "x", position.x());
    AppendNumberData(text, "y", position.y());
    AppendNumberData(text, "z", position.z());
    text += "    </node>\n";
    out << text;
  }
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const Edge& edge = *edges[e].edge;
    text = "    <edge id=\"e" + std::to_string(e) + "\" source=\"n" +
           std::to_string(edges[e].from) + "\" target=\"n" + std::to_string(edges[e].to) + "\">\n";
    AppendData(text, "edge_uuid", edge.id.ToString());
    if (edge.kind == EdgeKind::kMetric) {
      AppendData(text, "kind", "metric");
      const Eigen::Vector3d& t = edge.from_T_to.translation();
      const Eigen::Quaterniond q = RotationQuaternion(edge.from_T_to);
      AppendNumberData(text, "tx", t.x());
      AppendNumberData(text, "ty", t.y());
      AppendNumberData(text, "tz", t.z());
      AppendNumberData(text, "qw", q.w());
      AppendNumberData(text, "qx", q.x());
      AppendNumberData(text, "qy", q.y());
      AppendNumberData(text, "qz", q.z());
    } else {
      AppendData(text, "kind", "path");
      AppendData(text, "path", edge.path.ToString());
    }
    text += "    </edge>\n";
    out << text;
  }
  out << "  </graph>\n</graphml>\n";
}

}  // namespace fleetmap
