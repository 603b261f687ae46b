// What is wrong with a map store, and what to do about it: what `fleetmap doctor` reports (in
// the manner of `mcap doctor`). Only reads; it never repairs, because every repair here means
// deciding what a fleet's map should hold, which is a person's call.
//
// Checks, each named in StoreProblem::check:
//   "engine"           the engine's own check (StoreHealth::EngineProblems);
//   "dangling edges"   stored edges whose node or path is not stored;
//   "head"             edges visible at the head whose node or path is not (a map a robot
//                      would download with edges into nothing);
//   "cut off"          pieces of the head's map a hide (revert, promotion) cut off from the
//                      largest piece: they hold a stored metric edge into a hidden node;
//   "orphan versions"  version records of elements not stored or of revisions not made;
//   "history"          revisions not numbered 1..head without a gap, merges whose submission
//                      is missing or does not say it became that revision, and the reverse;
//   "submissions"      pushes stuck receiving, and queued submissions nobody merges.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "fleetmap/store/graph_store.h"

namespace fleetmap {

struct DiagnosisOptions {
  std::int64_t now_ns = 0;  // UTC; what "stuck" is measured from
  // A push still receiving this long after it began has stopped: its robot has not come
  // back to resume it.
  std::chrono::minutes receiving_stuck_after{24 * 60};
  // A queued submission this long after it arrived, with no live merge claim, is one no
  // fleetmapd merges (none runs on this store, or each refuses it).
  std::chrono::minutes queued_stuck_after{60};
  std::size_t examples = 5;  // ids named per problem
};

struct StoreProblem {
  std::string check;   // one of the names above
  std::string what;    // what is wrong, with counts and the first ids
  std::string remedy;  // what to do about it
};

// Every problem found; empty when the store is healthy. Throws what the store throws.
std::vector<StoreProblem> DiagnoseStore(GraphStore& store, const DiagnosisOptions& options);

}  // namespace fleetmap
