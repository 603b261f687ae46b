// The map `fleetmap bench scale` measures: a fleet repository of n nodes
// written straight into a store as revisions (MERGE of n nodes would take the benchmark's
// whole budget and is not what is measured), and the work measured on it: a robot's
// submission that revisits a known stretch of the map, merged as fleetmapd merges one, and a
// mission's time-of-day subset selected and encoded as fleetmapd does for a cold download.
//
// The map is outings of kOutingNodes experiences, 1 m and 0.5 s apart, chained by metric and
// path edges, each with its path (seed 002 §IV), starting at times of day spread evenly over
// the day (a golden-ratio sequence). Landmarks are random but reproducible per (seed, outing,
// node), so a revisit can be made again without reading the store.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::bench {

struct ScaleMapSpec {
  std::size_t nodes = 10'000;
  int landmarks_per_node = 200;  // about 9.3 KB of landmarks per node
  std::uint32_t seed = 1;
  static constexpr std::size_t kOutingNodes = 1000;

  std::size_t outings() const { return (nodes + kOutingNodes - 1) / kOutingNodes; }
  std::size_t OutingSize(std::size_t outing) const;
};

// Outing `outing` of the map: its nodes (fresh UUIDs, landmarks as the spec fixes them), its
// chain of metric and path edges and its path, by `robot`, starting `day` days after the
// spec's first day.
GraphBatch ScaleOuting(const ScaleMapSpec& spec, std::size_t outing, const Uuid& robot,
                       int day = 0);

// Writes the spec's map into the repository's store, one revision per outing (committed one
// by one, so memory stays at one outing), bringing the appearance index up to each revision as
// fleetmapd does after a merge. `progress(done, all)` after each. REQUIRES: an
// empty repository. Throws as the store does.
void WriteScaleMap(Repository& repository, const ScaleMapSpec& spec,
                   const std::function<void(std::size_t, std::size_t)>& progress);

// A robot's submission of `nodes` experiences (a new outing, new UUIDs) that re-observe the
// first `nodes` places of the map's middle outing with the same landmarks, a day later: MERGE
// should localise it in the map and omit most of it.
GraphBatch RevisitSubmission(const ScaleMapSpec& spec, std::size_t nodes, const Uuid& robot);

// The time of day (minutes since midnight UTC) the revisited outing starts at: the mission
// start of the download measured, so the subset holds the stretch a robot would drive.
double RevisitTimeOfDayMin(const ScaleMapSpec& spec);

}  // namespace fleetmap::bench
