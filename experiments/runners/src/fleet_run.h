// The fleet experiment's run (fleet_experiment.h: RunFleetExperiment): per fold, the
// single-agent map, the groups' maps and their merges (Fig. 7), two robots sharing (Fig. 8),
// the downloads of the merged map (Fig. 9) and dreaming (Fig. 10), as tasks on a queue, with
// the ground-truth diagnoses of why the maps localise as they do.
#pragma once

#include <Eigen/Core>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <utility>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/merge.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/runners/fleet_experiment.h"
#include "fleetmap/world/world.h"
#include "tracing_ranking.h"
#include "work_progress.h"

namespace fleetmap::fleet_internal {

using Clock = std::chrono::steady_clock;

// A map an EBN instance built, and what it cost.
struct BuiltMap {
  GraphBatch content;
  std::size_t nodes = 0;
  double cpu_seconds = 0.0;
  double wall_seconds = 0.0;
};

// One fold of the cross-validation: its outings and groups, and what its tasks leave for the
// merge diagnosis.
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

  // Every fold's tasks on options.threads threads, then the merge diagnoses.
  FleetExperimentResult Run();

 private:
  // ---- Running: the folds, builds and localisations (fleet_run.cc) ----

  void Prepare();

  std::int64_t Frames(const std::vector<std::size_t>& outings) const;

  BuilderOptions Builder(bool localise_only, int cores) const;

  // Single-agent EBN (Γ(distance)) over `outings` in order, from `start` (a downloaded map) or
  // from nothing, in its own SQLite store.
  BuiltMap Build(const std::string& name, const std::vector<std::size_t>& outings,
                 const GraphBatch* start = nullptr, int cost_fold = -1);

  // The held-out outings `outings` localised in `map` by the fleet's localiser.
  // With `traces`, what the localiser ranked and tried at each frame is appended to it.
  HeldOutRun Localise(const std::string& name, int fold, const ExperienceMap& map,
                      const PathMemory& memory, const std::vector<std::size_t>& outings,
                      std::vector<FrameTrace>* traces = nullptr);

  HeldOutRun LocaliseContent(const std::string& name, int fold, const GraphBatch& content,
                             const std::vector<std::size_t>& outings,
                             std::vector<FrameTrace>* traces = nullptr);

  std::string StorePath(const FoldState& fold, const std::string& name) const;

  void RecordBuild(FleetBuild build);

  void RecordRun(HeldOutRun run);

  // MERGE replays with the localiser the maps are built and used with.
  MergeOptions Merging() const;

  std::unique_ptr<Repository> OpenRepository(const FoldState& fold, const std::string& name);

  // Each group, and each robot of Fig. 8, pushes as a robot of its own.
  static Uuid GroupRobot(std::size_t group);

  static double ProbabilityGapExceeds(const HeldOutRun& run, double x_m);

  void Sort();

  void Advance(std::int64_t frames) { progress_.Advance(frames); }

  // ---- The maps of Figs. 7, 8 and 10 (fleet_builds.cc) ----

  // Fig. 7, the baseline: single-agent EBN over every training outing in time order.
  void SingleAgent(FoldState& fold);

  // Fig. 7, the merging strategy's EBN instances: one per group, independent.
  void BuildGroup(FoldState& fold, std::size_t g);

  // Fig. 8: two robots alone, and sharing through the server between their forays.
  void Sharing(FoldState& fold);

  // Fig. 10: the groups merged in every order, each candidate scored on the held-out outings.
  void Dreaming(FoldState& fold);

  // ---- The merges and Fig. 9's downloads (fleet_merge_downloads.cc) ----

  // Fig. 7, the merges, then Fig. 9's downloads of the merged map.
  void MergeAndDownload(FoldState& fold);

  // Fig. 7: each group's map pushed and merged in turn, each merge recorded as a build.
  void MergeGroups(FoldState& fold, Repository& repository);

  // With deterministic ids: what every merge of the fold kept, added and stood in, a line each
  // (FleetExperimentResult::merge_decisions).
  void RecordMergeDecisions(const FoldState& fold, Repository& repository,
                            const GraphBatch& merged);

  // The merged map's edge errors (and its links'), and its held-out run.
  void LocaliseMerged(FoldState& fold, const GraphBatch& merged);

  // Fig. 9: each held-out outing downloads by each policy for its own mission time, holding
  // the `depot` node it starts from, and is localised in what it got.
  void DownloadByEveryPolicy(const FoldState& fold, Repository& repository,
                             const GraphBatch& merged, const std::vector<Uuid>& depot);

  // What one outing's `download` by `policy` holds, against copy's `copy_nodes`.
  static FleetDownload DownloadRow(int fold, const std::string& name, const DownloadPolicy& policy,
                                   const Download& download, std::size_t copy_nodes,
                                   std::size_t map_paths);

  // The download policies' knobs swept, for the frontier an operator picks from; Fig. 9's own
  // settings are points too.
  std::vector<std::pair<std::string, DownloadPolicy>> FrontierPoints() const;

  void Frontier(const FoldState& fold, Repository& repository, const std::vector<Uuid>& depot,
                const GraphBatch& merged);

  // ---- Ground truth and the diagnoses (fleet_ground_truth.cc) ----

  // Where a node was captured, from its outing's ground truth (none for a node of no rendered
  // frame, which the experiment never makes).
  std::optional<Se3> TruePose(const Node& node) const;

  std::optional<Eigen::Vector3d> TruePlace(const Node& node) const;

  // FleetEdgeErrors of `map`'s metric edges between outings, less those in `skip`.
  void RecordEdgeErrors(int fold, const std::string& name, const GraphBatch& map,
                        const std::unordered_set<Uuid>& skip = {});

  // FleetLayoutError of `map`'s composed and relaxed layouts.
  void RecordLayoutErrors(int fold, const std::string& name, const GraphBatch& map);

  std::vector<Eigen::Vector3d> Places(const GraphBatch& map) const;

  // The held-out frames of `outing` in order, with their true places.
  std::vector<Eigen::Vector3d> FramePlaces(std::size_t outing) const;

  static bool AnyNear(const std::vector<Eigen::Vector3d>& places, const Eigen::Vector3d& at,
                      double radius_m);

  // Per held-out frame of `outing`: does the download hold a node near it, and where it lost
  // a frame copy localised, was the node copy localised in held, or where in time was it?
  void DiagnoseDownload(std::size_t outing, const GraphBatch& merged,
                        const std::unordered_map<Uuid, std::int64_t>& stamp_of,
                        const DownloadPolicy& policy, const GraphBatch& download,
                        const HeldOutRun& run, const HeldOutRun& copy, FleetDownload& row) const;

  // Fig. 7's why: per ground-truth stretch, what single-agent's and the merged map hold, and
  // where held-out frames fail in each.
  void DiagnoseMerge(const FoldState& fold);

  // FleetReach (fleet_experiment.h): the held-out `outings` as localised in
  // `map` (per frame: `localised`, `traces`) against a reference run's `reference_localised`.
  FleetReach Reach(const ExperienceMap& map, const std::vector<std::size_t>& outings,
                   const std::vector<char>& localised, const std::vector<FrameTrace>& traces,
                   const std::vector<char>& reference_localised) const;

  const FleetExperimentOptions& options_;
  WorkProgress progress_;
  World world_;
  std::vector<Outing> outings_;
  std::vector<std::vector<Frame>> frames_;
  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::shared_ptr<const AppearanceVocabulary> index_vocabulary_;  // every fold's repository's
  std::unordered_map<Uuid, std::size_t> outing_index_;            // outing id -> index in outings_
  std::vector<FoldState> folds_;

  std::mutex result_mutex_;
  FleetExperimentResult result_;
};

}  // namespace fleetmap::fleet_internal
