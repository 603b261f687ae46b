// What code outside the repository may read of it beyond Repository's own verbs: the records a
// command prints, a report counts or the daemon answers a robot and its status page with
// (Repository::inspect()). Every query only reads; whatever changes the repository is a verb
// of Repository or of a registry bound to it (robot_registry.h, channel_registry.h,
// dream_candidates.h, merge_claims.h), so the rules that keep the store consistent live in
// one place.
//
// Threading: as the Repository it belongs to (one thread at a time): the store's connection is
// shared, so a query made inside a transaction of the repository sees that transaction.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

class RepositoryInspection {
 public:
  // `store` is the repository's and must outlive the inspection.
  explicit RepositoryInspection(GraphStore& store) : store_(store) {}

  // The schema version of the store (opening it migrated it to the latest this binary knows).
  int SchemaVersion() const;

  // ---- Revisions ----

  // Counts and landmark bytes of the map at revision `r`. This and NodesAt throw
  // Error(kNotFound) unless 0 <= r <= the head.
  StoreStats StatsAt(RevisionNumber r) const;
  // The record of revision `r` (author, kind, what it added and hid); none outside the history.
  std::optional<Revision> FindRevision(RevisionNumber r) const;
  // The nodes visible at revision `r` (by stamp, then id), with their landmarks or without.
  std::vector<Node> NodesAt(RevisionNumber r, bool with_landmarks) const;
  // Stored nodes by id, with their landmarks, whatever revision shows or hides them, in the
  // order of `ids`. Throws Error(kNotFound) naming the first id not stored.
  std::vector<Node> GetNodes(std::span<const Uuid> ids) const;
  // Where a merge put `node`, which it omitted (the node that stands in for it); none when no
  // merge omitted it.
  std::optional<NodeStandIn> FindStandIn(const Uuid& node) const;

  // ---- Submissions ----

  std::optional<Submission> FindSubmission(const Uuid& id) const;
  // Chunk `seq` of submission `id` as stored (a serialised MapChunk). Throws as
  // VersionStore::SubmissionChunk.
  std::string SubmissionChunk(const Uuid& id, std::int64_t seq) const;
  // The claim of a fleetmapd instance on submission `id`, live or ended; none when none was
  // made. Throws Error(kNotFound) for an unknown submission.
  std::optional<SubmissionClaim> FindClaim(const Uuid& id) const;

 private:
  GraphStore& store_;
};

}  // namespace fleetmap
