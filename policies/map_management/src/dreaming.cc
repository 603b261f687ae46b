#include "fleetmap/map_management/dreaming.h"

#include <chrono>
#include <string>
#include <unordered_set>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

using Clock = std::chrono::steady_clock;

// One step's map: the mirror MERGE works on, and the same map as content.
struct DreamMap {
  ExperienceMap map;
  GraphBatch content;
  std::unordered_set<Uuid> edges, paths;  // ids in content, for MERGE's catalogue

  void Absorb(GraphBatch additions) {
    for (Edge& edge : additions.edges) {
      edges.insert(edge.id);
      content.edges.push_back(std::move(edge));
    }
    for (Path& path : additions.paths) {
      paths.insert(path.id);
      content.paths.push_back(std::move(path));
    }
    for (Node& node : additions.nodes) content.nodes.push_back(std::move(node));
  }
};

}  // namespace

DreamScorer HeldOutDreamScorer(std::span<const HeldOutOuting> held_out,
                               const BuilderOptions& localiser, double gap_m,
                               std::vector<HeldOutReplay>* replays) {
  return [held_out, localiser, gap_m, replays](const DreamCandidate& candidate) {
    HeldOutReplay replay = ReplayHeldOut(*candidate.map, held_out, localiser);
    const double score = HeldOutScore(replay, gap_m);
    if (replays->size() <= candidate.order_index) replays->resize(candidate.order_index + 1);
    (*replays)[candidate.order_index] = std::move(replay);
    return score;
  };
}

DreamResult Dream(std::span<const GraphBatch> groups, const GraphBatch& base,
                  std::shared_ptr<const AppearanceVocabulary> vocabulary, const DreamScorer& scorer,
                  const DreamOptions& options, const DreamProgress& progress) {
  const Clock::time_point start = Clock::now();
  if (!vocabulary) throw Error(ErrorCode::kInvalidArgument, "dreaming: no vocabulary");
  if (!scorer) throw Error(ErrorCode::kInvalidArgument, "dreaming: no scorer");
  DreamResult result;
  result.plan = PlanDreaming(static_cast<int>(groups.size()), options.max_orders, options.seed);
  const DreamPlan& plan = result.plan;

  DreamMap root{ExperienceMap::FromGraph(base.nodes, base.edges, vocabulary), base, {}, {}};
  for (const Edge& edge : base.edges) root.edges.insert(edge.id);
  for (const Path& path : base.paths) root.paths.insert(path.id);

  // A step's map lives until its last child has taken it over.
  std::vector<std::unique_ptr<DreamMap>> maps(plan.steps.size());
  std::vector<bool> has_children(plan.steps.size(), false);
  for (const DreamStep& step : plan.steps) {
    if (step.parent) has_children[*step.parent] = true;
  }
  double best_score = 0.0;
  std::size_t order_index = 0;
  for (std::size_t i = 0; i < plan.steps.size(); ++i) {
    const DreamStep& step = plan.steps[i];
    std::unique_ptr<DreamMap> map;
    if (!step.parent) {
      map = std::make_unique<DreamMap>(root);
    } else if (step.copies_parent) {
      const Clock::time_point copy_start = Clock::now();
      map = std::make_unique<DreamMap>(*maps[*step.parent]);
      result.copy_seconds.push_back(SecondsSince(copy_start));
    } else {
      map = std::move(maps[*step.parent]);  // the parent's last child
    }

    ServerCatalogue catalogue{[&map](const Uuid& id) { return map->edges.contains(id); },
                              [&map](const Uuid& id) { return map->paths.contains(id); },
                              {}};
    // Every group was accepted by the server, so an end this order's map lacks is one the
    // group found on the server or in another group: a robot built on what it pushed before,
    // and this order merges that group later (or the node was stood in for by a merge before
    // the base). The order goes on without the edge (edges_unresolved), as the server does
    // with a node seen only in a submission it could not merge.
    catalogue.seen_elsewhere = [](const Uuid&) { return true; };
    const Clock::time_point merge_start = Clock::now();
    MergeResult merged;
    try {
      merged =
          Merge(map->map, groups[static_cast<std::size_t>(step.group)], catalogue, options.merge);
    } catch (const Error& error) {
      throw Error(error.code(),
                  "dreaming: group " + std::to_string(step.group) + ": " + error.message());
    }
    (step.parent ? result.merge_seconds : result.first_merge_seconds)
        .push_back(SecondsSince(merge_start));
    map->Absorb(std::move(merged.additions));

    if (step.is_order) {
      const DreamCandidate candidate{order_index, &plan.orders[order_index], &map->map,
                                     &map->content};
      const Clock::time_point score_start = Clock::now();
      const double score = scorer(candidate);
      result.score_seconds += SecondsSince(score_start);
      result.orders.push_back({plan.orders[order_index], score, map->map.size()});
      if (order_index == 0 || score < best_score) {
        best_score = score;
        result.best = order_index;
        result.best_content = has_children[i] ? map->content : std::move(map->content);
      }
      ++order_index;
    }
    if (has_children[i]) maps[i] = std::move(map);
    if (progress) progress(i + 1, plan.steps.size());
  }
  result.seconds = SecondsSince(start);
  return result;
}

}  // namespace fleetmap
