#include "fleetmap/interchange/graph_layout.h"

#include <algorithm>
#include <deque>
#include <string>
#include <tuple>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// One way across a metric edge. The pose is read from the edge when the step is taken rather
// than stored here: an Se3 is 128 bytes, and a map has two steps per edge.
struct Step {
  std::size_t neighbour;
  const Edge* edge;
  bool forwards;  // from the edge's `from` node to its `to` node
};

}  // namespace

GraphLayout GraphLayout::Compute(const std::vector<Node>& nodes, const std::vector<Edge>& edges) {
  GraphLayout layout;
  layout.nodes_.reserve(nodes.size());
  for (const Node& node : nodes) {
    layout.nodes_.push_back(
        LaidOutNode{node.id, node.stamp_ns, node.robot, node.outing, -1, Se3::Identity()});
  }
  std::sort(layout.nodes_.begin(), layout.nodes_.end(),
            [](const LaidOutNode& a, const LaidOutNode& b) {
              return std::tie(a.stamp_ns, a.id) < std::tie(b.stamp_ns, b.id);
            });
  layout.index_of_.reserve(layout.nodes_.size());
  for (std::size_t i = 0; i < layout.nodes_.size(); ++i) {
    if (!layout.index_of_.emplace(layout.nodes_[i].id, i).second) {
      throw Error(ErrorCode::kInvalidArgument,
                  "graph layout: node " + layout.nodes_[i].id.ToString() + " is given twice");
    }
  }

  // Edges in UUID order, so the breadth-first walk (and with it every pose a loop makes
  // ambiguous) does not depend on the order the store returned them in.
  std::vector<const Edge*> metric;
  for (const Edge& edge : edges) {
    for (const Uuid* end : {&edge.from, &edge.to}) {
      if (!layout.index_of_.contains(*end)) {
        throw Error(ErrorCode::kIntegrity, "graph layout: edge " + edge.id.ToString() +
                                               " ends at node " + end->ToString() +
                                               ", which is not in the graph");
      }
    }
    if (edge.kind == EdgeKind::kMetric) metric.push_back(&edge);
  }
  std::sort(metric.begin(), metric.end(),
            [](const Edge* a, const Edge* b) { return a->id < b->id; });
  std::vector<std::vector<Step>> steps(layout.nodes_.size());
  for (const Edge* edge : metric) {
    const std::size_t from = layout.index_of_.at(edge->from);
    const std::size_t to = layout.index_of_.at(edge->to);
    steps[from].push_back(Step{to, edge, true});
    steps[to].push_back(Step{from, edge, false});
  }

  // Nodes are in (stamp, UUID) order, so the first node of each new component met here is its
  // earliest: its reference.
  std::deque<std::size_t> queue;
  for (std::size_t start = 0; start < layout.nodes_.size(); ++start) {
    if (layout.nodes_[start].component >= 0) continue;
    const int component = static_cast<int>(layout.references_.size());
    layout.references_.push_back(start);
    layout.nodes_[start].component = component;
    queue.push_back(start);
    while (!queue.empty()) {
      const std::size_t at = queue.front();
      queue.pop_front();
      for (const Step& step : steps[at]) {
        LaidOutNode& next = layout.nodes_[step.neighbour];
        if (next.component >= 0) continue;  // reached before: its first pose stands
        const Se3& layout_T_at = layout.nodes_[at].layout_T_node;
        next.component = component;
        next.layout_T_node = step.forwards ? layout_T_at * step.edge->from_T_to
                                           : layout_T_at * step.edge->from_T_to.inverse();
        queue.push_back(step.neighbour);
      }
    }
  }
  return layout;
}

GraphLayout GraphLayout::WithPoses(std::vector<Se3> layout_T_node) const {
  if (layout_T_node.size() != nodes_.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "graph layout: " + std::to_string(layout_T_node.size()) + " poses for " +
                    std::to_string(nodes_.size()) + " nodes");
  }
  for (const std::size_t reference : references_) {
    if (layout_T_node[reference].matrix() != Se3::Identity().matrix()) {
      throw Error(ErrorCode::kInvalidArgument, "graph layout: the reference node " +
                                                   nodes_[reference].id.ToString() +
                                                   " of a component must keep the identity pose");
    }
  }
  GraphLayout layout = *this;
  for (std::size_t i = 0; i < nodes_.size(); ++i) layout.nodes_[i].layout_T_node = layout_T_node[i];
  return layout;
}

std::optional<std::size_t> GraphLayout::IndexOf(const Uuid& id) const {
  const auto found = index_of_.find(id);
  if (found == index_of_.end()) return std::nullopt;
  return found->second;
}

}  // namespace fleetmap
