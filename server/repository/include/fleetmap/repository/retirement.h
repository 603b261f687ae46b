// Retirement: a map that forgets what the world forgot. Churchill and Newman's experiences are
// added where a place no longer localises (seed 004 §V-A's MERGE keeps only what does not);
// nothing ever took one away, so on a world that keeps changing the map grows with every day.
// A retirement is a revision (RevisionKind::kRetire) that hides the experiences nobody has
// localised against for a stated time, where the place holds others; a revert restores them.
//
// What it never hides (docs/retirement.md):
// - a node localised against within `retire_after` of the map's clock (VersionStore::UsageAt,
//   recorded by every MERGE: its replay, and the steps of the robot's path memory), or newer
//   than that itself;
// - the last experience of a place: a node is retired only when another experience (a node of
//   another outing) that stays lies within `place_radius_m` of it, with poses composed along
//   visible metric edges;
// - a node whose going would cut the map the rest keeps apart: nodes it joins must stay joined
//   through what stays (so no later revision's edges are left hanging off the map);
// - a node a robot's unmerged submission names (an end of its edges, a node it carries): that
//   robot built on it and its push is still to merge;
// - anything on a channel behind the head: a retirement is a new revision, and older ones keep
//   what they held.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

inline constexpr std::int64_t kNanosecondsPerDay = 86'400'000'000'000;

struct RetireOptions {
  // Unused for this long (by the map's clock) makes a node a candidate.
  std::int64_t retire_after_ns = 14 * kNanosecondsPerDay;
  // The map's clock. nullopt: the newest stamp the map has seen, of a node at the head or of
  // a frame a replay localised: time moves with the fleet's driving, so a depot whose robots
  // stay docked for a month retires nothing.
  std::optional<std::int64_t> now_ns;
  double place_radius_m = 8.0;  // another experience this close holds the place
  // How far along metric edges another experience of a node's place is looked for: MERGE links
  // a new experience to the old at the ends of the stretch it added, so the way from one to
  // the other runs to the nearer end and back.
  double search_radius_m = 250.0;
  // Nodes searched around a node for another experience of its place: bounds a node's cost (a
  // node with none within it stays).
  std::size_t search_nodes = 2000;
};

struct RetiredNode {
  Uuid node;
  std::int64_t last_used_ns = 0;  // newest use, or the node's own stamp when never used
  std::int64_t frames = 0;        // frames that ever localised against it
  Uuid held_by;                   // an experience of its place that stays
  double held_by_m = 0.0;         // how far that is
};

struct RetirementPlan {
  RevisionNumber head = 0;
  std::int64_t now_ns = 0;
  std::int64_t cutoff_ns = 0;  // nodes last used before this are candidates
  std::size_t visible_nodes = 0;
  std::size_t candidates = 0;            // unused since cutoff_ns
  std::size_t kept_last_of_place = 0;    // candidates kept: no other experience stays near
  std::size_t kept_joins_map = 0;        // candidates kept: their going would cut the map
  std::size_t kept_for_submissions = 0;  // candidates kept: an unmerged submission names them
  std::vector<RetiredNode> retire;       // by last use, oldest first
};

// What a plan is decided on, held in memory (Repository::PlanRetirement reads it from the
// store): kept apart from the store so that the rules can be checked on any graph.
struct RetirementInput {
  RevisionNumber head = 0;
  std::vector<Node> nodes;                    // visible at the head (landmarks not needed)
  std::vector<Edge> edges;                    // visible at the head; only metric ones are used
  std::unordered_map<Uuid, NodeUsage> usage;  // by node: frames and newest use
  std::unordered_set<Uuid> named_by_submissions;
};

// The plan on `input`. Throws Error(kInvalidArgument) for options out of range: a
// retire_after_ns, place_radius_m or search_radius_m that is not positive, or search_nodes < 2.
RetirementPlan PlanRetirementOf(const RetirementInput& input, const RetireOptions& options);

// The plan as JSON (a kRetire revision's report; `fleetmap retire --json`).
std::string RetirementPlanJson(const RetirementPlan& plan);

}  // namespace fleetmap
