// Dreaming (seed 004 §VI-E): MERGE k groups of a fleet's maps into one map in many orders, score
// every resulting map by how well held-out data localises in it, and keep the best.
//
// The orders run as the prefix tree of PlanDreaming (dream_plan.h): a step merges one group
// into the map of its parent step, on a copy when a later sibling still needs the parent's
// map, so orders sharing a prefix share its merges (the intermediate results Eq. 8 counts on).
// A step with no parent merges its group into `base` (usually empty). Merges and copies are
// timed so Eq. 8 can be evaluated with this machine's figures.
//
// Memory: at most one map per level of the tree is alive at once (depth-first).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/appearance_index.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/map_management/held_out_replay.h"
#include "fleetmap/map_management/merge.h"

namespace fleetmap {

// A candidate map of one complete order: the mirror MERGE built, and everything it holds as
// content (the base plus every group's additions: nodes with landmarks, edges, paths).
struct DreamCandidate {
  std::size_t order_index = 0;  // into DreamPlan::orders
  const std::vector<int>* order = nullptr;
  const ExperienceMap* map = nullptr;
  const GraphBatch* content = nullptr;
};

// Scores a candidate map; lower is better (e.g. P(X >= 10 m) of held-out outings). Called once
// per order, from the calling thread.
using DreamScorer = std::function<double(const DreamCandidate& candidate)>;

struct DreamOptions {
  MergeOptions merge{};
  std::optional<std::size_t> max_orders;  // none: all k!
  std::uint64_t seed = 1;                 // for a sample of orders
};

struct DreamOrderResult {
  std::vector<int> order;
  double score = 0.0;
  std::size_t nodes = 0;  // in the order's map
};

struct DreamResult {
  DreamPlan plan;
  std::vector<DreamOrderResult> orders;     // as plan.orders
  std::size_t best = 0;                     // index of the lowest score (ties: the first)
  GraphBatch best_content;                  // the best order's map as content, ready to store
  std::vector<double> merge_seconds;        // one per merge into a parent's map (T_M samples)
  std::vector<double> first_merge_seconds;  // merges of a group into the base
  std::vector<double> copy_seconds;         // one per copy of a parent's map (T_C samples)
  double score_seconds = 0.0;
  double seconds = 0.0;  // the whole run
};

// The scorer seed 004 §VI-E judges candidates with: each candidate map replays `held_out`
// (ReplayHeldOut with `localiser`) and scores HeldOutScore(replay, gap_m). Each order's replay
// is kept in (*replays)[order_index] for reports. `held_out` and `replays` must outlive it.
DreamScorer HeldOutDreamScorer(std::span<const HeldOutOuting> held_out,
                               const BuilderOptions& localiser, double gap_m,
                               std::vector<HeldOutReplay>* replays);

// Called after each step with (steps done, steps in all).
using DreamProgress = std::function<void(std::size_t, std::size_t)>;

// Throws Error(kInvalidArgument) for fewer than 1 or more than kMaxDreamGroups (dream_plan.h)
// groups, a null vocabulary or scorer, and whatever Merge throws for a group's content (naming
// the group).
DreamResult Dream(std::span<const GraphBatch> groups, const GraphBatch& base,
                  std::shared_ptr<const AppearanceVocabulary> vocabulary, const DreamScorer& scorer,
                  const DreamOptions& options = {}, const DreamProgress& progress = {});

}  // namespace fleetmap
