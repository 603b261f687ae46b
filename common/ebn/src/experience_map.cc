#include "fleetmap/ebn/experience_map.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <unordered_map>

#include "fleetmap/core/error.h"

namespace fleetmap {

ExperienceMap::ExperienceMap(std::shared_ptr<const AppearanceVocabulary> vocabulary)
    : appearance_(std::move(vocabulary)) {}

ExperienceMap ExperienceMap::Load(GraphReader& store,
                                  std::shared_ptr<const AppearanceVocabulary> vocabulary) {
  const GraphBatch map = store.ReadMap();
  return FromGraph(map.nodes, map.edges, std::move(vocabulary));
}

ExperienceMap ExperienceMap::FromGraph(std::span<const Node> nodes, std::span<const Edge> edges,
                                       std::shared_ptr<const AppearanceVocabulary> vocabulary) {
  ExperienceMap map(std::move(vocabulary));
  for (const Node& node : nodes) map.AddNode(node, DecodeLandmarks(node.landmarks_blob));
  for (const Edge& edge : edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    const std::optional<NodeIndex> from = map.Find(edge.from), to = map.Find(edge.to);
    if (!from || !to) {
      throw Error(ErrorCode::kIntegrity, "experience map: metric edge " + edge.id.ToString() +
                                             " has an end outside the map");
    }
    // One relative pose per pair of nodes: a second edge between them (either way round)
    // would only give the search a second, disagreeing estimate.
    bool linked = false;
    for (const MetricLink& link : map.experiences_[*from].links) linked |= link.to == *to;
    if (!linked) map.AddMetricEdge(edge.from, edge.to, edge.from_T_to, edge.covariance.optional());
  }
  return map;
}

ExperienceMap::NodeIndex ExperienceMap::AddNode(const Node& node, Landmarks landmarks) {
  const auto index = static_cast<NodeIndex>(experiences_.size());
  if (!index_of_.try_emplace(node.id, index).second) {
    throw Error(ErrorCode::kConflict, "experience map: node " + node.id.ToString() + " twice");
  }
  Experience& experience = experiences_.emplace_back();
  experience.node = node;
  experience.node.landmarks_blob.clear();
  experience.landmarks = std::move(landmarks);
  appearance_.Add(node.id, experience.landmarks.descriptors);
  return index;
}

void ExperienceMap::AddMetricEdge(const Uuid& from, const Uuid& to, const Se3& from_T_to,
                                  const std::optional<PoseCovariance>& covariance) {
  const std::optional<NodeIndex> a = Find(from), b = Find(to);
  if (!a || !b) {
    throw Error(ErrorCode::kIntegrity, "experience map: metric edge " + from.ToString() + " -> " +
                                           to.ToString() + " names an unknown node");
  }
  std::int32_t slot = -1;
  if (covariance) {
    slot = static_cast<std::int32_t>(covariances_.size());
    covariances_.push_back(*covariance);
  }
  experiences_[*a].links.push_back({*b, from_T_to, slot, false});
  experiences_[*b].links.push_back({*a, from_T_to.inverse(), slot, true});
  ++metric_edges_;
}

std::optional<PoseCovariance> ExperienceMap::LinkCovariance(const MetricLink& link) const {
  if (link.covariance < 0) return std::nullopt;
  const PoseCovariance& own = covariances_[static_cast<std::size_t>(link.covariance)];
  // Stored for the edge's direction; the reverse link's pose is the inverse of the edge's.
  return link.reversed ? InverseCovariance(link.from_T_to.inverse(), own) : own;
}

std::optional<ExperienceMap::NodeIndex> ExperienceMap::Find(const Uuid& id) const {
  const auto it = index_of_.find(id);
  if (it == index_of_.end()) return std::nullopt;
  return it->second;
}

std::vector<ExperienceMap::Nearby> ExperienceMap::Neighbourhood(
    NodeIndex origin, const Eigen::Vector3d& position_in_origin, double radius_m,
    double search_radius_m) const {
  return Neighbourhood(origin, position_in_origin,
                       Reach{.radius_m = radius_m, .max_radius_m = radius_m}, search_radius_m);
}

std::vector<ExperienceMap::Nearby> ExperienceMap::Neighbourhood(
    NodeIndex origin, const Eigen::Vector3d& position_in_origin, const Reach& reach,
    double search_radius_m) const {
  // Dijkstra over metric edges by their length. Visited marks live in local hash maps rather
  // than in the nodes, so concurrent read-only searches on one map do not interfere. A chain's
  // covariance is kept only once an edge on it carried one.
  struct Reached {
    double metres = 0.0;
    Se3 origin_T_node = Se3::Identity();
    std::optional<PoseCovariance> covariance;
    bool settled = false;
  };
  std::unordered_map<NodeIndex, Reached> reached;
  using Entry = std::pair<double, NodeIndex>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
  std::vector<Nearby> nearby;
  reached.emplace(origin, Reached{});
  queue.emplace(0.0, origin);
  const double position_variance = reach.position_sigma_m * reach.position_sigma_m;
  while (!queue.empty()) {
    const auto [metres, current] = queue.top();
    queue.pop();
    Reached& here = reached.at(current);
    if (here.settled) continue;
    here.settled = true;
    const Se3 origin_T_current = here.origin_T_node;
    const double distance = (origin_T_current.translation() - position_in_origin).norm();
    const double sigma = here.covariance ? PositionSigma(origin_T_current, *here.covariance) : 0.0;
    const double radius =
        std::min(reach.max_radius_m,
                 reach.radius_m + reach.sigmas * std::sqrt(sigma * sigma + position_variance));
    if (distance <= std::max(radius, reach.radius_m)) {
      nearby.push_back({current, origin_T_current, distance, sigma, here.covariance});
    }
    if (origin_T_current.translation().norm() > search_radius_m) continue;
    for (const MetricLink& link : experiences_[current].links) {
      const double next = metres + link.from_T_to.translation().norm();
      const auto [it, inserted] = reached.try_emplace(link.to);
      if (!inserted && (it->second.settled || it->second.metres <= next)) continue;
      it->second.metres = next;
      it->second.origin_T_node = origin_T_current * link.from_T_to;
      const std::optional<PoseCovariance> own = LinkCovariance(link);
      if (own) {
        it->second.covariance = ComposeCovariance(
            origin_T_current, here.covariance.value_or(PoseCovariance::Zero()), *own);
      } else {
        it->second.covariance = here.covariance;
      }
      queue.emplace(next, link.to);
    }
  }
  return nearby;
}

}  // namespace fleetmap
