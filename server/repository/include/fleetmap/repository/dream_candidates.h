// The candidate maps nightly dreams leave (seed 004 §VI-E; nightly_dream.h), kept in the
// repository's store until someone promotes one (Repository::Promote) or ignores it.
//
// A dream must not change the map: it runs beside pushes and merges, and its result is judged
// by people before it becomes a revision. So a candidate is stored apart from the history, in
// the store's settings, which both backends have and which need no schema of their own:
// - "dream-candidate/<uuid>": the candidate's description (JSON, below), written last, so a
//   candidate that is listed is complete;
// - "dream-content/<uuid>/<seq>": its content, as MapChunks (map_chunks.h), read one by one.
// Only what the dream added to its base is stored (the base is in the history already): the
// groups' nodes the best order kept, and their edges and paths.
//
// Threading: as the VersionStore it is given (one thread at a time).
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

// What a dream made and how the held-out data judged it.
struct DreamCandidateRecord {
  Uuid id;
  std::int64_t created_ns = 0;         // when the dream finished, UTC
  RevisionNumber base_revision = 0;    // the map the groups were merged into
  RevisionNumber dreamed_at_head = 0;  // the head when the dream started
  std::vector<Uuid> groups;            // the submissions merged, in the best order
  std::vector<Uuid> merged_order;      // the same, in the order the server merged them
  Uuid held_out;                       // the submission that judged the orders
  std::string held_out_rule;           // how it was chosen, for people
  std::size_t orders = 0;              // orders explored
  std::size_t held_out_frames = 0;
  // The best order's held-out replay (held_out_replay.h): P(gap > gap_m), the share of frames
  // not localised, and HeldOutScore (lower is better).
  double gap_m = 10.0;
  double p_gap_exceeds = 0.0;
  double not_localised = 0.0;
  double score = 0.0;
  // The same for the order the server merged the groups in, when the dream explored it.
  std::optional<double> merged_order_score;
  std::int64_t nodes = 0, edges = 0, paths = 0;  // the content stored (see above)
  std::int64_t chunks = 0;
  RevisionNumber promoted_as = 0;  // the revision Promote made of it; 0: not promoted

  friend bool operator==(const DreamCandidateRecord&, const DreamCandidateRecord&) = default;
};

// The record as JSON (`fleetmap candidates --json`, the promotion's revision report) and
// back. FromJson throws Error(kCorrupt) naming what is wrong.
std::string DreamCandidateJson(const DreamCandidateRecord& record);
DreamCandidateRecord DreamCandidateFromJson(std::string_view json);

// Whether promoting `record` can improve the map: its held-out score (lower is better) is
// below that of the order the server merged its groups in, the same score of the same replay
// of the same held-out data (like with like). Throws Error(kInvalidArgument) giving both
// scores when it ties or loses, or saying the dream did not score the merged order, each
// naming --force, the way to promote it all the same.
void RequireBeatsMergedOrder(const DreamCandidateRecord& record);

// Throws Error(kConflict) naming the revision that promoted `record` already; returns when it
// was never promoted.
void RequireNotPromoted(const DreamCandidateRecord& record);

class DreamCandidates {
 public:
  // The candidates of `repository`, which must outlive them.
  explicit DreamCandidates(Repository& repository) : DreamCandidates(repository.versions()) {}
  // The candidates kept in `versions` (a repository's, or a test's store), which must outlive
  // them.
  explicit DreamCandidates(VersionStore& versions) : versions_(versions) {}

  // Stores `content` as candidate record.id (generated when nil) with its record; counts and
  // chunks are filled in. Returns the record as stored. Throws as the store does; a candidate
  // cut off before its record is written is never listed.
  DreamCandidateRecord Put(DreamCandidateRecord record, const GraphBatch& content);
  // Every complete candidate, newest first.
  std::vector<DreamCandidateRecord> List();
  std::optional<DreamCandidateRecord> Find(const Uuid& id);
  // Its content. Throws Error(kNotFound) for an unknown candidate, Error(kCorrupt) when a
  // chunk is missing or does not decode.
  GraphBatch Content(const DreamCandidateRecord& record);
  // Records that revision `revision` promoted candidate `id`, inside the promotion's
  // transaction (REQUIRES: one open), and only if nothing promoted it first: the check and the
  // write are one step of the store (VersionStore::ReplaceSetting), so of promotions of one
  // candidate at once exactly one records, and the others wait for it to end. Returns the
  // record as promoted. Throws Error(kConflict) naming the revision that promoted it already,
  // Error(kNotFound) for an unknown candidate.
  DreamCandidateRecord MarkPromoted(const Uuid& id, RevisionNumber revision);

 private:
  VersionStore& versions_;
};

}  // namespace fleetmap
