// Held-out replay (seed 004 §VI-A, §VI-B): how well a map localises data it was not built
// from. A held-out robot map is turned back into the live frames that made it (its nodes'
// landmarks, grouped by outing, in stamp order, with the motion between consecutive nodes from
// the metric edge joining them) and replayed, localise-only, against a candidate map; each
// frame records the visual-odometry metres travelled since the last successful localisation
// (X of seed 004 §VI-B's P(X >= x)). Dreaming (§VI-E, dreaming.h) scores each candidate order
// this way.
//
// Every outing starts lost (seed 004 §III-B: the appearance index seeds it), so a map is
// judged on relocalising too. The replay uses Γ(distance) (distance_ranking.h), like MERGE.
#pragma once

#include <cstddef>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/ebn/frame.h"

namespace fleetmap {

// One outing of a held-out map as live frames.
struct HeldOutOuting {
  Uuid robot;
  Uuid outing;
  // One per node of the outing, by stamp (then id). prev_T_this is the pose of the frame in
  // the previous one's camera frame from the metric edge joining the two nodes (of several,
  // the lowest edge id), identity when none joins them and on the first frame.
  std::vector<Frame> frames;
};

// The outings of `map`, ordered by their first stamp (then outing id); nodes are grouped by
// Node::outing. Throws Error(kCorrupt) naming a node whose landmarks do not decode.
std::vector<HeldOutOuting> HeldOutOutings(const GraphBatch& map);

struct HeldOutReplay {
  std::size_t outings = 0;
  std::size_t frames = 0;
  std::size_t localised_frames = 0;  // frames with a successful localisation
  // Per frame, in replay order: FrameReport::distance_since_success_m, which for these frames
  // (they carry no ground truth) is visual-odometry metres since the last success (0 on one).
  std::vector<double> gaps_m;

  // P(X > x_m) over the frames; 0 for no frames.
  double ProbabilityGapExceeds(double x_m) const;
  // 1 − localised / frames; 0 for no frames.
  double FractionNotLocalised() const;
};

// Replays `outings` through a localise-only ExperienceBuilder on `map` (which it does not
// change; localise_only is forced on in `options`). Deterministic. Throws as ExperienceBuilder
// for options out of range.
HeldOutReplay ReplayHeldOut(const ExperienceMap& map, std::span<const HeldOutOuting> outings,
                            const BuilderOptions& options = {});

// Dreaming's score of a replay, lower better: P(X > gap_m) (seed 004 §VI-E judges maps by how
// far the held-out data travels unlocalised), ties broken by the fraction of frames not
// localised. Returned as one number, P + not_localised / (frames + 1): for replays of the same
// held-out outings (the same frame count) P moves in steps of 1 / frames, so the tie-break term
// never reorders different P. REQUIRES: gap_m >= 0.
double HeldOutScore(const HeldOutReplay& replay, double gap_m = 10.0);

}  // namespace fleetmap
