#include "fleetmap/runners/ranking_experiment.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <memory>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_ranking.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_runs.h"
#include "outing_runs.h"
#include "task_queue.h"
#include "work_progress.h"

namespace fleetmap {
namespace {

using Clock = std::chrono::steady_clock;

void Validate(const RankingExperimentOptions& o) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "ranking experiment: " + what);
  };
  if (o.folds < 2) fail("folds must be >= 2");
  if (o.cores.empty()) fail("cores must list at least one Np");
  for (int np : o.cores) {
    if (np < 1) fail("every Np in cores must be >= 1");
  }
  for (int t : o.windows) {
    if (t < 0) fail("every T in windows must be >= 0");
  }
  if (o.reference_cores < 1) fail("reference_cores must be >= 1");
  if (o.default_window < 0) fail("default_window must be >= 0");
  if (o.map_size_steps < 1) fail("map_size_steps must be >= 1");
  if (o.build_cores < 1) fail("build_cores must be >= 1");
  if (o.build_rounds < 1) fail("build_rounds must be >= 1");
  if (o.threads < 1) fail("threads must be >= 1");
  if (o.work_dir.empty()) fail("work_dir must be set");
}

// Everything one fold needs after its map is built, shared read-only by its runs.
struct RankingFoldState {
  std::vector<std::size_t> test_outings;      // indexes into the schedule, in time order
  std::vector<std::size_t> training_outings;  // likewise
  std::unique_ptr<ExperienceMap> map;
  PathMemory memory;
};

class Experiment {
 public:
  Experiment(const RankingExperimentOptions& options, const ProgressCallback& progress)
      : options_(options), progress_(progress), world_(options.world) {}

  RankingExperimentResult Run() {
    const Clock::time_point start = Clock::now();
    Prepare();
    RankingExperimentResult result;
    result.outings = static_cast<int>(outings_.size());
    for (const auto& frames : frames_)
      result.frames_rendered += static_cast<std::int64_t>(frames.size());
    result.builds.resize(static_cast<std::size_t>(options_.folds));

    TaskQueue queue;
    for (int fold = 0; fold < options_.folds; ++fold) {
      queue.Push([this, fold, &queue, &result] {
        result.builds[static_cast<std::size_t>(fold)] = Build(fold);
        // The fold's full-map runs queue up as soon as its map exists.
        for (RunSpec spec : FullMapRuns(fold)) {
          queue.Push([this, spec] { Store(Localise(spec)); });
        }
      });
    }
    queue.Run(options_.threads);

    result.runs = std::move(runs_);
    std::sort(result.runs.begin(), result.runs.end(), [](const auto& a, const auto& b) {
      return std::tie(a.policy, a.cores, a.window, a.map_step, a.fold) <
             std::tie(b.policy, b.cores, b.window, b.map_step, b.fold);
    });
    result.seconds = SecondsSince(start);
    return result;
  }

 private:
  struct RunSpec {
    std::string policy;
    int cores;
    int window;
    int fold;
    int map_step;
  };

  void Prepare() {
    outings_ = ScheduleOutings(options_.world);
    vocabulary_ = TrainWorldVocabulary(world_);
    frames_ = RenderOutings(world_, outings_, options_.threads);

    folds_.resize(static_cast<std::size_t>(options_.folds));
    // Outings are in time order; dealing them out round-robin gives every fold the whole
    // period (seed 002 §VII: the datasets divided into five groups).
    for (std::size_t i = 0; i < outings_.size(); ++i) {
      for (int fold = 0; fold < options_.folds; ++fold) {
        auto& state = folds_[static_cast<std::size_t>(fold)];
        (static_cast<int>(i % static_cast<std::size_t>(options_.folds)) == fold
             ? state.test_outings
             : state.training_outings)
            .push_back(i);
      }
    }
    for (const RankingFoldState& fold : folds_) {
      if (fold.test_outings.empty() || fold.training_outings.empty()) {
        throw Error(ErrorCode::kInvalidArgument, "ranking experiment: too few outings for " +
                                                     std::to_string(options_.folds) + " folds");
      }
    }
    std::int64_t total = 0;
    for (const RankingFoldState& fold : folds_) {
      const std::int64_t test = Frames(fold.test_outings);
      total += Frames(fold.training_outings);
      total += test * static_cast<std::int64_t>(RunsPerFold());
    }
    progress_.Plan(total);
  }

  std::int64_t Frames(const std::vector<std::size_t>& outings) const {
    std::int64_t n = 0;
    for (std::size_t i : outings) n += static_cast<std::int64_t>(frames_[i].size());
    return n;
  }

  std::size_t RunsPerFold() const {
    return 2 * static_cast<std::size_t>(options_.map_size_steps - 1) + FullMapRuns(0).size();
  }

  std::vector<RunSpec> FullMapRuns(int fold) const {
    const int steps = options_.map_size_steps;
    std::vector<RunSpec> specs;
    std::vector<int> cores = options_.cores;
    if (std::find(cores.begin(), cores.end(), options_.reference_cores) == cores.end()) {
      cores.push_back(options_.reference_cores);  // the last point of the map-size curve
    }
    for (int np : cores) {
      specs.push_back({"distance", np, 0, fold, steps});
      specs.push_back({"path", np, options_.default_window, fold, steps});
    }
    for (int t : options_.windows) {
      if (t != options_.default_window) {
        specs.push_back({"path", options_.reference_cores, t, fold, steps});
      }
    }
    return specs;
  }

  OutingStart Start(std::size_t outing, const RankingFoldState& fold) const {
    return DepotStart(outings_[outing], *fold.map);
  }

  void Advance(std::int64_t frames) { progress_.Advance(frames); }

  FoldBuild Build(int fold_number) {
    const Clock::time_point start = Clock::now();
    RankingFoldState& fold = folds_[static_cast<std::size_t>(fold_number)];
    const std::string uri =
        "sqlite:" + (options_.work_dir / ("fold-" + std::to_string(fold_number) + ".db")).string();
    std::unique_ptr<GraphStore> store =
        GraphStore::Open(uri, {.durability = Durability::kBuffered});
    fold.map = std::make_unique<ExperienceMap>(vocabulary_);
    DistanceRanking policy;
    BuilderOptions builder_options = options_.builder;
    builder_options.cores = options_.build_cores;
    builder_options.rounds = options_.build_rounds;
    builder_options.localise_only = false;
    ExperienceBuilder builder(store.get(), *fold.map, policy, builder_options);

    FoldBuild build;
    build.fold = fold_number;
    build.training_outings = static_cast<int>(fold.training_outings.size());
    const std::size_t n = fold.training_outings.size();
    int next_step = 1;
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t index = fold.training_outings[k];
      builder.StartOuting(Start(index, fold));
      for (const Frame& frame : frames_[index]) builder.Process(frame);
      builder.FinishOuting();
      build.frames += static_cast<std::int64_t>(frames_[index].size());
      build.nodes_after_outing.push_back(fold.map->size());
      Advance(static_cast<std::int64_t>(frames_[index].size()));
      // Fig. 9: the held-out fold against the map as it stands after each share of training.
      while (next_step < options_.map_size_steps &&
             (k + 1) * static_cast<std::size_t>(options_.map_size_steps) >=
                 static_cast<std::size_t>(next_step) * n) {
        fold.memory = PathMemory::Load(*store);
        for (const char* policy_name : {"distance", "path"}) {
          Store(Localise({policy_name, options_.reference_cores, options_.default_window,
                          fold_number, next_step}));
        }
        ++next_step;
      }
    }
    fold.memory = PathMemory::Load(*store);
    const StoreStats stats = store->Stats();
    build.nodes = static_cast<std::size_t>(stats.nodes);
    build.metric_edges = fold.map->metric_edge_count();
    build.paths = static_cast<std::size_t>(stats.paths);
    build.seconds = SecondsSince(start);
    return build;
  }

  LocalisationRun Localise(const RunSpec& spec) {
    const RankingFoldState& fold = folds_[static_cast<std::size_t>(spec.fold)];
    std::unique_ptr<RankingPolicy> policy;
    if (spec.policy == "path") {
      policy = std::make_unique<PathRanking>(fold.memory, PathRankingOptions{spec.window});
    } else {
      policy = std::make_unique<DistanceRanking>();
    }
    BuilderOptions builder_options = options_.builder;
    builder_options.cores = spec.cores;
    builder_options.rounds = 1;
    builder_options.localise_only = true;
    ExperienceBuilder localiser(nullptr, *fold.map, *policy, builder_options);

    LocalisationRun run;
    run.policy = spec.policy;
    run.cores = spec.cores;
    run.window = spec.policy == "path" ? spec.window : 0;
    run.fold = spec.fold;
    run.map_step = spec.map_step;
    run.map_nodes = fold.map->size();
    for (std::size_t index : fold.test_outings) {
      localiser.StartOuting(Start(index, fold));
      for (const Frame& frame : frames_[index]) {
        const FrameReport report = localiser.Process(frame);
        ++run.frames;
        run.localised_frames += report.successes > 0 ? 1 : 0;
        run.attempts += report.attempts;
        run.gaps_m.push_back(static_cast<float>(report.distance_since_success_m));
      }
      localiser.FinishOuting();
      Advance(static_cast<std::int64_t>(frames_[index].size()));
    }
    return run;
  }

  void Store(LocalisationRun run) {
    const std::lock_guard lock(runs_mutex_);
    runs_.push_back(std::move(run));
  }

  const RankingExperimentOptions& options_;
  WorkProgress progress_;
  World world_;
  std::vector<Outing> outings_;
  std::vector<std::vector<Frame>> frames_;
  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::vector<RankingFoldState> folds_;

  std::mutex runs_mutex_;
  std::vector<LocalisationRun> runs_;
};

}  // namespace

RankingExperimentResult RunRankingExperiment(const RankingExperimentOptions& options,
                                             const ProgressCallback& progress) {
  Validate(options);
  std::filesystem::create_directories(options.work_dir);
  return Experiment(options, progress).Run();
}

double ProbabilityGapExceeds(const std::vector<const LocalisationRun*>& runs, double x_m) {
  std::int64_t frames = 0, beyond = 0;
  for (const LocalisationRun* run : runs) {
    for (float gap : run->gaps_m) {
      ++frames;
      beyond += gap > x_m ? 1 : 0;
    }
  }
  return frames == 0 ? 0.0 : static_cast<double>(beyond) / static_cast<double>(frames);
}

}  // namespace fleetmap
