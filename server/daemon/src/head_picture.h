// The status page's picture of the head and its recent history (fleet_status.h
// head_picture_svg, recent_revisions), drawn once per head revision, not per request.
//
// Cost: Refresh runs on a store worker (never on the HTTP thread) and, only when the head has
// moved since the picture it holds, reads the head's nodes without landmarks and its edges,
// lays them out and writes SVG (about 80 bytes of SVG per node and per edge drawn). The layout
// is relaxed (fleetmap/relaxation/relaxed_layout.h) up to kMaxRelaxedPictureNodes nodes, whose
// solve takes a few seconds of the worker (tests/benchmarks/relaxation_benchmark.cc: 3-4 CPU-s
// at 10^4 nodes, growing faster than the map); a larger map is drawn composed (time
// O(nodes + edges)) and its title says why, plus the last FleetStatus::kRecentRevisions revisions
// and the robots. At most one drawing runs at a time; a refresh that finds one running returns at
// once and the next refresh (a merge, or the status page's periodic look at the store) catches up.
// A request only copies the pointer to the finished SVG.
//
// Threading: every member is safe from any thread.
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {

// The largest map the status page relaxes: beyond it the picture is composed.
inline constexpr std::size_t kMaxRelaxedPictureNodes = 10'000;

class HeadPicture {
 public:
  // Draws the head's picture and reads the history when the head is not the one drawn.
  // Throws as the store does (the picture held stays as it was).
  void Refresh(Repository& repository);
  // Sets status's picture and history to the latest drawn.
  void AddTo(FleetStatus& status) const;

 private:
  mutable Mutex mutex_;
  bool drawing_ GUARDED_BY(mutex_) = false;
  std::int64_t drawn_ GUARDED_BY(mutex_) = -1;
  std::shared_ptr<const std::string> svg_ GUARDED_BY(mutex_);
  std::vector<RevisionRow> history_ GUARDED_BY(mutex_);
};

}  // namespace fleetmap::daemon
