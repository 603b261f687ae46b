#include "fleetmap/map_management/stretch_coverage.h"

#include <algorithm>
#include <cmath>
#include <map>
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
  return Cut(LayOutMap(nodes, edges), stretch_m);
}

MapStretches MapStretches::Cut(const MapLayout& layout, double stretch_m) {
  CheckStretchLength(stretch_m);
  MapStretches stretches;
  const std::size_t node_count = layout.component.size();
  stretches.stretch_of_.resize(node_count);
  std::map<std::tuple<std::size_t, long, long, long>, std::size_t> cube_index;
  for (std::size_t i = 0; i < node_count; ++i) {
    const Eigen::Vector3d p = layout.position_m(i) / stretch_m;
    const auto key = std::tuple(layout.component[i], std::lround(std::floor(p.x())),
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
                                                            std::span<const double> likelihood,
                                                            std::span<const char> eligible) {
  std::vector<std::vector<StretchExperience>> ranked(stretches.stretch_count());
  for (std::size_t s = 0; s < stretches.stretch_count(); ++s) {
    std::map<std::pair<Uuid, Uuid>, StretchExperience> experiences;
    for (const std::size_t node : stretches.members(s)) {
      if (!eligible.empty() && !eligible[node]) continue;
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
