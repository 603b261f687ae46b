// A robot's map of corridor outings (corridor_scene.h), built by the EBN builder from scratch,
// as the robot would keep and push it: for repository, dreaming and CLI tests.
#pragma once

#include <filesystem>
#include <vector>

#include "corridor_scene.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/store/graph_store.h"
#include "scratch_dir.h"

namespace fleetmap {

// One outing of the corridor: condition 0 (day) or 1 (night), from `start_m` metres.
struct CorridorOuting {
  int condition = 0;
  double start_m = 0.0;
};

// Builds the outings, in order and each starting lost, into `store` (one robot).
inline void BuildCorridorRobotMap(GraphStore& store, const std::vector<CorridorOuting>& outings,
                                  const Uuid& robot = Uuid::Generate()) {
  ExperienceMap map(SharedCorridorVocabulary());
  DistanceRanking policy;
  ExperienceBuilder builder(&store, map, policy, {});
  for (const CorridorOuting& outing : outings) {
    OutingStart start;
    start.robot = robot;
    start.outing = Uuid::Generate();
    builder.StartOuting(start);
    for (const Frame& frame : SharedCorridor().Outing(outing.condition, outing.start_m)) {
      builder.Process(frame);
    }
    builder.FinishOuting();
  }
}

// The same, in a scratch store, read back whole.
inline GraphBatch CorridorRobotMap(const std::vector<CorridorOuting>& outings,
                                   const Uuid& robot = Uuid::Generate()) {
  const ScratchDir dir("fleetmap-robot-map");
  const std::unique_ptr<GraphStore> store =
      GraphStore::Open("sqlite:" + (dir / "robot.db").string());
  BuildCorridorRobotMap(*store, outings, robot);
  return store->ReadMap();
}

}  // namespace fleetmap
