// The map the format tests export: two robots' outings that never met, so three components.
//   component 0: outing A, 5 nodes of robot A with a consistent loop-closing edge (4 -> 1);
//   component 1: the first 3 nodes of outing B (robot B), 10 s later, 4 landmarks each;
//   component 2: outing B's last node, 20 s after A's first, with no metric edge and no
//                landmarks; only a path edge reaches it, and path edges do not join components.
// Every pose the layout must give follows from the survey (surveyed_map.h).
#pragma once

#include <algorithm>
#include <map>
#include <tuple>
#include <vector>

#include "surveyed_map.h"

namespace fleetmap::testing {

struct ExportTestMap {
  static constexpr std::int64_t kFirstStampNs = 1'700'000'000'250'000'000;

  SurveyedMap surveyed;
  Uuid robot_a = Uuid::Generate(), robot_b = Uuid::Generate();
  Uuid outing_a = Uuid::Generate(), outing_b = Uuid::Generate();
  std::vector<Uuid> a_nodes, b_nodes;  // b_nodes holds the lone node last
  std::map<Uuid, int> component;       // what the layout must number each node's component
  std::map<Uuid, Uuid> reference;      // and the node its frame is that of

  ExportTestMap() {
    AddSurveyedOuting(surveyed, robot_a, outing_a, kFirstStampNs, WindingRoute(5, 0.0), 6);
    AddSurveyedOuting(surveyed, robot_b, outing_b, kFirstStampNs + 10'000'000'000,
                      WindingRoute(3, 100.0), 4);
    for (const Node& node : surveyed.map.nodes) {
      (node.outing == outing_a ? a_nodes : b_nodes).push_back(node.id);
    }
    surveyed.AddMetricEdge(Uuid::Generate(), a_nodes[4], a_nodes[1]);
    const Uuid lone = surveyed.AddNode(Uuid::Generate(), kFirstStampNs + 20'000'000'000, robot_b,
                                       outing_b, SurveyPose(2.0, {1, 0, 0}, {7, 8, 9}), 0);
    surveyed.AddPathEdge(Uuid::Generate(), b_nodes.back(), lone, surveyed.map.paths[1].id);
    b_nodes.push_back(lone);
    const auto place = [this](const Uuid& node, int c, const Uuid& first) {
      component[node] = c;
      reference[node] = first;
    };
    for (const Uuid& id : a_nodes) place(id, 0, a_nodes.front());
    for (std::size_t i = 0; i < 3; ++i) place(b_nodes[i], 1, b_nodes.front());
    place(lone, 2, lone);
  }

  const GraphBatch& map() const { return surveyed.map; }
  Se3 ExpectedPose(const Uuid& node) const { return surveyed.Expected(reference.at(node), node); }

  // The node ids in the order exports number them, worked out here: by (stamp_ns, UUID).
  std::vector<Uuid> NumberedIds() const {
    std::vector<const Node*> nodes;
    for (const Node& node : surveyed.map.nodes) nodes.push_back(&node);
    std::sort(nodes.begin(), nodes.end(), [](const Node* a, const Node* b) {
      return std::tie(a->stamp_ns, a->id) < std::tie(b->stamp_ns, b->id);
    });
    std::vector<Uuid> ids;
    for (const Node* node : nodes) ids.push_back(node->id);
    return ids;
  }
};

// The angle between two rotations, radians.
inline double AngleBetween(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.normalized().angularDistance(b.normalized());
}

}  // namespace fleetmap::testing
