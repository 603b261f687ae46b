#include "fleetmap/runners/fleet_experiment.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <mutex>
#include <numeric>
#include <optional>
#include <tuple>
#include <unordered_map>
#include <unordered_set>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/ebn/localiser.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/dreaming.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_ranking.h"
#include "fleetmap/ranking/time_of_day.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/world/world.h"
#include "fleetmap/world/world_runs.h"
#include "outing_runs.h"
#include "task_queue.h"
#include "work_progress.h"

namespace fleetmap {
namespace {

using Clock = std::chrono::steady_clock;

void Validate(const FleetExperimentOptions& o) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "fleet experiment: " + what);
  };
  if (o.folds < 3) fail("folds must be >= 3 (one held out, at least two groups)");
  if (o.build_cores < 1) fail("build_cores must be >= 1");
  if (o.test_policy != "path" && o.test_policy != "distance") {
    fail("test_policy must be path or distance, not " + o.test_policy);
  }
  if (o.test_cores < 1) fail("test_cores must be >= 1");
  if (o.test_window < 0) fail("test_window must be >= 0");
  if (!(o.tod_window_min >= 0.0)) fail("tod_window_min must be >= 0 (0: each policy's own)");
  if (!(o.paths_percent > 0.0 && o.paths_percent <= 100.0)) fail("paths_percent in (0, 100]");
  if (!(o.epoch_min > 0.0 && o.epoch_min <= 1440.0)) fail("epoch_min in (0, 1440]");
  if (o.dream_folds < 0 || o.dream_folds > o.folds) fail("dream_folds in [0, folds]");
  if (o.folds - 1 > kMaxDreamGroups) {
    fail("at most " + std::to_string(kMaxDreamGroups) +
         " groups can be dreamt (folds <= " + std::to_string(kMaxDreamGroups + 1) + ")");
  }
  if (o.threads < 1) fail("threads must be >= 1");
  if (o.work_dir.empty()) fail("work_dir must be set");
}

// What the localiser did with one held-out frame: the candidates Γ ranked, best first, and the
// nodes it tried (relocalisation's included), for the merge diagnosis.
struct FrameTrace {
  Uuid reference;  // n_k when it ranked (nil: no candidates, nothing ranked)
  std::vector<Uuid> ranked;
  std::vector<Uuid> tried;
};

// The fleet's ranking policy, unchanged, keeping a FrameTrace per localiser iteration (the
// builder runs exactly one per frame, ranking at most once before it).
class TracingRanking final : public RankingPolicy {
 public:
  TracingRanking(RankingPolicy& inner, std::vector<FrameTrace>& traces)
      : inner_(inner), traces_(traces) {}
  std::string name() const override { return inner_.name(); }
  void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override {
    inner_.Rank(reference, candidates);
    reference_ = reference;
    ranked_.clear();
    for (const Candidate& candidate : candidates) ranked_.push_back(candidate.node);
  }
  void ObserveIteration(std::span<const LocalisationAttempt> attempts) override {
    inner_.ObserveIteration(attempts);
    FrameTrace& trace = traces_.emplace_back();
    trace.reference = reference_;
    trace.ranked = std::move(ranked_);
    ranked_.clear();
    reference_ = Uuid();
    for (const LocalisationAttempt& attempt : attempts) trace.tried.push_back(attempt.node);
  }
  void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) override {
    inner_.ObservePathEdge(path, from, to);
  }
  void StartOuting() override { inner_.StartOuting(); }

 private:
  RankingPolicy& inner_;
  std::vector<FrameTrace>& traces_;
  Uuid reference_;
  std::vector<Uuid> ranked_;
};

// A map an EBN instance built, and what it cost.
struct BuiltMap {
  GraphBatch content;
  std::size_t nodes = 0;
  double cpu_seconds = 0.0;
  double wall_seconds = 0.0;
};

struct FoldState {
  int number = 0;
  std::vector<std::size_t> test;                 // outing indexes, in time order
  std::vector<std::size_t> training;             // likewise
  std::vector<std::vector<std::size_t>> groups;  // the training folds, each in time order
  std::vector<BuiltMap> group_maps;
  std::atomic<int> groups_left{0};
  // For the merge diagnosis once every task is done: where each map's nodes were captured
  // (ground truth) and which held-out frames each localised.
  std::vector<Eigen::Vector3d> single_places, merged_places;
  std::vector<char> single_localised, merged_localised;
  // The merged map and what its localiser did per held-out frame (the reach diagnosis).
  std::shared_ptr<const ExperienceMap> merged_map;
  std::vector<FrameTrace> merged_traces;
};

class FleetRun {
 public:
  FleetRun(const FleetExperimentOptions& options, const ProgressCallback& progress)
      : options_(options), progress_(progress), world_(options.world) {}

  FleetExperimentResult Run() {
    const Clock::time_point start = Clock::now();
    Prepare();
    TaskQueue queue;
    for (FoldState& fold : folds_) {
      queue.Push([this, &fold] { SingleAgent(fold); });
      for (std::size_t g = 0; g < fold.groups.size(); ++g) {
        queue.Push([this, &fold, g, &queue] {
          BuildGroup(fold, g);
          if (--fold.groups_left == 0) {
            queue.Push([this, &fold] { MergeAndDownload(fold); });
            if (fold.number < options_.dream_folds) queue.Push([this, &fold] { Dreaming(fold); });
          }
        });
      }
      if (options_.sharing) queue.Push([this, &fold] { Sharing(fold); });
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

 private:
  void Prepare() {
    outings_ = ScheduleOutings(options_.world);
    vocabulary_ = TrainWorldVocabulary(world_);
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

  std::int64_t Frames(const std::vector<std::size_t>& outings) const {
    std::int64_t n = 0;
    for (std::size_t i : outings) n += static_cast<std::int64_t>(frames_[i].size());
    return n;
  }

  void Advance(std::int64_t frames) { progress_.Advance(frames); }

  BuilderOptions Builder(bool localise_only, int cores) const {
    BuilderOptions builder = options_.builder;
    builder.cores = cores;
    builder.rounds = 1;
    builder.localise_only = localise_only;
    return builder;
  }

  // Single-agent EBN (Γ(distance)) over `outings` in order, from `start` (a downloaded map) or
  // from nothing, in its own SQLite store.
  BuiltMap Build(const std::string& name, const std::vector<std::size_t>& outings,
                 const GraphBatch* start = nullptr, int cost_fold = -1) {
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

  // The held-out outings `outings` localised in `map` by the fleet's localiser.
  // With `traces`, what the localiser ranked and tried at each frame is appended to it.
  HeldOutRun Localise(const std::string& name, int fold, const ExperienceMap& map,
                      const PathMemory& memory, const std::vector<std::size_t>& outings,
                      std::vector<FrameTrace>* traces = nullptr) {
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

  HeldOutRun LocaliseContent(const std::string& name, int fold, const GraphBatch& content,
                             const std::vector<std::size_t>& outings,
                             std::vector<FrameTrace>* traces = nullptr) {
    const ExperienceMap map = ExperienceMap::FromGraph(content.nodes, content.edges, vocabulary_);
    return Localise(name, fold, map, PathMemoryOf(content), outings, traces);
  }

  // A TracingRanking that owns the policy it wraps.
  class OwningTracer final : public RankingPolicy {
   public:
    OwningTracer(std::unique_ptr<RankingPolicy> inner, std::vector<FrameTrace>& traces)
        : inner_(std::move(inner)), tracer_(*inner_, traces) {}
    std::string name() const override { return tracer_.name(); }
    void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override {
      tracer_.Rank(reference, candidates);
    }
    void ObserveIteration(std::span<const LocalisationAttempt> attempts) override {
      tracer_.ObserveIteration(attempts);
    }
    void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) override {
      tracer_.ObservePathEdge(path, from, to);
    }
    void StartOuting() override { tracer_.StartOuting(); }

   private:
    std::unique_ptr<RankingPolicy> inner_;
    TracingRanking tracer_;
  };

  std::string StorePath(const FoldState& fold, const std::string& name) const {
    return "fold-" + std::to_string(fold.number) + "-" + name;
  }

  void RecordBuild(FleetBuild build) {
    const std::lock_guard lock(result_mutex_);
    result_.builds.push_back(std::move(build));
  }
  void RecordRun(HeldOutRun run) {
    const std::lock_guard lock(result_mutex_);
    result_.runs.push_back(std::move(run));
  }

  // Fig. 7, the baseline: single-agent EBN over every training outing in time order.
  void SingleAgent(FoldState& fold) {
    BuiltMap single = Build(StorePath(fold, "single"), fold.training, nullptr, fold.number);
    RecordBuild({"single", fold.number, single.nodes, single.cpu_seconds, single.wall_seconds});
    HeldOutRun run = LocaliseContent("single", fold.number, single.content, fold.test);
    fold.single_places = Places(single.content);
    RecordEdgeErrors(fold.number, "single", single.content);
    fold.single_localised = run.localised;
    RecordRun(std::move(run));
    // How much of it MERGE finds redundant: merged into an empty map, what does it keep? This
    // bounds how far below single-agent EBN's size a merged map can go on this world.
    const Clock::time_point wall = Clock::now();
    const double cpu = ThreadCpuSeconds();
    ExperienceMap empty(vocabulary_);
    const MergeResult self = Merge(
        empty, single.content,
        {[](const Uuid&) { return false; }, [](const Uuid&) { return false; }, {}}, Merging());
    RecordBuild({"single self-merge", fold.number, self.report.nodes_added,
                 ThreadCpuSeconds() - cpu, SecondsSince(wall)});
  }

  // Fig. 7, the merging strategy's EBN instances: one per group, independent.
  void BuildGroup(FoldState& fold, std::size_t g) {
    BuiltMap built = Build(StorePath(fold, "group-" + std::to_string(g)), fold.groups[g]);
    RecordBuild({"group " + std::to_string(g), fold.number, built.nodes, built.cpu_seconds,
                 built.wall_seconds});
    RecordEdgeErrors(fold.number, "groups", built.content);
    fold.group_maps[g] = std::move(built);
  }

  // MERGE replays with the localiser the maps are built and used with.
  MergeOptions Merging() const {
    MergeOptions merge = options_.merge;
    merge.localiser = Builder(true, options_.build_cores);
    return merge;
  }

  std::unique_ptr<Repository> OpenRepository(const FoldState& fold, const std::string& name) {
    RepositoryOptions repository;
    repository.merge = Merging();
    repository.vocabulary = vocabulary_;
    return std::make_unique<Repository>(
        GraphStore::Open("sqlite:" + (options_.work_dir / (StorePath(fold, name) + ".db")).string(),
                         {.durability = Durability::kBuffered}),
        repository);
  }

  // Fig. 7, the merges, then Fig. 9's downloads of the merged map.
  void MergeAndDownload(FoldState& fold) {
    std::unique_ptr<Repository> repository = OpenRepository(fold, "server");
    for (std::size_t g = 0; g < fold.group_maps.size(); ++g) {
      const Clock::time_point wall = Clock::now();
      const double cpu = ThreadCpuSeconds();
      const Uuid submission = Uuid::Generate();
      repository->Push(submission, GroupRobot(g), "group " + std::to_string(g),
                       fold.group_maps[g].content);
      const double pushed = SecondsSince(wall);
      const MergeOutcome outcome = repository->Merge(submission);
      const std::int64_t nodes = repository->versions().StatsAt(repository->Head()).nodes;
      FleetBuild build{"merge " + std::to_string(g), fold.number, static_cast<std::size_t>(nodes),
                       ThreadCpuSeconds() - cpu, SecondsSince(wall)};
      build.push_seconds = pushed;
      build.merge_algorithm_seconds = outcome.report.seconds;
      build.links = outcome.report.links_added;
      build.links_registered = outcome.report.links_registered;
      build.links_inconsistent = outcome.report.links_inconsistent;
      build.merge_call_seconds = outcome.seconds;
      RecordBuild(build);
    }
    const GraphBatch merged = repository->Checkout();
    RecordEdgeErrors(fold.number, "merged", merged);
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

    // Fig. 9: each held-out outing downloads for its own mission time, holding the depot node
    // it starts from (the merged map's earliest, see DepotStart).
    const std::size_t copy_nodes = merged.nodes.size();
    std::vector<Uuid> depot;
    if (!merged.nodes.empty()) {
      depot.push_back(std::min_element(merged.nodes.begin(), merged.nodes.end(),
                                       [](const Node& a, const Node& b) {
                                         return std::pair(a.stamp_ns, a.id) <
                                                std::pair(b.stamp_ns, b.id);
                                       })
                          ->id);
    }
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
        const Download download = repository->SelectForDownload(policy);
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
        FleetDownload row;
        row.fold = fold.number;
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
        row.map_paths = merged.paths.size();
        row.derived_edges = download.report.derived_edges;
        DiagnoseDownload(index, merged, stamp_of, policy, download.map, one, copy_runs[index], row);
        row.reach = Reach(map, {index}, one.localised, traces, copy_runs[index].localised);
        const std::lock_guard lock(result_mutex_);
        result_.downloads.push_back(row);
      }
      run.map_nodes = node_sum / std::max<std::size_t>(1, fold.test.size());
      RecordRun(std::move(run));
    }
    if (options_.frontier) Frontier(fold, *repository, depot, merged);
  }

  // Issue 34 item 4: the download policies' knobs swept; Fig. 9's own settings are points too.
  std::vector<std::pair<std::string, DownloadPolicy>> FrontierPoints() const {
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

  void Frontier(const FoldState& fold, Repository& repository, const std::vector<Uuid>& depot,
                const GraphBatch& merged) {
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

  // Where a node was captured, from its outing's ground truth (none for a node of no rendered
  // frame, which the experiment never makes).
  std::optional<Se3> TruePose(const Node& node) const {
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

  std::optional<Eigen::Vector3d> TruePlace(const Node& node) const {
    const std::optional<Se3> pose = TruePose(node);
    if (!pose) return std::nullopt;
    return pose->translation();
  }

  // FleetEdgeErrors of `map`'s metric edges between outings, less those in `skip`.
  void RecordEdgeErrors(int fold, const std::string& name, const GraphBatch& map,
                        const std::unordered_set<Uuid>& skip = {}) {
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

  std::vector<Eigen::Vector3d> Places(const GraphBatch& map) const {
    std::vector<Eigen::Vector3d> places;
    for (const Node& node : map.nodes) {
      if (const auto place = TruePlace(node)) places.push_back(*place);
    }
    return places;
  }

  // The held-out frames of `outing` in order, with their true places.
  std::vector<Eigen::Vector3d> FramePlaces(std::size_t outing) const {
    std::vector<Eigen::Vector3d> places;
    for (const Frame& frame : frames_[outing]) {
      places.push_back(frame.world_T_camera_truth
                           ? Eigen::Vector3d(frame.world_T_camera_truth->translation())
                           : Eigen::Vector3d::Constant(1e9));
    }
    return places;
  }

  static bool AnyNear(const std::vector<Eigen::Vector3d>& places, const Eigen::Vector3d& at,
                      double radius_m) {
    for (const Eigen::Vector3d& p : places) {
      if ((p - at).squaredNorm() <= radius_m * radius_m) return true;
    }
    return false;
  }

  // Per held-out frame of `outing`: does the download hold a node near it, and where it lost
  // a frame copy localised, was the node copy localised in held, or where in time was it?
  void DiagnoseDownload(std::size_t outing, const GraphBatch& merged,
                        const std::unordered_map<Uuid, std::int64_t>& stamp_of,
                        const DownloadPolicy& policy, const GraphBatch& download,
                        const HeldOutRun& run, const HeldOutRun& copy, FleetDownload& row) const {
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
      } else if (WithinTimeOfDayWindow(stamp->second, policy.mission_start_min,
                                       policy.window_min) ||
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

  // Fig. 7's why: per ground-truth stretch, what single-agent's and the merged map hold, and
  // where held-out frames fail in each.
  void DiagnoseMerge(const FoldState& fold) {
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
        const bool single_ok = fold.single_localised[frame],
                   merged_ok = fold.merged_localised[frame];
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

  // Issue 34 item 2 (fleet_experiment.h FleetReach): the held-out `outings` as localised in
  // `map` (per frame: `localised`, `traces`) against a reference run's `reference_localised`.
  FleetReach Reach(const ExperienceMap& map, const std::vector<std::size_t>& outings,
                   const std::vector<char>& localised, const std::vector<FrameTrace>& traces,
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

  // Fig. 8: two robots alone, and sharing through the server between their forays.
  void Sharing(FoldState& fold) {
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
      push(r,
           Build(StorePath(fold, "r" + std::to_string(r + 1) + "-foray-1"), forays[r][0]).content);
    }
    const GraphBatch copy = server->Checkout();  // both robots download the whole map
    for (int r = 0; r < 2; ++r) {
      push(r, Build(StorePath(fold, "r" + std::to_string(r + 1) + "-foray-2"), forays[r][1], &copy)
                  .content);
    }
    RecordRun(LocaliseContent("shared", fold.number, server->Checkout(), fold.test));
  }

  // Fig. 10: the groups merged in every order, each candidate scored on the held-out outings.
  void Dreaming(FoldState& fold) {
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

  // Each group, and each robot of Fig. 8, pushes as a robot of its own.
  static Uuid GroupRobot(std::size_t group) {
    Uuid::Bytes bytes{};
    bytes[0] = 0xF1;
    bytes[6] = 0x40;
    bytes[8] = 0x80;
    bytes[15] = static_cast<std::uint8_t>(group + 1);
    return Uuid(bytes);
  }

  static double ProbabilityGapExceeds(const HeldOutRun& run, double x_m) {
    std::int64_t beyond = 0;
    for (float gap : run.gaps_m) beyond += gap > x_m ? 1 : 0;
    return run.gaps_m.empty()
               ? 0.0
               : static_cast<double>(beyond) / static_cast<double>(run.gaps_m.size());
  }

  void Sort() {
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
  }

  const FleetExperimentOptions& options_;
  WorkProgress progress_;
  World world_;
  std::vector<Outing> outings_;
  std::vector<std::vector<Frame>> frames_;
  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::unordered_map<Uuid, std::size_t> outing_index_;  // outing id -> index in outings_
  std::vector<FoldState> folds_;

  std::mutex result_mutex_;
  FleetExperimentResult result_;
};

}  // namespace

FleetReach& FleetReach::operator+=(const FleetReach& other) {
  lost += other.lost;
  no_node_near += other.no_node_near;
  none_localises += other.none_localises;
  not_candidate += other.not_candidate;
  not_candidate_lost += other.not_candidate_lost;
  not_candidate_unreached += other.not_candidate_unreached;
  not_candidate_placed_far += other.not_candidate_placed_far;
  not_candidate_reference_far += other.not_candidate_reference_far;
  not_tried += other.not_tried;
  tried += other.tried;
  return *this;
}

FleetExperimentResult RunFleetExperiment(const FleetExperimentOptions& options,
                                         const ProgressCallback& progress) {
  Validate(options);
  std::filesystem::create_directories(options.work_dir);
  return FleetRun(options, progress).Run();
}

}  // namespace fleetmap
