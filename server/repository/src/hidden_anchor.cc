#include "hidden_anchor.h"

#include <functional>
#include <queue>
#include <unordered_map>
#include <utility>
#include <vector>

#include "element_visibility.h"

namespace fleetmap {

std::optional<NodeStandIn> AnchorThroughHidden(GraphStore& store, RevisionNumber head,
                                               const Uuid& hidden,
                                               const HiddenAnchorLimits& limits) {
  VersionStore& versions = store.versions();
  // Dijkstra by metres; at_T_hidden is the hidden node's pose in each settled node's frame.
  struct Reached {
    double distance_m;
    Se3 at_T_hidden;
  };
  std::unordered_map<Uuid, Reached> reached{{hidden, {0.0, Se3::Identity()}}};
  std::unordered_map<Uuid, bool> settled;
  using Entry = std::pair<double, Uuid>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  queue.push({0.0, hidden});
  while (!queue.empty() && settled.size() < limits.max_nodes) {
    const auto [distance_m, at] = queue.top();
    queue.pop();
    if (settled.contains(at) || distance_m > reached.at(at).distance_m) continue;
    settled.emplace(at, true);
    const Se3 at_T_hidden = reached.at(at).at_T_hidden;
    if (at != hidden && VisibleAt(versions.VersionOf(at), head)) {
      return NodeStandIn{hidden, at, at_T_hidden, 0};
    }
    const Uuid ids[] = {at};
    for (const Edge& edge : store.EdgesTouching(ids)) {
      if (edge.kind != EdgeKind::kMetric) continue;
      const std::optional<ElementVersion> version = versions.VersionOf(edge.id);
      if (!version || version->added > head) continue;  // stored after the head
      const bool outgoing = edge.from == at;
      const Uuid& next = outgoing ? edge.to : edge.from;
      const double d = distance_m + edge.from_T_to.translation().norm();
      if (d > limits.radius_m || settled.contains(next)) continue;
      const auto known = reached.find(next);
      if (known != reached.end() && known->second.distance_m <= d) continue;
      // next_T_hidden = next_T_at * at_T_hidden, next_T_at from the edge either way round.
      const Se3 next_T_at = outgoing ? edge.from_T_to.inverse() : edge.from_T_to;
      reached.insert_or_assign(next, Reached{d, next_T_at * at_T_hidden});
      queue.push({d, next});
    }
  }
  return std::nullopt;
}

}  // namespace fleetmap
