// A scope in which Uuid::Generate on this thread returns a sequence fixed by a seed and a
// stream name instead of time-ordered random ids. Two runs of the same work under the same
// scopes mint the same ids, and ids break ties in MERGE, ranking and downloads: so two arms of
// an experiment (or a change to the code) can be compared decision for decision, node for node.
// For tests and experiments, never for ids a fleet stores: the ids do not reveal time and are
// unique only within one (seed, stream).
//
// Scopes are per thread (a task that runs on a worker thread opens its own) and nest: the
// destructor restores the scope that was open before. Ids within a scope keep version 7's
// layout and increase, so the stores' B-tree indexes still append.
#pragma once

#include <cstdint>
#include <random>
#include <string_view>

#include "fleetmap/core/uuid.h"

namespace fleetmap {

class DeterministicUuids {
 public:
  DeterministicUuids(std::uint64_t seed, std::string_view stream);
  ~DeterministicUuids();
  DeterministicUuids(const DeterministicUuids&) = delete;
  DeterministicUuids& operator=(const DeterministicUuids&) = delete;

  // The scope open on this thread, or nullptr.
  static DeterministicUuids* Current();

  // The next id of this scope's sequence.
  Uuid Next();

 private:
  std::mt19937_64 bits_;
  std::uint64_t count_ = 0;
  DeterministicUuids* previous_;
};

}  // namespace fleetmap
