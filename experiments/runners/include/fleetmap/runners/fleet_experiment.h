// The fleet experiments of seed 004 §VI on the synthetic world, by 5-fold cross-validation over
// outings (§VI-A): four folds are training data, the fifth is held out and localised.
//
// Per fold:
// - Fig. 7, building good maps quickly: single-agent EBN over the training outings in time
//   order, against the merging strategy: each training fold is a group whose map an EBN
//   instance builds from scratch, and the groups are pushed to a Repository (SQLite) and
//   merged one after another into revisions. Build time is the CPU time of each task (robust
//   on a busy machine); the merging strategy's time is the critical path with the group EBN
//   instances in parallel (seed 004 Fig. 3b): the slowest group plus every merge.
// - Fig. 8, sharing expertise: the training outings are shared by two robots, alternately in
//   time; each drives two forays (the first and second half of its outings). Alone, each
//   robot builds its own map. Shared, both push after the first foray, each downloads the
//   merged map (copy) and drives its second foray on it, and both push again; the held-out
//   outings localise in the final server map and in each robot's lone map.
// - Fig. 9, mission-specific downloads: every held-out outing takes a download of the merged
//   map of Fig. 7 chosen for its own start time by copy, tod (T_w) and tod+paths (top p %),
//   and localises in it.
// - Fig. 10, dreaming: the four groups merged in all 24 orders (Dream, dreaming.h), every
//   candidate map scored by the held-out outings, timed beside Eq. 8.
//
// Localisation runs use one policy throughout (the fleet's localiser: by default Γ(path), seed
// 002, over the map's path memory) and measure P(X > x) per frame as the ranking experiment
// does (ranking_experiment.h).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/map_management/merge.h"
#include "fleetmap/map_management/stretch_coverage.h"
#include "fleetmap/runners/ranking_experiment.h"
#include "fleetmap/world/world_config.h"

namespace fleetmap {

struct FleetExperimentOptions {
  WorldConfig world{};
  int folds = 5;  // >= 3: a fold is held out, the others are the groups
  // Maps are built by single-agent EBN with Γ(distance) at Np = build_cores, one round.
  int build_cores = 4;
  // The localiser of every held-out run: "path" (Γ(path), window T) or "distance", at Np.
  std::string test_policy = "path";
  int test_cores = 4;
  int test_window = 20;
  BuilderOptions builder = RankingBuilderOptions();
  // MERGE's inclusion rule; its replay localises with `builder` at build_cores.
  MergeOptions merge = {};
  // Fig. 9: T_w and p of the tod and tod+paths downloads, Δt of the path matrices.
  double tod_window_min = 0.0;  // T_w; 0: each policy's default (ParseDownloadPolicy)
  double paths_percent = 50.0;
  double epoch_min = 60.0;
  // "tod+cover" and "tod+paths+cover": the coverage guarantee's stretches, k and cap.
  CoverageOptions coverage = {};
  // Ground-truth radius of the diagnoses: a held-out frame "has an experience" in a map when
  // one of its nodes was captured within this distance of the frame.
  double place_radius_m = 5.0;
  // Each DOWNLOAD policy again with its knobs swept (window, cover k, cap,
  // paths share), every held-out outing downloading and localising at each point.
  bool frontier = true;
  // Fig. 10 runs on this many folds (0 skips it), each in all k! orders of its groups.
  int dream_folds = 1;
  // Fig. 8, two robots sharing: off for a quicker look at MERGE and DOWNLOAD (a third of the
  // work), which nothing judged depends on.
  bool sharing = true;
  // Every task mints its ids from a sequence fixed by the world's seed and the task's name
  // (DeterministicUuids, fleetmap/core/uuid.h), so that two runs take the same decisions node for
  // node: to compare a change to MERGE or two arms by their kept nodes, not by chance.
  bool deterministic_ids = false;
  int threads = 2;                 // >= 1
  std::filesystem::path work_dir;  // stores go here (created; removed by the caller)
};

// Held-out frames localised in one map: ground-truth metres since the last success per frame.
struct HeldOutRun {
  std::string map;  // "single", "merged", "r1", "r2", "shared", "copy", "tod", ... "order ..."
  int fold = 0;
  std::size_t map_nodes = 0;  // nodes of the map localised in (Fig. 9: mean over outings)
  std::int64_t frames = 0;
  std::int64_t localised_frames = 0;
  std::vector<float> gaps_m;
  std::vector<char> localised;   // per frame, as gaps_m
  std::vector<Uuid> references;  // per frame: the node it localised in, nil when it did not
};

// One map built for Fig. 7, with its cost.
struct FleetBuild {
  // "single", "group 0", ..., "merge 0", ..., and "single self-merge": the single-agent map
  // merged into an empty one (nodes: what MERGE keeps of it).
  std::string map;
  int fold = 0;
  std::size_t nodes = 0;  // of the map after this step
  double cpu_seconds = 0.0;
  double wall_seconds = 0.0;
  // A merge's wall time in parts: the push (storing the submission), MERGE itself (the replay
  // and its decisions), and the rest of Repository::Merge (reading the submission, the head's
  // mirror, writing the revision).
  double push_seconds = 0.0;
  double merge_algorithm_seconds = 0.0;
  double merge_call_seconds = 0.0;
  // Of the rest of the call (MergeOutcome::Phases): the vocabularies and appearance index
  // brought up to date, the region loaded, the revision written.
  double merge_index_seconds = 0.0;
  double merge_region_seconds = 0.0;
  double merge_write_seconds = 0.0;
  // A merge's links to the server map: made, of those registered by the frame's own
  // registration, and dropped as inconsistent with their neighbours (MergeReport).
  std::size_t links = 0, links_registered = 0, links_inconsistent = 0;
};

// Could the localiser have reached the experience it needed? Each held-out frame a
// map lost where a reference map localised it (merged vs single-agent's, a download vs copy),
// by the map's nodes captured within place_radius_m of it (ground truth) and which of them
// localise it when tried one by one (an oracle the robot lacks).
struct FleetReach {
  std::int64_t lost = 0;            // frames lost here, localised in the reference map
  std::int64_t no_node_near = 0;    // none near
  std::int64_t none_localises = 0;  // near ones, none localises: no experience for it
  std::int64_t not_candidate = 0;   // one localises, none was among the candidates Y
  // ... of those: no candidate at all (lost: the appearance search was its only chance); the
  // right node not reached by the search from n_k (breadth-first to search_radius_m); reached,
  // but placed beyond candidate_radius_m of the position estimate; and n_k itself captured
  // beyond 2 place_radius_m of the frame (the estimate was elsewhere)
  std::int64_t not_candidate_lost = 0;
  std::int64_t not_candidate_unreached = 0;
  std::int64_t not_candidate_placed_far = 0;
  std::int64_t not_candidate_reference_far = 0;
  std::int64_t not_tried = 0;  // a candidate, ranked below the Np tried
  std::int64_t tried = 0;      // tried and failed anyway (never, with a deterministic localiser)

  FleetReach& operator+=(const FleetReach& other);
};

// Fig. 9: one held-out outing's download.
struct FleetDownload {
  int fold = 0;
  std::string policy;
  double mission_start_min = 0.0;
  std::size_t nodes = 0;
  std::size_t copy_nodes = 0;  // the whole map, for the ratio
  std::int64_t bytes = 0;
  std::size_t bridging_nodes = 0;
  std::size_t components_before = 0, components_after = 0;
  std::size_t picked_nodes = 0;  // before bridging
  std::size_t paths_chosen = 0;  // "paths": |P*|, the best paths over the mission's epochs
  std::size_t map_paths = 0;     // paths recorded in the map
  // Nodes on the chosen paths, and those of them the earlier parts allowed (tod+paths: inside
  // the window).
  std::size_t nodes_on_chosen_paths = 0;
  std::size_t stretches = 0, stretches_reached_outside = 0;  // "cover"
  // Why it localised worse than copy, per held-out frame (ground truth, place_radius_m):
  std::int64_t frames = 0;
  std::int64_t frames_with_node_near = 0;      // the mission's route the download covers
  std::int64_t lost_vs_copy = 0;               // copy localised the frame, this download did not
  std::int64_t lost_vs_copy_no_node_near = 0;  // ... and held no node near it
  // Of the frames lost where copy localised, by the node copy localised in: held by this
  // download too (lost by the localiser's search, not the selection); not held, but captured
  // or used within the window; not held, and neither (so only outside the window); the mean
  // clock distance in hours between those last nodes' capture and the mission's start.
  std::int64_t lost_copy_node_held = 0;
  std::int64_t lost_copy_node_in_window = 0;
  std::int64_t lost_copy_node_outside_window = 0;
  double lost_copy_node_hours_away = 0.0;
  std::size_t derived_edges = 0;  // path memory and metric edges contracted over nodes left out
  FleetReach reach;               // of the frames lost where copy localised
};

// One policy at one setting of its knobs, on one fold: every held-out outing
// downloaded for its own start time and localised in it. Fig. 9's own policies are points too.
struct FleetFrontierPoint {
  std::string label;   // the policy and its settings, e.g. "tod+cover k=1 cap=2"
  std::string policy;  // download_policy.h name
  int fold = 0;
  std::size_t downloads = 0;
  double node_share_sum = 0.0;  // Σ over downloads of nodes / copy's nodes
  std::int64_t bytes = 0, copy_bytes = 0;
  std::int64_t frames = 0;
  std::int64_t beyond_10m = 0;  // frames with X > 10 m
  std::int64_t not_localised = 0;
};

// Why a merged map holds what it holds, against single-agent EBN's (seed 004 Fig. 7), per
// route stretch: ground-truth cubes of the coverage's stretch_m, fold by fold.
struct FleetMergeDiagnosis {
  int fold = 0;
  std::size_t stretches = 0;                 // holding a node of either map
  std::size_t stretches_more = 0;            // merged holds more nodes than single-agent there
  std::size_t nodes_more = 0;                // the excess, summed
  std::size_t stretches_fewer = 0;           // merged holds fewer
  std::size_t nodes_fewer = 0;               // the shortfall, summed
  std::int64_t frames = 0;                   // held-out frames
  std::int64_t single_lost = 0;              // not localised in single-agent's map
  std::int64_t merged_lost = 0;              // not localised in the merged map
  std::int64_t merged_lost_where_fewer = 0;  // of those, in stretches where merged holds fewer
  std::int64_t merged_only_lost = 0;         // lost in merged, localised in single-agent's
  std::int64_t merged_only_lost_where_fewer = 0;
  FleetReach reach;  // of the frames lost only in the merged map
};

// EBN's cost per frame against the size of the map it localises in: one row per outing of the
// single-agent builds (where the paper's time saving must come from, seed 004 §VI-B).
struct FleetFrameCost {
  int fold = 0;
  std::size_t map_nodes = 0;  // when the outing started
  std::int64_t frames = 0;
  double cpu_seconds = 0.0;  // of the whole outing
};

// How well a map's metric edges between outings agree with the world: per edge joining nodes
// of two outings, the distance in metres between the translation it carries and the true one
// (the `to` camera in the `from` camera's frame, from the frames' ground truth). Within an
// outing an edge is visual odometry; between outings it is where one experience was placed
// against another, which is what the localiser's search composes across.
struct FleetEdgeErrors {
  int fold = 0;
  // "single": single-agent's map; "groups": each group's map before MERGE; "merged": the merged
  // map (its groups' own edges between outings and MERGE's); "merge links": only the edges
  // MERGE wrote.
  std::string map;
  std::vector<float> errors_m;
  // Per edge, as errors_m: the standard deviation of its position that its covariance claims
  // (pose_covariance.h PositionSigma), or NaN when it carries none.
  std::vector<float> sigmas_m;
};

// How far a layout of a map (fleetmap/relaxation/relaxed_layout.h) puts its nodes from where
// they were captured: the largest metric component's nodes, their layout positions aligned to
// the true ones by the rigid motion that fits best (Umeyama, no scale).
struct FleetLayoutError {
  int fold = 0;
  std::string map;     // "single" or "merged"
  std::string layout;  // "composed" or "relaxed"
  std::size_t nodes = 0;
  double ate_rmse_m = 0.0;  // root mean square of the aligned position errors
  double max_m = 0.0;       // the largest of them
  double seconds = 0.0;     // laying the map out
};

// Fig. 10: one order of one fold.
struct FleetDreamOrder {
  int fold = 0;
  std::vector<int> order;
  double score = 0.0;  // P(X > 10 m) of the held-out outings
  std::size_t nodes = 0;
};

struct FleetDreamTiming {
  int fold = 0;
  int groups = 0;
  double group_seconds = 0.0;  // T_G: mean CPU seconds of a group's EBN build
  double merge_seconds = 0.0;  // T_M: mean seconds of one merge into a parent's map
  double copy_seconds = 0.0;   // T_C: mean seconds of one copy of a map
  std::size_t merges = 0, copies = 0, orders = 0;
  double dream_seconds = 0.0;    // measured: k T_G plus every merge and copy of the run
  double predicted_ratio = 0.0;  // Eq. 8 with T_G, T_M, T_C
  double measured_ratio = 0.0;   // dream_seconds over Eq. 8's single-agent denominator
  std::size_t best = 0;          // index of the best order
};

struct FleetExperimentResult {
  std::vector<FleetBuild> builds;
  std::vector<HeldOutRun> runs;
  std::vector<FleetDownload> downloads;
  std::vector<FleetDreamOrder> dream_orders;
  std::vector<FleetDreamTiming> dream_timings;
  std::vector<FleetMergeDiagnosis> merge_diagnoses;
  std::vector<FleetFrameCost> frame_costs;
  std::vector<FleetFrontierPoint> frontier;  // empty unless options.frontier
  std::vector<FleetEdgeErrors> edge_errors;
  std::vector<FleetLayoutError> layout_errors;
  // With options.deterministic_ids: every merge's decisions, a line each, sorted: the nodes each
  // revision kept, the edges it added (ends and pose in hex floats) and the stand-ins of the
  // nodes it omitted. Two runs decide alike exactly when these are equal.
  std::vector<std::string> merge_decisions;
  int outings = 0;
  std::int64_t frames_rendered = 0;
  double seconds = 0.0;
};

// Throws Error(kInvalidArgument) for options out of range.
FleetExperimentResult RunFleetExperiment(const FleetExperimentOptions& options,
                                         const ProgressCallback& progress = {});

}  // namespace fleetmap
