#include "export_inputs.h"

#include <algorithm>
#include <string>
#include <tuple>

#include "fleetmap/core/error.h"

namespace fleetmap::interchange_internal {

std::vector<const Node*> NodesInLayoutOrder(const GraphBatch& map, const GraphLayout& layout) {
  if (map.nodes.size() != layout.nodes().size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "export: the layout places " + std::to_string(layout.nodes().size()) +
                    " nodes but the map holds " + std::to_string(map.nodes.size()));
  }
  std::vector<const Node*> ordered(map.nodes.size(), nullptr);
  for (const Node& node : map.nodes) {
    const std::optional<std::size_t> index = layout.IndexOf(node.id);
    if (!index || ordered[*index] != nullptr) {
      throw Error(ErrorCode::kInvalidArgument,
                  "export: node " + node.id.ToString() +
                      (index ? " is in the map twice" : " is not in the layout"));
    }
    ordered[*index] = &node;
  }
  return ordered;
}

std::vector<OrderedEdge> EdgesInLayoutOrder(const GraphBatch& map, const GraphLayout& layout,
                                            bool metric_only) {
  std::vector<OrderedEdge> ordered;
  for (const Edge& edge : map.edges) {
    if (metric_only && edge.kind != EdgeKind::kMetric) continue;
    const std::optional<std::size_t> from = layout.IndexOf(edge.from);
    const std::optional<std::size_t> to = layout.IndexOf(edge.to);
    if (!from || !to) {
      throw Error(ErrorCode::kInvalidArgument,
                  "export: edge " + edge.id.ToString() + " ends at a node not in the layout");
    }
    ordered.push_back(OrderedEdge{&edge, *from, *to});
  }
  std::sort(ordered.begin(), ordered.end(), [](const OrderedEdge& a, const OrderedEdge& b) {
    return std::tie(a.from, a.to, a.edge->id) < std::tie(b.from, b.to, b.edge->id);
  });
  return ordered;
}

Landmarks LandmarksOf(const Node& node) {
  try {
    return DecodeLandmarks(node.landmarks_blob);
  } catch (const Error& error) {
    throw Error(error.code(),
                "landmarks of node " + node.id.ToString() + " do not decode: " + error.message());
  }
}

}  // namespace fleetmap::interchange_internal
