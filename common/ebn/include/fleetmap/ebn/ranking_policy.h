// A ranking policy Γ orders the candidate nodes Y of one localiser iteration by how likely
// each is to localise the live frame (seed 002 §III-C). The builder (common/) owns the loop
// and calls this interface; the policies themselves live in policies/.
//
// Threading: one policy object per builder, used from one thread.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

// A node the localiser may try, with its metric distance from the robot's position estimate.
struct Candidate {
  Uuid node;
  double distance_m = 0.0;
};

// One localisation attempt of an iteration and its outcome.
struct LocalisationAttempt {
  Uuid node;
  bool success = false;
};

class RankingPolicy {
 public:
  virtual ~RankingPolicy() = default;

  // Short name for reports, e.g. "distance", "path".
  virtual std::string name() const = 0;

  // Orders candidates best first. `reference` is the node the robot is currently localised
  // against (n_k), nil when lost.
  virtual void Rank(const Uuid& reference, std::vector<Candidate>& candidates) = 0;

  // Called once per localiser iteration with every attempt it made (possibly none).
  virtual void ObserveIteration(std::span<const LocalisationAttempt> attempts) = 0;

  // Called when the builder adds a path-memory edge (seed 002 §IV): the robot moved in
  // experience space from `from` to `to` on path `path`.
  virtual void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) = 0;

  // A new outing starts: forget the live run's observations (path memory stays).
  virtual void StartOuting() = 0;
};

}  // namespace fleetmap
