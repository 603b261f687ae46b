// The status page's pictures (fleet_status.h ServedPicture): the head's map, drawn once per
// head revision, and, when the page asks, the map of any revision (a channel's) and what a
// revision changed (as `fleetmap render --diff R`), kept for the last few asked.
//
// Cost: Refresh runs on a store worker (never on the HTTP thread). When the head has moved since
// the picture held, it reads the head's nodes without landmarks and its edges, lays them out and
// writes SVG (about 80 bytes per node and per edge drawn) and the nodes' facts (about 250 bytes
// a node). The layout is relaxed (fleetmap/relaxation/relaxed_layout.h) up to
// relax_max_nodes nodes (fleetmapd --picture-relax-nodes), whose solve takes a few seconds of the
// worker (tests/benchmarks/relaxation_benchmark.cc: 3-4 CPU-s at 10^4 nodes, growing faster than
// the map); a larger map is drawn composed (time O(nodes + edges)) and its title says why. Then it
// draws the pictures asked for since (Find), at most kMaxAsked waiting at once, each costing what
// the head's does, plus, for a change, the earlier revision's nodes when the change hid any.
// At most kKept pictures besides the head's are held; the oldest asked goes first. At most one
// drawing runs at a time; a refresh that finds one running returns at once and the next refresh
// (a merge, a request for a picture, or the status page's periodic look) catches up.
//
// Threading: every member is safe from any thread.
#pragma once

#include <cstddef>
#include <deque>
#include <memory>
#include <string>
#include <vector>

#include "fleetmap/core/mutex.h"
#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/repository.h"

namespace fleetmap::daemon {

class StatusPictures {
 public:
  // Pictures of maps of more than `relax_max_nodes` nodes are composed, not relaxed.
  explicit StatusPictures(std::size_t relax_max_nodes) : relax_max_nodes_(relax_max_nodes) {}

  static constexpr std::size_t kKept = 8;      // pictures held besides the head's map
  static constexpr std::size_t kMaxAsked = 4;  // asked for and not yet drawn

  // Draws the head's picture and reads the history when the head is not the one drawn, then
  // the pictures asked for. Throws as the store does (what is held stays as it was; a picture
  // that failed is no longer asked for).
  void Refresh(Repository& repository);
  // Sets status's head picture and history to the latest drawn.
  void AddTo(FleetStatus& status) const;
  // The picture when drawn; else null, and asked for when `revision` is one of the history
  // (1 to the head last seen; the head's map is drawn anyway) and fewer than kMaxAsked wait.
  // The caller then has a refresh run (returns whether it asked).
  std::shared_ptr<const ServedPicture> Find(PictureKind kind, std::int64_t revision,
                                            bool* asked = nullptr);

 private:
  struct Asked {
    PictureKind kind;
    std::int64_t revision;
  };
  void DrawHead(Repository& repository);
  void DrawAsked(Repository& repository);

  const std::size_t relax_max_nodes_;
  mutable Mutex mutex_;
  bool drawing_ GUARDED_BY(mutex_) = false;
  std::int64_t drawn_ GUARDED_BY(mutex_) = -1;
  std::shared_ptr<const ServedPicture> head_ GUARDED_BY(mutex_);
  std::vector<RevisionRow> history_ GUARDED_BY(mutex_);
  std::deque<std::shared_ptr<const ServedPicture>> kept_ GUARDED_BY(mutex_);  // newest first
  std::vector<Asked> asked_ GUARDED_BY(mutex_);
};

}  // namespace fleetmap::daemon
