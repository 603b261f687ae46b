// A robot's corridor foray (corridor_scene.h) on a given day, its condition changing along the
// way: for tests of what time does to a map (retirement), where every outing of the plain
// corridor would carry the same stamps. Built by the EBN builder from scratch, as the robot
// would keep and push it.
#pragma once

#include <cstdint>
#include <vector>

#include "corridor_scene.h"
#include "day_stamps.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/store/graph_store.h"
#include "scratch_dir.h"

namespace fleetmap {

// A stretch of the foray: from `from_m` (to the next stretch's start, or the corridor's end)
// in condition 0 (day) or 1 (night).
struct CorridorStretch {
  double from_m = 0.0;
  int condition = 0;
};

// The frames of one foray from the first stretch's start to the corridor's end, a metre apart,
// each in its stretch's condition, stamped `days_later` days after day_stamps.h's day at 09:00
// UTC plus the corridor's own second per metre. REQUIRES: stretches ascending by from_m.
inline std::vector<Frame> DatedCorridorFrames(const std::vector<CorridorStretch>& stretches,
                                              int days_later) {
  const double start_m = stretches.front().from_m;
  std::vector<std::vector<Frame>> by_condition;
  for (int condition : {0, 1}) by_condition.push_back(SharedCorridor().Outing(condition, start_m));
  std::vector<Frame> frames;
  std::size_t stretch = 0;
  for (std::size_t i = 0; i < by_condition[0].size(); ++i) {
    const double z = start_m + static_cast<double>(i);
    while (stretch + 1 < stretches.size() && z >= stretches[stretch + 1].from_m) ++stretch;
    Frame frame = by_condition[stretches[stretch].condition][i];
    frame.stamp_ns += At(9, 0, days_later);
    frames.push_back(std::move(frame));
  }
  return frames;
}

// The foray built into a fresh map of `robot`'s, read back whole (one outing).
inline GraphBatch DatedCorridorForay(const Uuid& robot,
                                     const std::vector<CorridorStretch>& stretches,
                                     int days_later) {
  const ScratchDir dir("fleetmap-dated-foray");
  const std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (dir / "robot.db").string());
  ExperienceMap map(SharedCorridorVocabulary());
  DistanceRanking policy;
  ExperienceBuilder builder(store.get(), map, policy, {});
  OutingStart start;
  start.robot = robot;
  start.outing = Uuid::Generate();
  builder.StartOuting(start);
  for (const Frame& frame : DatedCorridorFrames(stretches, days_later)) builder.Process(frame);
  builder.FinishOuting();
  return store->ReadMap();
}

}  // namespace fleetmap
