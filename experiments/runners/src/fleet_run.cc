// Running the fleet experiment (fleet_run.h): the folds and their tasks, and what every task
// shares: building a map by single-agent EBN, localising held-out outings in a map, the
// repository a fold merges through, and recording what each measured.
#include "fleet_run.h"

#include <algorithm>
#include <tuple>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_ranking.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/world/world_runs.h"
#include "outing_runs.h"
#include "task_ids.h"
#include "task_queue.h"

namespace fleetmap::fleet_internal {

FleetExperimentResult FleetRun::Run() {
  const Clock::time_point start = Clock::now();
  Prepare();
  TaskQueue queue;
  // Each task under the ids of its own name (task_ids.h), when they are deterministic.
  const auto ids = [this](const std::string& task, const FoldState& fold) {
    return TaskIds(options_.deterministic_ids, options_.world.seed,
                   task + " " + std::to_string(fold.number));
  };
  for (FoldState& fold : folds_) {
    queue.Push([this, &fold, ids] {
      const TaskIds task = ids("single", fold);
      SingleAgent(fold);
    });
    for (std::size_t g = 0; g < fold.groups.size(); ++g) {
      queue.Push([this, &fold, g, &queue, ids] {
        {
          const TaskIds task = ids("group " + std::to_string(g), fold);
          BuildGroup(fold, g);
        }
        if (--fold.groups_left == 0) {
          queue.Push([this, &fold, ids] {
            const TaskIds task = ids("merge", fold);
            MergeAndDownload(fold);
          });
          if (fold.number < options_.dream_folds) {
            queue.Push([this, &fold, ids] {
              const TaskIds task = ids("dream", fold);
              Dreaming(fold);
            });
          }
        }
      });
    }
    if (options_.sharing) {
      queue.Push([this, &fold, ids] {
        const TaskIds task = ids("sharing", fold);
        Sharing(fold);
      });
    }
  }
  queue.Run(options_.threads);
  for (const FoldState& fold : folds_) DiagnoseMerge(fold);

  result_.outings = static_cast<int>(outings_.size());
  for (const auto& frames : frames_) {
    result_.frames_rendered += static_cast<std::int64_t>(frames.size());
  }
  Sort();
  result_.seconds = SecondsSince(start);
  return std::move(result_);
}

void FleetRun::Prepare() {
  outings_ = ScheduleOutings(options_.world);
  vocabulary_ = TrainWorldVocabulary(world_);
  // One appearance-index vocabulary for every fold's repository, as a fleet's one store trains
  // one at its first merge and keeps it: not one per fold.
  index_vocabulary_ = TrainWorldVocabulary(world_, IndexVocabularyOptions());
  frames_ = RenderOutings(world_, outings_, options_.threads);
  for (std::size_t i = 0; i < outings_.size(); ++i) outing_index_.emplace(outings_[i].id, i);

  // Outings are in time order; dealt round-robin, every fold spans the whole period.
  const auto folds = static_cast<std::size_t>(options_.folds);
  folds_ = std::vector<FoldState>(folds);
  for (std::size_t f = 0; f < folds; ++f) {
    FoldState& fold = folds_[f];
    fold.number = static_cast<int>(f);
    for (std::size_t i = 0; i < outings_.size(); ++i) {
      if (i % folds == f) {
        fold.test.push_back(i);
      } else {
        fold.training.push_back(i);
      }
    }
    // The other folds, in fold order, are the groups of the merging strategy.
    for (std::size_t g = 0; g < folds; ++g) {
      if (g == f) continue;
      std::vector<std::size_t> group;
      for (std::size_t i = g; i < outings_.size(); i += folds) group.push_back(i);
      fold.groups.push_back(std::move(group));
    }
    fold.group_maps.resize(fold.groups.size());
    fold.groups_left = static_cast<int>(fold.groups.size());
    if (fold.test.empty() || fold.training.empty()) {
      throw Error(ErrorCode::kInvalidArgument, "fleet experiment: too few outings for " +
                                                   std::to_string(options_.folds) + " folds");
    }
  }
  std::int64_t total = 0;
  for (const FoldState& fold : folds_) {
    const std::int64_t training = Frames(fold.training), test = Frames(fold.test);
    // single + groups + alone (both robots) + shared forays; held-out runs: single, merged,
    // r1, r2, shared, five downloads, and the orders when dreaming.
    total += (options_.sharing ? 4 : 2) * training + (options_.sharing ? 10 : 7) * test;
    if (options_.frontier) {
      total += static_cast<std::int64_t>(FrontierPoints().size()) * test;
    }
    if (fold.number < options_.dream_folds) {
      std::int64_t orders = 1;
      for (std::size_t k = 2; k <= fold.groups.size(); ++k) {
        orders *= static_cast<std::int64_t>(k);
      }
      total += orders * test;
    }
  }
  progress_.Plan(total);
}

std::int64_t FleetRun::Frames(const std::vector<std::size_t>& outings) const {
  std::int64_t n = 0;
  for (std::size_t i : outings) n += static_cast<std::int64_t>(frames_[i].size());
  return n;
}

BuilderOptions FleetRun::Builder(bool localise_only, int cores) const {
  BuilderOptions builder = options_.builder;
  builder.cores = cores;
  builder.rounds = 1;
  builder.localise_only = localise_only;
  return builder;
}

BuiltMap FleetRun::Build(const std::string& name, const std::vector<std::size_t>& outings,
                         const GraphBatch* start, int cost_fold) {
  const Clock::time_point wall = Clock::now();
  const double cpu = ThreadCpuSeconds();
  std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (options_.work_dir / (name + ".db")).string(),
                       {.durability = Durability::kBuffered});
  std::unique_ptr<ExperienceMap> map;
  if (start) {
    store->Put(*start);
    map = std::make_unique<ExperienceMap>(
        ExperienceMap::FromGraph(start->nodes, start->edges, vocabulary_));
  } else {
    map = std::make_unique<ExperienceMap>(vocabulary_);
  }
  DistanceRanking policy;
  ExperienceBuilder builder(store.get(), *map, policy, Builder(false, options_.build_cores));
  for (std::size_t index : outings) {
    const std::size_t map_nodes = map->size();
    const double outing_cpu = ThreadCpuSeconds();
    builder.StartOuting(DepotStart(outings_[index], *map));
    for (const Frame& frame : frames_[index]) builder.Process(frame);
    builder.FinishOuting();
    if (cost_fold >= 0) {
      const std::lock_guard lock(result_mutex_);
      result_.frame_costs.push_back({cost_fold, map_nodes,
                                     static_cast<std::int64_t>(frames_[index].size()),
                                     ThreadCpuSeconds() - outing_cpu});
    }
    Advance(static_cast<std::int64_t>(frames_[index].size()));
  }
  BuiltMap built;
  built.content = store->ReadMap();
  built.nodes = map->size();
  built.cpu_seconds = ThreadCpuSeconds() - cpu;
  built.wall_seconds = SecondsSince(wall);
  return built;
}

HeldOutRun FleetRun::Localise(const std::string& name, int fold, const ExperienceMap& map,
                              const PathMemory& memory, const std::vector<std::size_t>& outings,
                              std::vector<FrameTrace>* traces) {
  std::unique_ptr<RankingPolicy> policy;
  if (options_.test_policy == "path") {
    policy = std::make_unique<PathRanking>(memory, PathRankingOptions{options_.test_window});
  } else {
    policy = std::make_unique<DistanceRanking>();
  }
  if (traces != nullptr) policy = std::make_unique<OwningTracer>(std::move(policy), *traces);
  OutingLocalisation localised;
  for (std::size_t index : outings) {
    LocaliseOuting(map, *policy, Builder(true, options_.test_cores),
                   DepotStart(outings_[index], map), frames_[index], localised);
    Advance(static_cast<std::int64_t>(frames_[index].size()));
  }
  HeldOutRun run;
  run.map = name;
  run.fold = fold;
  run.map_nodes = map.size();
  run.frames = localised.frames();
  run.localised_frames = run.frames - localised.not_localised();
  run.gaps_m = std::move(localised.gaps_m);
  run.localised = std::move(localised.localised);
  run.references = std::move(localised.references);
  return run;
}

HeldOutRun FleetRun::LocaliseContent(const std::string& name, int fold, const GraphBatch& content,
                                     const std::vector<std::size_t>& outings,
                                     std::vector<FrameTrace>* traces) {
  const ExperienceMap map = ExperienceMap::FromGraph(content.nodes, content.edges, vocabulary_);
  return Localise(name, fold, map, PathMemoryOf(content), outings, traces);
}

std::string FleetRun::StorePath(const FoldState& fold, const std::string& name) const {
  return "fold-" + std::to_string(fold.number) + "-" + name;
}

void FleetRun::RecordBuild(FleetBuild build) {
  const std::lock_guard lock(result_mutex_);
  result_.builds.push_back(std::move(build));
}

void FleetRun::RecordRun(HeldOutRun run) {
  const std::lock_guard lock(result_mutex_);
  result_.runs.push_back(std::move(run));
}

MergeOptions FleetRun::Merging() const {
  MergeOptions merge = options_.merge;
  merge.localiser = Builder(true, options_.build_cores);
  return merge;
}

std::unique_ptr<Repository> FleetRun::OpenRepository(const FoldState& fold,
                                                     const std::string& name) {
  RepositoryOptions repository;
  repository.merge = Merging();
  repository.vocabulary = vocabulary_;
  repository.index_vocabulary = index_vocabulary_;
  return std::make_unique<Repository>(
      GraphStore::Open("sqlite:" + (options_.work_dir / (StorePath(fold, name) + ".db")).string(),
                       {.durability = Durability::kBuffered}),
      repository);
}

Uuid FleetRun::GroupRobot(std::size_t group) {
  Uuid::Bytes bytes{};
  bytes[0] = 0xF1;
  bytes[6] = 0x40;
  bytes[8] = 0x80;
  bytes[15] = static_cast<std::uint8_t>(group + 1);
  return Uuid(bytes);
}

double FleetRun::ProbabilityGapExceeds(const HeldOutRun& run, double x_m) {
  std::int64_t beyond = 0;
  for (float gap : run.gaps_m) beyond += gap > x_m ? 1 : 0;
  return run.gaps_m.empty() ? 0.0
                            : static_cast<double>(beyond) / static_cast<double>(run.gaps_m.size());
}

void FleetRun::Sort() {
  std::sort(result_.merge_decisions.begin(), result_.merge_decisions.end());
  std::sort(result_.builds.begin(), result_.builds.end(), [](const auto& a, const auto& b) {
    return std::tie(a.fold, a.map) < std::tie(b.fold, b.map);
  });
  std::sort(result_.runs.begin(), result_.runs.end(), [](const auto& a, const auto& b) {
    return std::tie(a.map, a.fold) < std::tie(b.map, b.fold);
  });
  std::sort(result_.downloads.begin(), result_.downloads.end(), [](const auto& a, const auto& b) {
    return std::tie(a.policy, a.fold, a.mission_start_min) <
           std::tie(b.policy, b.fold, b.mission_start_min);
  });
  std::sort(result_.dream_timings.begin(), result_.dream_timings.end(),
            [](const auto& a, const auto& b) { return a.fold < b.fold; });
  std::sort(result_.edge_errors.begin(), result_.edge_errors.end(),
            [](const auto& a, const auto& b) {
              return std::tie(a.map, a.fold) < std::tie(b.map, b.fold);
            });
  std::sort(result_.layout_errors.begin(), result_.layout_errors.end(),
            [](const auto& a, const auto& b) {
              return std::tie(a.map, a.fold, a.layout) < std::tie(b.map, b.fold, b.layout);
            });
}

}  // namespace fleetmap::fleet_internal
