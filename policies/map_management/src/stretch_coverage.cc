#include "fleetmap/map_management/stretch_coverage.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <queue>
#include <tuple>

#include "fleetmap/core/error.h"
#include "fleetmap/ranking/time_of_day.h"

namespace fleetmap {

namespace {

void CheckStretchLength(double stretch_m) {
  if (!(stretch_m > 0.0 && std::isfinite(stretch_m))) {
    throw Error(ErrorCode::kInvalidArgument, "coverage: stretch_m must be finite and > 0");
  }
}

}  // namespace

void ValidateCoverageOptions(const CoverageOptions& options) {
  CheckStretchLength(options.stretch_m);
  if (options.experiences < 1) {
    throw Error(ErrorCode::kInvalidArgument, "coverage: experiences (k) must be >= 1");
  }
  if (options.most_experiences != 0 && options.most_experiences < options.experiences) {
    throw Error(ErrorCode::kInvalidArgument,
                "coverage: most_experiences must be 0 (no cap) or >= experiences (k)");
  }
}

MapStretches MapStretches::Cut(std::span<const Node* const> nodes, std::span<const Edge> edges,
                               double stretch_m) {
  CheckStretchLength(stretch_m);
  std::unordered_map<Uuid, std::size_t> position;
  position.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) position.emplace(nodes[i]->id, i);
  struct Link {
    std::size_t to;
    Se3 from_T_to;
  };
  std::vector<std::vector<Link>> links(nodes.size());
  for (const Edge& edge : edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    const auto from = position.find(edge.from), to = position.find(edge.to);
    if (from == position.end() || to == position.end()) {
      throw Error(ErrorCode::kIntegrity,
                  "coverage: metric edge " + edge.id.ToString() + " has an end outside the map");
    }
    links[from->second].push_back({to->second, edge.from_T_to});
    links[to->second].push_back({from->second, edge.from_T_to.inverse()});
  }

  // Roots in ascending UUID order, so the layout does not depend on the order given.
  std::vector<std::size_t> by_id(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) by_id[i] = i;
  std::sort(by_id.begin(), by_id.end(),
            [&](std::size_t a, std::size_t b) { return nodes[a]->id < nodes[b]->id; });

  constexpr std::size_t kUnplaced = static_cast<std::size_t>(-1);
  std::vector<std::size_t> component(nodes.size(), kUnplaced);
  std::vector<Se3> root_T_node(nodes.size(), Se3::Identity());
  std::vector<double> reach(nodes.size(), std::numeric_limits<double>::infinity());
  std::size_t components = 0;
  for (const std::size_t root : by_id) {
    if (component[root] != kUnplaced) continue;
    // Dijkstra in metres: the shortest chains drift least.
    using Entry = std::pair<double, std::size_t>;
    std::priority_queue<Entry, std::vector<Entry>, std::greater<>> queue;
    reach[root] = 0.0;
    queue.emplace(0.0, root);
    while (!queue.empty()) {
      const auto [distance, at] = queue.top();
      queue.pop();
      if (component[at] != kUnplaced) continue;
      component[at] = components;
      for (const Link& link : links[at]) {
        if (component[link.to] != kUnplaced) continue;
        const double next = distance + link.from_T_to.translation().norm();
        if (next < reach[link.to]) {
          reach[link.to] = next;
          root_T_node[link.to] = root_T_node[at] * link.from_T_to;
          queue.emplace(next, link.to);
        }
      }
    }
    ++components;
  }

  MapStretches stretches;
  stretches.stretch_of_.resize(nodes.size());
  std::map<std::tuple<std::size_t, long, long, long>, std::size_t> cube_index;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Eigen::Vector3d p = root_T_node[i].translation() / stretch_m;
    const auto key = std::tuple(component[i], std::lround(std::floor(p.x())),
                                std::lround(std::floor(p.y())), std::lround(std::floor(p.z())));
    const auto [it, fresh] = cube_index.emplace(key, stretches.members_.size());
    if (fresh) stretches.members_.emplace_back();
    stretches.stretch_of_[i] = it->second;
    stretches.members_[it->second].push_back(i);
  }
  return stretches;
}

double LocalisationLikelihood(std::int64_t capture_ns, std::span<const std::int64_t> use_stamps_ns,
                              double mission_min, double window_min) {
  const auto kernel = [&](std::int64_t stamp_ns) {
    const double z = MinutesApartOnTheClock(MinuteOfDay(stamp_ns), mission_min) / window_min;
    return std::exp(-0.5 * z * z);
  };
  double likelihood = kernel(capture_ns);
  for (const std::int64_t stamp : use_stamps_ns) likelihood += kernel(stamp);
  return likelihood;
}

std::vector<std::vector<StretchExperience>> RankExperiences(std::span<const Node* const> nodes,
                                                            const MapStretches& stretches,
                                                            std::span<const double> likelihood) {
  std::vector<std::vector<StretchExperience>> ranked(stretches.stretch_count());
  for (std::size_t s = 0; s < stretches.stretch_count(); ++s) {
    std::map<std::pair<Uuid, Uuid>, StretchExperience> experiences;
    for (const std::size_t node : stretches.members(s)) {
      StretchExperience& e = experiences[{nodes[node]->robot, nodes[node]->outing}];
      e.likelihood = std::max(e.likelihood, likelihood[node]);
      e.nodes.push_back(node);
    }
    // std::map iterates in (robot, outing) order; a stable sort keeps it for ties.
    for (auto& [key, experience] : experiences) ranked[s].push_back(std::move(experience));
    std::stable_sort(ranked[s].begin(), ranked[s].end(),
                     [](const StretchExperience& a, const StretchExperience& b) {
                       return a.likelihood > b.likelihood;
                     });
  }
  return ranked;
}

std::vector<char> CoverStretches(const std::vector<std::vector<StretchExperience>>& ranked,
                                 std::size_t node_count, std::span<const char> allowed,
                                 const CoverageOptions& options) {
  ValidateCoverageOptions(options);
  std::vector<char> kept(node_count, 0);
  for (const std::vector<StretchExperience>& stretch : ranked) {
    int held = 0;
    std::vector<char> taken(stretch.size(), 0);
    for (std::size_t e = 0; e < stretch.size() && held < options.experiences; ++e, ++held) {
      for (const std::size_t node : stretch[e].nodes) kept[node] = 1;
      taken[e] = 1;
    }
    const int cap =
        options.most_experiences == 0 ? static_cast<int>(stretch.size()) : options.most_experiences;
    for (std::size_t e = 0; e < stretch.size() && held < cap; ++e) {
      if (taken[e]) continue;
      bool any = false;
      for (const std::size_t node : stretch[e].nodes) {
        if (allowed[node]) {
          kept[node] = 1;
          any = true;
        }
      }
      held += any ? 1 : 0;
    }
  }
  return kept;
}

}  // namespace fleetmap
