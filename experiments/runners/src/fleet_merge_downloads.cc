// The fleet experiment's merges and downloads (fleet_run.h): the groups merged through a
// repository (Fig. 7), each held-out outing's download of the merged map by every policy
// (Fig. 9), and the policies' knobs swept for the frontier an operator picks from.
#include <algorithm>
#include <cstdio>
#include <functional>
#include <map>

#include "fleet_run.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/store/version_store.h"
#include "outing_runs.h"

namespace fleetmap::fleet_internal {

namespace {

// The node every download holds: the merged map's earliest, the depot each held-out outing
// starts from (see DepotStart).
std::vector<Uuid> DepotOf(const GraphBatch& merged) {
  std::vector<Uuid> depot;
  if (!merged.nodes.empty()) {
    depot.push_back(std::min_element(merged.nodes.begin(), merged.nodes.end(),
                                     [](const Node& a, const Node& b) {
                                       return std::pair(a.stamp_ns, a.id) <
                                              std::pair(b.stamp_ns, b.id);
                                     })
                        ->id);
  }
  return depot;
}

// Hex floats: the same bits print the same, any other bits differently.
std::string PoseText(const Se3& pose) {
  std::string text;
  char number[32];
  for (int row = 0; row < 3; ++row) {
    for (int col = 0; col < 4; ++col) {
      std::snprintf(number, sizeof number, " %a", pose.matrix()(row, col));
      text += number;
    }
  }
  return text;
}

}  // namespace

void FleetRun::MergeAndDownload(FoldState& fold) {
  std::unique_ptr<Repository> repository = OpenRepository(fold, "server");
  MergeGroups(fold, *repository);
  const GraphBatch merged = repository->Checkout();
  if (options_.deterministic_ids) RecordMergeDecisions(fold, *repository, merged);
  LocaliseMerged(fold, merged);
  const std::vector<Uuid> depot = DepotOf(merged);
  DownloadByEveryPolicy(fold, *repository, merged, depot);
  if (options_.frontier) Frontier(fold, *repository, depot, merged);
}

void FleetRun::MergeGroups(FoldState& fold, Repository& repository) {
  for (std::size_t g = 0; g < fold.group_maps.size(); ++g) {
    const Clock::time_point wall = Clock::now();
    const double cpu = ThreadCpuSeconds();
    const Uuid submission = Uuid::Generate();
    repository.Push(submission, GroupRobot(g), "group " + std::to_string(g),
                    fold.group_maps[g].content);
    const double pushed = SecondsSince(wall);
    const MergeOutcome outcome = repository.Merge(submission);
    const std::int64_t nodes = repository.inspect().StatsAt(repository.Head()).nodes;
    FleetBuild build{"merge " + std::to_string(g), fold.number, static_cast<std::size_t>(nodes),
                     ThreadCpuSeconds() - cpu, SecondsSince(wall)};
    build.push_seconds = pushed;
    build.merge_algorithm_seconds = outcome.report.seconds;
    build.links = outcome.report.links_added;
    build.links_registered = outcome.report.links_registered;
    build.links_inconsistent = outcome.report.links_inconsistent;
    build.merge_call_seconds = outcome.seconds;
    build.merge_index_seconds = outcome.phases.index_seconds;
    build.merge_region_seconds = outcome.phases.region_seconds;
    build.merge_write_seconds = outcome.phases.write_seconds;
    RecordBuild(build);
  }
}

void FleetRun::RecordMergeDecisions(const FoldState& fold, Repository& repository,
                                    const GraphBatch& merged) {
  std::unordered_map<Uuid, const Edge*> edges;
  for (const Edge& edge : merged.edges) edges.emplace(edge.id, &edge);
  std::vector<std::string> lines;
  const std::string fold_text = "fold " + std::to_string(fold.number);
  for (RevisionNumber r = 1; r <= repository.Head(); ++r) {
    const RevisionChanges changes = repository.Diff(r - 1, r);
    const std::string merge = fold_text + " revision " + std::to_string(r);
    for (const Uuid& node : changes.nodes_added)
      lines.push_back(merge + " keeps " + node.ToString());
    for (const Uuid& id : changes.edges_added) {
      const auto edge = edges.find(id);
      std::string line = merge + " adds edge " + id.ToString();
      if (edge != edges.end()) {
        line += " " + edge->second->from.ToString() + " " + edge->second->to.ToString() +
                PoseText(edge->second->from_T_to);
      }
      lines.push_back(line);
    }
  }
  for (const BuiltMap& group : fold.group_maps) {
    for (const Node& node : group.content.nodes) {
      if (const std::optional<NodeStandIn> s = repository.inspect().FindStandIn(node.id)) {
        lines.push_back(fold_text + " revision " + std::to_string(s->revision) + " stands " +
                        s->stand_in.ToString() + " in for " + node.id.ToString() +
                        PoseText(s->stand_in_T_node));
      }
    }
  }
  const std::lock_guard lock(result_mutex_);
  result_.merge_decisions.insert(result_.merge_decisions.end(), lines.begin(), lines.end());
}

void FleetRun::LocaliseMerged(FoldState& fold, const GraphBatch& merged) {
  RecordEdgeErrors(fold.number, "merged", merged);
  RecordLayoutErrors(fold.number, "merged", merged);
  std::unordered_set<Uuid> group_edges;
  for (const BuiltMap& group : fold.group_maps) {
    for (const Edge& edge : group.content.edges) group_edges.insert(edge.id);
  }
  RecordEdgeErrors(fold.number, "merge links", merged, group_edges);
  fold.merged_map = std::make_shared<const ExperienceMap>(
      ExperienceMap::FromGraph(merged.nodes, merged.edges, vocabulary_));
  HeldOutRun merged_run = Localise("merged", fold.number, *fold.merged_map, PathMemoryOf(merged),
                                   fold.test, &fold.merged_traces);
  fold.merged_places = Places(merged);
  fold.merged_localised = merged_run.localised;
  RecordRun(std::move(merged_run));
}

void FleetRun::DownloadByEveryPolicy(const FoldState& fold, Repository& repository,
                                     const GraphBatch& merged, const std::vector<Uuid>& depot) {
  const std::size_t copy_nodes = merged.nodes.size();
  std::map<std::size_t, HeldOutRun> copy_runs;      // by held-out outing
  std::unordered_map<Uuid, std::int64_t> stamp_of;  // the merged map's capture times
  for (const Node& node : merged.nodes) stamp_of.emplace(node.id, node.stamp_ns);
  for (const std::string name : {"copy", "tod", "tod+paths", "tod+cover", "tod+paths+cover"}) {
    DownloadPolicy policy = ParseDownloadPolicy(name);
    if (options_.tod_window_min > 0) policy.window_min = options_.tod_window_min;
    policy.best_percent = options_.paths_percent;
    policy.epoch_min = options_.epoch_min;
    policy.coverage = options_.coverage;
    policy.include = depot;
    HeldOutRun run;
    run.map = name;
    run.fold = fold.number;
    std::size_t node_sum = 0;
    for (std::size_t index : fold.test) {
      policy.mission_start_min = outings_[index].start_time_h * 60.0;
      const Download download = repository.SelectForDownload(policy);
      const ExperienceMap map =
          ExperienceMap::FromGraph(download.map.nodes, download.map.edges, vocabulary_);
      std::vector<FrameTrace> traces;
      const HeldOutRun one =
          Localise(name, fold.number, map, PathMemoryOf(download.map), {index}, &traces);
      run.frames += one.frames;
      run.localised_frames += one.localised_frames;
      run.gaps_m.insert(run.gaps_m.end(), one.gaps_m.begin(), one.gaps_m.end());
      run.localised.insert(run.localised.end(), one.localised.begin(), one.localised.end());
      node_sum += download.map.nodes.size();
      if (name == "copy") copy_runs[index] = one;
      FleetDownload row =
          DownloadRow(fold.number, name, policy, download, copy_nodes, merged.paths.size());
      DiagnoseDownload(index, merged, stamp_of, policy, download.map, one, copy_runs[index], row);
      row.reach = Reach(map, {index}, one.localised, traces, copy_runs[index].localised);
      const std::lock_guard lock(result_mutex_);
      result_.downloads.push_back(row);
    }
    run.map_nodes = node_sum / std::max<std::size_t>(1, fold.test.size());
    RecordRun(std::move(run));
  }
}

FleetDownload FleetRun::DownloadRow(int fold, const std::string& name, const DownloadPolicy& policy,
                                    const Download& download, std::size_t copy_nodes,
                                    std::size_t map_paths) {
  FleetDownload row;
  row.fold = fold;
  row.policy = name;
  row.mission_start_min = policy.mission_start_min;
  row.nodes = download.map.nodes.size();
  row.copy_nodes = copy_nodes;
  row.bytes = download.report.bytes;
  row.bridging_nodes = download.report.integrity.bridging_nodes;
  row.components_before = download.report.integrity.fragments_before;
  row.components_after = download.report.integrity.components_after;
  row.picked_nodes = download.report.picked_nodes;
  row.paths_chosen = download.report.paths_chosen;
  row.stretches = download.report.stretches;
  row.stretches_reached_outside = download.report.stretches_reached_outside;
  row.nodes_on_chosen_paths = download.report.nodes_on_chosen_paths;
  row.map_paths = map_paths;
  row.derived_edges = download.report.derived_edges;
  return row;
}

std::vector<std::pair<std::string, DownloadPolicy>> FleetRun::FrontierPoints() const {
  std::vector<std::pair<std::string, DownloadPolicy>> points;
  const auto add = [&](const std::string& name, const std::string& label,
                       const std::function<void(DownloadPolicy&)>& set) {
    DownloadPolicy policy = ParseDownloadPolicy(name);
    if (options_.tod_window_min > 0) policy.window_min = options_.tod_window_min;
    policy.best_percent = options_.paths_percent;
    policy.epoch_min = options_.epoch_min;
    policy.coverage = options_.coverage;
    set(policy);
    points.emplace_back(label.empty() ? name : name + " " + label, policy);
  };
  const auto nothing = [](DownloadPolicy&) {};
  for (const std::string name : {"tod", "tod+paths", "tod+cover", "tod+paths+cover"}) {
    add(name, "", nothing);
  }
  for (const double window : {60.0, 90.0, 120.0, 360.0}) {
    const std::string label = "T_w=" + std::to_string(static_cast<int>(window));
    for (const std::string name : {"tod", "tod+cover"}) {
      add(name, label, [window](DownloadPolicy& p) { p.window_min = window; });
    }
  }
  for (const int k : {1, 3}) {
    add("tod+cover", "k=" + std::to_string(k),
        [k](DownloadPolicy& p) { p.coverage.experiences = k; });
  }
  for (const auto& [k, cap] : {std::pair(1, 1), std::pair(1, 2), std::pair(2, 2), std::pair(2, 3),
                               std::pair(2, 4), std::pair(2, 6)}) {
    add("tod+cover", "k=" + std::to_string(k) + " cap=" + std::to_string(cap),
        [k = k, cap = cap](DownloadPolicy& p) {
          p.coverage.experiences = k;
          p.coverage.most_experiences = cap;
        });
  }
  for (const double share : {25.0, 75.0}) {
    add("tod+paths+cover", "p=" + std::to_string(static_cast<int>(share)),
        [share](DownloadPolicy& p) { p.best_percent = share; });
  }
  return points;
}

void FleetRun::Frontier(const FoldState& fold, Repository& repository,
                        const std::vector<Uuid>& depot, const GraphBatch& merged) {
  std::int64_t copy_bytes = 0;
  for (const Node& node : merged.nodes) {
    copy_bytes += static_cast<std::int64_t>(node.landmarks_blob.size());
  }
  for (auto& [label, policy] : FrontierPoints()) {
    FleetFrontierPoint point;
    point.label = label;
    point.policy = policy.Name();
    point.fold = fold.number;
    policy.include = depot;
    for (std::size_t index : fold.test) {
      policy.mission_start_min = outings_[index].start_time_h * 60.0;
      const Download download = repository.SelectForDownload(policy);
      const HeldOutRun run = LocaliseContent(label, fold.number, download.map, {index});
      ++point.downloads;
      point.node_share_sum += static_cast<double>(download.map.nodes.size()) /
                              static_cast<double>(std::max<std::size_t>(1, merged.nodes.size()));
      point.bytes += download.report.bytes;
      point.copy_bytes += copy_bytes;
      point.frames += run.frames;
      point.not_localised += run.frames - run.localised_frames;
      for (const float gap : run.gaps_m) point.beyond_10m += gap > 10.0f ? 1 : 0;
    }
    const std::lock_guard lock(result_mutex_);
    result_.frontier.push_back(point);
  }
}

}  // namespace fleetmap::fleet_internal
