#include "promotion_hides.h"

#include <deque>
#include <unordered_map>
#include <unordered_set>

namespace fleetmap {

std::vector<Uuid> NodesPromotionHides(VersionStore& versions, RevisionNumber head,
                                      const std::vector<Uuid>& merged_groups,
                                      const std::set<Uuid>& visible, const std::set<Uuid>& kept) {
  std::set<Uuid> hide;
  std::unordered_set<Uuid> groups_edges;
  for (const Uuid& group : merged_groups) {
    const std::optional<Submission> submission = versions.FindSubmission(group);
    if (!submission || submission->state != SubmissionState::kMerged) continue;
    const RevisionChanges merge = versions.Changes(submission->revision - 1, submission->revision);
    for (const Uuid& node : merge.nodes_added) {
      if (visible.contains(node) && !kept.contains(node)) hide.insert(node);
    }
    groups_edges.insert(merge.edges_added.begin(), merge.edges_added.end());
  }
  if (hide.empty()) return {};

  // The head's metric edges around the nodes to hide, and the nodes other revisions' edges
  // hang from (a later merge's chain, its links).
  std::unordered_map<Uuid, std::vector<Uuid>> adjacent;
  std::vector<Uuid> hung_from;
  for (const Edge& edge : versions.EdgesAt(head)) {
    const bool from_hidden = hide.contains(edge.from), to_hidden = hide.contains(edge.to);
    if (!from_hidden && !to_hidden) continue;
    if (edge.kind == EdgeKind::kMetric) {
      adjacent[edge.from].push_back(edge.to);
      adjacent[edge.to].push_back(edge.from);
    }
    if (groups_edges.contains(edge.id)) continue;
    if (from_hidden && !to_hidden) hung_from.push_back(edge.from);
    if (to_hidden && !from_hidden) hung_from.push_back(edge.to);
  }

  // Each such node is kept, with the fewest-hop chain of would-be-hidden nodes to a node that
  // stays (when there is one: a piece hidden whole keeps only what is hung from).
  for (const Uuid& start : hung_from) {
    if (!hide.contains(start)) continue;  // kept already
    std::unordered_map<Uuid, Uuid> parent{{start, start}};
    std::deque<Uuid> queue{start};
    std::optional<Uuid> reached;
    while (!queue.empty() && !reached) {
      const Uuid at = queue.front();
      queue.pop_front();
      for (const Uuid& next : adjacent[at]) {
        if (!parent.emplace(next, at).second) continue;
        if (!hide.contains(next)) {
          reached = at;
          break;
        }
        queue.push_back(next);
      }
    }
    hide.erase(start);
    for (Uuid at = reached.value_or(start); at != start; at = parent.at(at)) hide.erase(at);
  }
  return {hide.begin(), hide.end()};
}

}  // namespace fleetmap
