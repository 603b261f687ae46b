#include "fleetmap/runners/lifelong_experiment.h"

#include <atomic>
#include <chrono>
#include <cmath>
#include <memory>
#include <mutex>
#include <optional>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_ranking.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_runs.h"
#include "outing_runs.h"
#include "task_ids.h"
#include "task_queue.h"
#include "work_progress.h"

namespace fleetmap {
namespace {

void Validate(const LifelongOptions& o) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "lifelong experiment: " + what);
  };
  if (o.days < 2) fail("days must be >= 2");
  if (o.forays_per_day < 1) fail("forays_per_day must be >= 1");
  if (o.build_cores < 1 || o.test_cores < 1) fail("build_cores and test_cores must be >= 1");
  if (o.build_policy != "path" && o.build_policy != "distance") {
    fail("build_policy must be path or distance, not " + o.build_policy);
  }
  if (o.test_window < 0) fail("test_window must be >= 0");
  if (!(o.retire_after_days >= 0.0 && o.retire_after_days <= 36500.0)) {
    fail("retire_after_days must be in [0, 36500]");
  }
  // The repository checks the rest when it retires, after the arm without has run.
  if (!(o.retire.place_radius_m > 0.0) || !std::isfinite(o.retire.place_radius_m)) {
    fail("retire.place_radius_m must be > 0");
  }
  if (o.threads < 1) fail("threads must be >= 1");
  if (o.work_dir.empty()) fail("work_dir must be set");
  for (const std::string& name : o.policies) {
    if (name == "copy") fail("copy is always measured; list only the other policies");
    ParseDownloadPolicy(name);  // throws naming a bad one
  }
}

class LifelongRun {
 public:
  LifelongRun(const LifelongOptions& options, const ProgressCallback& progress)
      : options_(options), progress_(progress), world_(options.world) {}

  LifelongResult Run() {
    const auto start = std::chrono::steady_clock::now();
    Prepare();
    // Without first, then with: the same forays, each arm in a repository of its own.
    result_.days = RunArm(options_.work_dir / "server.db", std::nullopt);
    if (options_.retire_after_days > 0) {
      RetireOptions retire = options_.retire;
      retire.retire_after_ns = static_cast<std::int64_t>(
          std::llround(options_.retire_after_days * static_cast<double>(kNanosecondsPerDay)));
      retire.now_ns = std::nullopt;
      result_.retiring_days = RunArm(options_.work_dir / "server-retiring.db", retire);
    }
    result_.seconds = SecondsSince(start);
    return std::move(result_);
  }

 private:
  std::vector<LifelongDay> RunArm(const std::filesystem::path& database,
                                  const std::optional<RetireOptions>& retirement) {
    OpenRepository(database);
    std::vector<LifelongDay> days;
    for (int day = 0; day < options_.days; ++day) {
      LifelongDay row = DriveAndMerge(day);
      if (retirement) {
        // Between the day's merges and the next day's pull, as a depot would run it overnight.
        const std::optional<Revision> retired = repository_->Retire(*retirement, "lifelong");
        if (retired) row.nodes_retired = static_cast<std::size_t>(retired->nodes_hidden);
      }
      const StoreStats stats = repository_->inspect().StatsAt(repository_->Head());
      row.map_nodes = static_cast<std::size_t>(stats.nodes);
      row.map_bytes = stats.landmark_bytes;
      row.world_replaced = world_.LandmarksReplacedBetween(day, day + 1.0);
      row.next_day = HoldOut(day + 1);
      days.push_back(std::move(row));
    }
    repository_.reset();
    return days;
  }

  void Prepare() {
    outings_ = ScheduleDailyOutings(options_.world, options_.days + 1, options_.forays_per_day);
    vocabulary_ = TrainWorldVocabulary(world_);
    frames_ = RenderOutings(world_, outings_, options_.threads);
    for (const auto& frames : frames_) {
      result_.frames_rendered += static_cast<std::int64_t>(frames.size());
    }
    // Building every day, and localising every later day in copy and each download.
    std::int64_t total = 0;
    for (std::size_t i = 0; i < outings_.size(); ++i) {
      const auto frames = static_cast<std::int64_t>(frames_[i].size());
      if (outings_[i].day < options_.days) total += frames;
      if (outings_[i].day > 0) {
        total += frames * static_cast<std::int64_t>(1 + options_.policies.size());
      }
    }
    const int arms = options_.retire_after_days > 0 ? 2 : 1;
    progress_.Plan(total * arms);
  }

  void OpenRepository(const std::filesystem::path& database) {
    RepositoryOptions repository;
    repository.merge = options_.merge;
    repository.merge.localiser = Builder(true, options_.build_cores);
    repository.vocabulary = vocabulary_;
    repository_ = std::make_unique<Repository>(
        GraphStore::Open("sqlite:" + database.string(), {.durability = Durability::kBuffered}),
        repository);
  }

  BuilderOptions Builder(bool localise_only, int cores) const {
    BuilderOptions builder = options_.builder;
    builder.cores = cores;
    builder.rounds = 1;
    builder.localise_only = localise_only;
    return builder;
  }

  std::vector<std::size_t> OutingsOf(int day) const {
    std::vector<std::size_t> of_day;
    for (std::size_t i = 0; i < outings_.size(); ++i) {
      if (outings_[i].day == day) of_day.push_back(i);
    }
    return of_day;
  }

  void Advance(std::int64_t frames) { progress_.Advance(frames); }

  // The ids of one task (task_ids.h): named alike in both arms, which are then paired.
  TaskIds Ids(const std::string& task, int day, std::size_t k) const {
    return TaskIds(options_.deterministic_ids, options_.world.seed,
                   task + " " + std::to_string(day) + " " + std::to_string(k));
  }

  // One foray: single-agent EBN onto the copy it pulled; what it built, to push.
  GraphBatch Drive(const GraphBatch& copy, std::size_t outing) {
    ExperienceMap map = ExperienceMap::FromGraph(copy.nodes, copy.edges, vocabulary_);
    CollectingWriter built;
    std::unique_ptr<RankingPolicy> policy;
    if (options_.build_policy == "path") {
      policy = std::make_unique<PathRanking>(PathMemoryOf(copy),
                                             PathRankingOptions{options_.test_window});
    } else {
      policy = std::make_unique<DistanceRanking>();
    }
    ExperienceBuilder builder(&built, map, *policy, Builder(false, options_.build_cores));
    builder.StartOuting(DepotStart(outings_[outing], map));
    for (const Frame& frame : frames_[outing]) builder.Process(frame);
    builder.FinishOuting();
    Advance(static_cast<std::int64_t>(frames_[outing].size()));
    return built.written();
  }

  LifelongDay DriveAndMerge(int day) {
    const std::vector<std::size_t> forays = OutingsOf(day);
    const GraphBatch copy = repository_->Checkout();
    std::vector<GraphBatch> built(forays.size());
    TaskQueue drives;
    for (std::size_t k = 0; k < forays.size(); ++k) {
      drives.Push([this, &built, &copy, &forays, day, k] {
        const TaskIds ids = Ids("drive", day, k);
        built[k] = Drive(copy, forays[k]);
      });
    }
    drives.Run(options_.threads);
    const TaskIds ids = Ids("merge", day, 0);

    LifelongDay row;
    row.day = day + 1;
    row.forays = static_cast<int>(forays.size());
    for (std::size_t k = 0; k < forays.size(); ++k) {
      row.nodes_built += built[k].nodes.size();
      const Uuid submission = Uuid::Generate();
      repository_->Push(submission, outings_[forays[k]].robot,
                        "day " + std::to_string(day + 1) + " foray " + std::to_string(k + 1),
                        built[k]);
      const MergeOutcome outcome = repository_->Merge(submission);
      row.nodes_added += outcome.report.nodes_added;
    }
    return row;
  }

  // Day `day`'s forays, before they drive, localised in copy and in each download.
  std::vector<LifelongHeldOut> HoldOut(int day) {
    const std::vector<std::size_t> forays = OutingsOf(day);
    const GraphBatch copy = repository_->Checkout();
    std::vector<Uuid> depot;
    if (!copy.nodes.empty()) {
      depot.push_back(
          std::min_element(copy.nodes.begin(), copy.nodes.end(), [](const Node& a, const Node& b) {
            return std::pair(a.stamp_ns, a.id) < std::pair(b.stamp_ns, b.id);
          })->id);
    }
    // The maps: copy, then every policy's download per foray (the repository serves one thread,
    // so the selections are made here, the localisations in parallel).
    struct Job {
      std::size_t map = 0;  // 0: copy, else 1 + policy index
      std::size_t outing = 0;
      std::shared_ptr<const GraphBatch> content;
    };
    std::vector<Job> jobs;
    auto whole = std::make_shared<const GraphBatch>(copy);
    for (const std::size_t outing : forays) jobs.push_back({0, outing, whole});
    for (std::size_t p = 0; p < options_.policies.size(); ++p) {
      DownloadPolicy policy = ParseDownloadPolicy(options_.policies[p]);
      if (options_.tod_window_min > 0) policy.window_min = options_.tod_window_min;
      policy.best_percent = options_.paths_percent;
      policy.epoch_min = options_.epoch_min;
      policy.coverage = options_.coverage;
      policy.include = depot;
      for (const std::size_t outing : forays) {
        policy.mission_start_min = outings_[outing].start_time_h * 60.0;
        jobs.push_back(
            {p + 1, outing,
             std::make_shared<const GraphBatch>(repository_->SelectForDownload(policy).map)});
      }
    }
    std::vector<LifelongHeldOut> held(1 + options_.policies.size());
    held[0].map = "copy";
    for (std::size_t p = 0; p < options_.policies.size(); ++p) {
      held[p + 1].map = options_.policies[p];
    }
    std::mutex held_mutex;
    TaskQueue localise;
    for (std::size_t j = 0; j < jobs.size(); ++j) {
      localise.Push([this, &job = jobs[j], &held, &held_mutex, day, j] {
        const TaskIds ids = Ids("hold out", day, j);
        const ExperienceMap map =
            ExperienceMap::FromGraph(job.content->nodes, job.content->edges, vocabulary_);
        PathRanking policy(PathMemoryOf(*job.content), {.window_iterations = options_.test_window});
        OutingLocalisation run;
        LocaliseOuting(map, policy, Builder(true, options_.test_cores),
                       DepotStart(outings_[job.outing], map), frames_[job.outing], run);
        Advance(run.frames());
        const std::lock_guard lock(held_mutex);
        LifelongHeldOut& h = held[job.map];
        h.mean_nodes += static_cast<double>(job.content->nodes.size());
        h.frames += run.frames();
        h.not_localised += run.not_localised();
        h.beyond_10m += run.gaps_beyond(10.0);
      });
    }
    localise.Run(options_.threads);
    for (LifelongHeldOut& h : held) {
      h.mean_nodes /= static_cast<double>(std::max<std::size_t>(1, forays.size()));
    }
    return held;
  }

  const LifelongOptions& options_;
  WorkProgress progress_;
  World world_;
  std::vector<Outing> outings_;
  std::vector<std::vector<Frame>> frames_;
  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::unique_ptr<Repository> repository_;
  LifelongResult result_;
};

}  // namespace

LifelongResult RunLifelongExperiment(const LifelongOptions& options,
                                     const ProgressCallback& progress) {
  Validate(options);
  std::filesystem::create_directories(options.work_dir);
  return LifelongRun(options, progress).Run();
}

}  // namespace fleetmap
