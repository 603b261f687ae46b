// The fleet experiment's ground truth (fleet_run.h): where each node and frame truly was, the
// error of the maps' edges against it, and the diagnoses of why the merged map and the
// downloads lose frames (per stretch, per download, and whether the localiser could reach the
// experience it needed), and how far the map's layouts put its nodes from where they were.
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <tuple>

#include "fleet_run.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/ranking/time_of_day.h"
#include "fleetmap/relaxation/relaxed_layout.h"
#include "layout_accuracy.h"
#include "outing_runs.h"

namespace fleetmap::fleet_internal {

std::optional<Se3> FleetRun::TruePose(const Node& node) const {
  const auto outing = outing_index_.find(node.outing);
  if (outing == outing_index_.end()) return std::nullopt;
  const std::vector<Frame>& frames = frames_[outing->second];
  const auto frame =
      std::lower_bound(frames.begin(), frames.end(), node.stamp_ns,
                       [](const Frame& f, std::int64_t stamp) { return f.stamp_ns < stamp; });
  if (frame == frames.end() || frame->stamp_ns != node.stamp_ns || !frame->world_T_camera_truth) {
    return std::nullopt;
  }
  return *frame->world_T_camera_truth;
}

std::optional<Eigen::Vector3d> FleetRun::TruePlace(const Node& node) const {
  const std::optional<Se3> pose = TruePose(node);
  if (!pose) return std::nullopt;
  return pose->translation();
}

void FleetRun::RecordEdgeErrors(int fold, const std::string& name, const GraphBatch& map,
                                const std::unordered_set<Uuid>& skip) {
  std::unordered_map<Uuid, const Node*> node_of;
  for (const Node& node : map.nodes) node_of.emplace(node.id, &node);
  FleetEdgeErrors errors{fold, name, {}, {}};
  for (const Edge& edge : map.edges) {
    if (edge.kind != EdgeKind::kMetric || skip.contains(edge.id)) continue;
    const auto from = node_of.find(edge.from), to = node_of.find(edge.to);
    if (from == node_of.end() || to == node_of.end()) continue;
    if (from->second->outing == to->second->outing) continue;
    const std::optional<Se3> world_T_from = TruePose(*from->second),
                             world_T_to = TruePose(*to->second);
    if (!world_T_from || !world_T_to) continue;
    const Se3 truth = world_T_from->inverse() * *world_T_to;
    errors.errors_m.push_back(
        static_cast<float>((truth.translation() - edge.from_T_to.translation()).norm()));
    errors.sigmas_m.push_back(
        edge.covariance ? static_cast<float>(PositionSigma(edge.from_T_to, *edge.covariance))
                        : std::numeric_limits<float>::quiet_NaN());
  }
  const std::lock_guard lock(result_mutex_);
  result_.edge_errors.push_back(std::move(errors));
}

void FleetRun::RecordLayoutErrors(int fold, const std::string& name, const GraphBatch& map) {
  std::unordered_map<Uuid, const Node*> node_of;
  for (const Node& node : map.nodes) node_of.emplace(node.id, &node);
  std::vector<FleetLayoutError> errors;
  for (const LayoutKind kind : {LayoutKind::kComposed, LayoutKind::kRelaxed}) {
    const Clock::time_point start = Clock::now();
    const GraphLayout layout = LayOutGraph(map.nodes, map.edges, kind);
    const double seconds = SecondsSince(start);
    const LayoutAccuracy accuracy = MeasureLayoutAccuracy(
        layout, [&](const LaidOutNode& node) { return TruePlace(*node_of.at(node.id)); });
    if (accuracy.nodes == 0) continue;
    errors.push_back({fold, name, std::string(LayoutName(kind)), accuracy.nodes, accuracy.rmse_m,
                      accuracy.max_m, seconds});
  }
  const std::lock_guard lock(result_mutex_);
  result_.layout_errors.insert(result_.layout_errors.end(), errors.begin(), errors.end());
}

std::vector<Eigen::Vector3d> FleetRun::Places(const GraphBatch& map) const {
  std::vector<Eigen::Vector3d> places;
  for (const Node& node : map.nodes) {
    if (const auto place = TruePlace(node)) places.push_back(*place);
  }
  return places;
}

std::vector<Eigen::Vector3d> FleetRun::FramePlaces(std::size_t outing) const {
  std::vector<Eigen::Vector3d> places;
  for (const Frame& frame : frames_[outing]) {
    places.push_back(frame.world_T_camera_truth
                         ? Eigen::Vector3d(frame.world_T_camera_truth->translation())
                         : Eigen::Vector3d::Constant(1e9));
  }
  return places;
}

bool FleetRun::AnyNear(const std::vector<Eigen::Vector3d>& places, const Eigen::Vector3d& at,
                       double radius_m) {
  for (const Eigen::Vector3d& p : places) {
    if ((p - at).squaredNorm() <= radius_m * radius_m) return true;
  }
  return false;
}

void FleetRun::DiagnoseDownload(std::size_t outing, const GraphBatch& merged,
                                const std::unordered_map<Uuid, std::int64_t>& stamp_of,
                                const DownloadPolicy& policy, const GraphBatch& download,
                                const HeldOutRun& run, const HeldOutRun& copy,
                                FleetDownload& row) const {
  const std::vector<Eigen::Vector3d> nodes = Places(download);
  const std::vector<Eigen::Vector3d> frames = FramePlaces(outing);
  std::unordered_set<Uuid> held;
  for (const Node& node : download.nodes) held.insert(node.id);
  std::unordered_set<Uuid> window_paths, used_in_window;
  for (const Path& path : merged.paths) {
    if (WithinTimeOfDayWindow(path.start_ns, policy.mission_start_min, policy.window_min)) {
      window_paths.insert(path.id);
    }
  }
  for (const Edge& edge : merged.edges) {
    if (edge.kind == EdgeKind::kPath && window_paths.contains(edge.path)) {
      used_in_window.insert(edge.from);
      used_in_window.insert(edge.to);
    }
  }
  double hours_away = 0.0;
  for (std::size_t i = 0; i < frames.size() && i < run.localised.size(); ++i) {
    ++row.frames;
    const bool near = AnyNear(nodes, frames[i], options_.place_radius_m);
    row.frames_with_node_near += near ? 1 : 0;
    if (i >= copy.localised.size() || !copy.localised[i] || run.localised[i]) continue;
    ++row.lost_vs_copy;
    row.lost_vs_copy_no_node_near += near ? 0 : 1;
    const Uuid& used = copy.references[i];
    const auto stamp = stamp_of.find(used);
    if (stamp == stamp_of.end()) continue;  // copy is the merged map: never
    if (held.contains(used)) {
      ++row.lost_copy_node_held;
    } else if (WithinTimeOfDayWindow(stamp->second, policy.mission_start_min, policy.window_min) ||
               used_in_window.contains(used)) {
      ++row.lost_copy_node_in_window;
    } else {
      ++row.lost_copy_node_outside_window;
      hours_away +=
          MinutesApartOnTheClock(MinuteOfDay(stamp->second), policy.mission_start_min) / 60.0;
    }
  }
  row.lost_copy_node_hours_away =
      row.lost_copy_node_outside_window == 0
          ? 0.0
          : hours_away / static_cast<double>(row.lost_copy_node_outside_window);
}

void FleetRun::DiagnoseMerge(const FoldState& fold) {
  const double side = options_.coverage.stretch_m;
  using Cube = std::tuple<long, long, long>;
  const auto cube = [side](const Eigen::Vector3d& p) {
    return Cube(std::lround(std::floor(p.x() / side)), std::lround(std::floor(p.y() / side)),
                std::lround(std::floor(p.z() / side)));
  };
  std::map<Cube, std::pair<std::size_t, std::size_t>> held;  // single, merged
  for (const Eigen::Vector3d& p : fold.single_places) ++held[cube(p)].first;
  for (const Eigen::Vector3d& p : fold.merged_places) ++held[cube(p)].second;
  FleetMergeDiagnosis d;
  d.fold = fold.number;
  d.stretches = held.size();
  for (const auto& [at, counts] : held) {
    if (counts.second > counts.first) {
      ++d.stretches_more;
      d.nodes_more += counts.second - counts.first;
    } else if (counts.second < counts.first) {
      ++d.stretches_fewer;
      d.nodes_fewer += counts.first - counts.second;
    }
  }
  std::size_t frame = 0;
  for (std::size_t outing : fold.test) {
    for (const Eigen::Vector3d& p : FramePlaces(outing)) {
      if (frame >= fold.single_localised.size() || frame >= fold.merged_localised.size()) break;
      const auto it = held.find(cube(p));
      const bool fewer = it != held.end() && it->second.second < it->second.first;
      const bool single_ok = fold.single_localised[frame], merged_ok = fold.merged_localised[frame];
      ++d.frames;
      d.single_lost += single_ok ? 0 : 1;
      if (!merged_ok) {
        ++d.merged_lost;
        d.merged_lost_where_fewer += fewer ? 1 : 0;
        if (single_ok) {
          ++d.merged_only_lost;
          d.merged_only_lost_where_fewer += fewer ? 1 : 0;
        }
      }
      ++frame;
    }
  }
  if (fold.merged_map) {
    d.reach = Reach(*fold.merged_map, fold.test, fold.merged_localised, fold.merged_traces,
                    fold.single_localised);
  }
  result_.merge_diagnoses.push_back(d);
}

FleetReach FleetRun::Reach(const ExperienceMap& map, const std::vector<std::size_t>& outings,
                           const std::vector<char>& localised,
                           const std::vector<FrameTrace>& traces,
                           const std::vector<char>& reference_localised) const {
  FleetReach reach;
  if (traces.size() != localised.size()) return reach;
  std::vector<std::pair<Eigen::Vector3d, ExperienceMap::NodeIndex>> placed;
  for (ExperienceMap::NodeIndex n = 0; n < map.size(); ++n) {
    if (const auto place = TruePlace(map.at(n).node)) placed.emplace_back(*place, n);
  }
  const Localiser oracle(options_.builder.localiser);
  const double radius2 = options_.place_radius_m * options_.place_radius_m;
  std::size_t frame = 0;
  for (std::size_t outing : outings) {
    for (const Frame& live : frames_[outing]) {
      const std::size_t i = frame++;
      if (i >= reference_localised.size() || !reference_localised[i] || localised[i] ||
          !live.world_T_camera_truth) {
        continue;
      }
      ++reach.lost;
      const Eigen::Vector3d at = live.world_T_camera_truth->translation();
      std::vector<Uuid> right;
      bool near = false;
      for (const auto& [place, node] : placed) {
        if ((place - at).squaredNorm() > radius2) continue;
        near = true;
        if (oracle.Localise(live.landmarks, map.at(node).landmarks).success) {
          right.push_back(map.at(node).node.id);
        }
      }
      const FrameTrace& trace = traces[i];
      const auto among = [&](const std::vector<Uuid>& ids) {
        for (const Uuid& id : right) {
          if (std::find(ids.begin(), ids.end(), id) != ids.end()) return true;
        }
        return false;
      };
      if (!near) {
        ++reach.no_node_near;
      } else if (right.empty()) {
        ++reach.none_localises;
      } else if (among(trace.tried)) {
        ++reach.tried;
      } else if (among(trace.ranked)) {
        ++reach.not_tried;
      } else {
        ++reach.not_candidate;
        const std::optional<ExperienceMap::NodeIndex> reference = map.Find(trace.reference);
        if (trace.ranked.empty() || !reference) {
          ++reach.not_candidate_lost;
          continue;
        }
        if (const auto place = TruePlace(map.at(*reference).node);
            place && (*place - at).norm() > 2.0 * options_.place_radius_m) {
          ++reach.not_candidate_reference_far;
        }
        std::vector<Uuid> reached;
        for (const ExperienceMap::Nearby& near_node : map.Neighbourhood(
                 *reference, Eigen::Vector3d::Zero(), std::numeric_limits<double>::infinity(),
                 options_.builder.search_radius_m)) {
          reached.push_back(map.at(near_node.node).node.id);
        }
        if (among(reached)) {
          ++reach.not_candidate_placed_far;
        } else {
          ++reach.not_candidate_unreached;
        }
      }
    }
  }
  return reach;
}

}  // namespace fleetmap::fleet_internal
