// The fleet experiment's maps (fleet_run.h): single-agent EBN and the groups of the merging
// strategy (Fig. 7), two robots alone and sharing through the server (Fig. 8), and the groups
// merged in every order (Fig. 10, dreaming).
#include <numeric>

#include "fleet_run.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/map_management/dreaming.h"
#include "outing_runs.h"

namespace fleetmap::fleet_internal {

void FleetRun::SingleAgent(FoldState& fold) {
  BuiltMap single = Build(StorePath(fold, "single"), fold.training, nullptr, fold.number);
  RecordBuild({"single", fold.number, single.nodes, single.cpu_seconds, single.wall_seconds});
  HeldOutRun run = LocaliseContent("single", fold.number, single.content, fold.test);
  fold.single_places = Places(single.content);
  RecordEdgeErrors(fold.number, "single", single.content);
  RecordLayoutErrors(fold.number, "single", single.content);
  fold.single_localised = run.localised;
  RecordRun(std::move(run));
  // How much of it MERGE finds redundant: merged into an empty map, what does it keep? This
  // bounds how far below single-agent EBN's size a merged map can go on this world.
  const Clock::time_point wall = Clock::now();
  const double cpu = ThreadCpuSeconds();
  ExperienceMap empty(vocabulary_);
  const MergeResult self =
      Merge(empty, single.content,
            {[](const Uuid&) { return false; }, [](const Uuid&) { return false; }, {}}, Merging());
  RecordBuild({"single self-merge", fold.number, self.report.nodes_added, ThreadCpuSeconds() - cpu,
               SecondsSince(wall)});
}

void FleetRun::BuildGroup(FoldState& fold, std::size_t g) {
  BuiltMap built = Build(StorePath(fold, "group-" + std::to_string(g)), fold.groups[g]);
  RecordBuild({"group " + std::to_string(g), fold.number, built.nodes, built.cpu_seconds,
               built.wall_seconds});
  RecordEdgeErrors(fold.number, "groups", built.content);
  fold.group_maps[g] = std::move(built);
}

void FleetRun::Sharing(FoldState& fold) {
  std::vector<std::size_t> robots[2], forays[2][2];
  for (std::size_t k = 0; k < fold.training.size(); ++k) {
    robots[k % 2].push_back(fold.training[k]);
  }
  for (int r = 0; r < 2; ++r) {
    const std::size_t half = robots[r].size() / 2;
    forays[r][0].assign(robots[r].begin(), robots[r].begin() + static_cast<long>(half));
    forays[r][1].assign(robots[r].begin() + static_cast<long>(half), robots[r].end());
    const std::string name = "r" + std::to_string(r + 1);
    const BuiltMap alone = Build(StorePath(fold, name + "-alone"), robots[r]);
    RecordRun(LocaliseContent(name, fold.number, alone.content, fold.test));
  }
  std::unique_ptr<Repository> server = OpenRepository(fold, "shared");
  const auto push = [&](int r, const GraphBatch& map) {
    const Uuid submission = Uuid::Generate();
    server->Push(submission, GroupRobot(100 + static_cast<std::size_t>(r)),
                 "r" + std::to_string(r + 1), map);
    server->Merge(submission);
  };
  for (int r = 0; r < 2; ++r) {
    push(r, Build(StorePath(fold, "r" + std::to_string(r + 1) + "-foray-1"), forays[r][0]).content);
  }
  const GraphBatch copy = server->Checkout();  // both robots download the whole map
  for (int r = 0; r < 2; ++r) {
    push(r, Build(StorePath(fold, "r" + std::to_string(r + 1) + "-foray-2"), forays[r][1], &copy)
                .content);
  }
  RecordRun(LocaliseContent("shared", fold.number, server->Checkout(), fold.test));
}

void FleetRun::Dreaming(FoldState& fold) {
  std::vector<GraphBatch> groups;
  double group_seconds = 0.0;
  for (const BuiltMap& built : fold.group_maps) {
    groups.push_back(built.content);
    group_seconds += built.cpu_seconds;
  }
  const auto k = static_cast<int>(groups.size());
  const DreamScorer scorer = [&](const DreamCandidate& candidate) {
    std::string name = "order ";
    for (int g : *candidate.order) name += std::to_string(g);
    HeldOutRun run =
        Localise(name, fold.number, *candidate.map, PathMemoryOf(*candidate.content), fold.test);
    const double score = ProbabilityGapExceeds(run, 10.0);
    RecordRun(std::move(run));
    return score;
  };
  DreamOptions dream;
  dream.merge = Merging();
  const DreamResult result = Dream(groups, GraphBatch{}, vocabulary_, scorer, dream);

  FleetDreamTiming timing;
  timing.fold = fold.number;
  timing.groups = k;
  timing.group_seconds = group_seconds / k;
  const auto mean = [](const std::vector<double>& v) {
    return v.empty() ? 0.0
                     : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
  };
  const auto sum = [](const std::vector<double>& v) {
    return std::accumulate(v.begin(), v.end(), 0.0);
  };
  timing.merge_seconds = mean(result.merge_seconds);
  timing.copy_seconds = mean(result.copy_seconds);
  timing.merges = result.merge_seconds.size();
  timing.copies = result.copy_seconds.size();
  timing.orders = result.orders.size();
  timing.dream_seconds = k * timing.group_seconds + sum(result.first_merge_seconds) +
                         sum(result.merge_seconds) + sum(result.copy_seconds);
  timing.predicted_ratio =
      DreamingTimeRatio(k, timing.group_seconds, timing.merge_seconds, timing.copy_seconds);
  double orders = 1.0;
  for (int i = 2; i <= k; ++i) orders *= i;
  timing.measured_ratio = timing.dream_seconds / ((orders * (k - 1) + 1) * timing.group_seconds +
                                                  (orders - 1) * timing.copy_seconds);
  timing.best = result.best;
  const std::lock_guard lock(result_mutex_);
  for (const DreamOrderResult& order : result.orders) {
    result_.dream_orders.push_back({fold.number, order.order, order.score, order.nodes});
  }
  result_.dream_timings.push_back(timing);
}

}  // namespace fleetmap::fleet_internal
