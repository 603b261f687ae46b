// Repository::Promote: a dream's candidate made the map (seed 004 §VI-E; repository.h).
#include <chrono>
#include <set>

#include "fleetmap/core/error.h"
#include "fleetmap/repository/dream_candidates.h"
#include "fleetmap/repository/repository.h"
#include "promotion_hides.h"

namespace fleetmap {
namespace {

template <typename T>
std::set<Uuid> IdsOf(const std::vector<T>& items) {
  std::set<Uuid> ids;
  for (const T& item : items) ids.insert(item.id);
  return ids;
}

}  // namespace

Revision Repository::Promote(const Uuid& candidate_id, const std::string& author, bool force) {
  DreamCandidates candidates(versions());
  const std::optional<DreamCandidateRecord> record = candidates.Find(candidate_id);
  if (!record) {
    throw Error(ErrorCode::kNotFound, "no dream candidate " + candidate_id.ToString() +
                                          " (`fleetmap candidates` lists them)");
  }
  RequireNotPromoted(*record);
  const GraphBatch content = candidates.Content(*record);
  // A candidate that only ties the map as merged would swap nodes for nothing.
  if (!force) RequireBeatsMergedOrder(*record);
  // fleetmapd instances merging meanwhile append revisions: an append that finds the head moved
  // fails, and the promotion is worked out again on the new head (the operator's command
  // should not fail because robots are docking). A promotion of this candidate made meanwhile
  // ends it: MarkPromoted, in the promotion's transaction, says by which revision.
  constexpr int kAttempts = 8;
  for (int attempt = 1;; ++attempt) {
    const RevisionNumber head = versions().HeadRevision();
    try {
      return PromoteOnHead(*record, content, author);
    } catch (const Error& error) {
      if (error.code() != ErrorCode::kConflict || attempt == kAttempts ||
          versions().HeadRevision() == head) {
        throw;
      }
      if (const std::optional<DreamCandidateRecord> now = candidates.Find(candidate_id)) {
        RequireNotPromoted(*now);
      }
    }
  }
}

Revision Repository::PromoteOnHead(const DreamCandidateRecord& record_ref,
                                   const GraphBatch& content, const std::string& author) {
  const DreamCandidateRecord* record = &record_ref;
  DreamCandidates candidates(versions());
  const RevisionNumber head = versions().HeadRevision();

  // The nodes the merges of the dreamed groups added that the candidate does without, less
  // what later merges hang from (promotion_hides.h).
  const std::set<Uuid> visible = IdsOf(versions().NodesAt(head, /*with_landmarks=*/false));
  const std::vector<Uuid> hide =
      NodesPromotionHides(versions(), head, record->merged_order, visible, IdsOf(content.nodes));

  // What the candidate holds that was never stored. A stored element stays as it is: visible,
  // or hidden by a revert since (nothing un-hides).
  const auto unstored = [&](const Uuid& id) { return !versions().VersionOf(id).has_value(); };
  GraphBatch additions;
  std::set<Uuid> nodes_after = visible;
  for (const Uuid& node : hide) nodes_after.erase(node);
  for (const Node& node : content.nodes) {
    if (!unstored(node.id)) continue;
    additions.nodes.push_back(node);
    nodes_after.insert(node.id);
  }
  std::set<Uuid> paths_after = IdsOf(versions().PathsAt(head));
  for (const Path& path : content.paths) {
    if (!unstored(path.id)) continue;
    additions.paths.push_back(path);
    paths_after.insert(path.id);
  }
  // An edge whose end (or path) is not in the map after the promotion would dangle.
  for (const Edge& edge : content.edges) {
    if (!nodes_after.contains(edge.from) || !nodes_after.contains(edge.to)) continue;
    if (edge.kind == EdgeKind::kPath && !paths_after.contains(edge.path)) continue;
    if (unstored(edge.id)) additions.edges.push_back(edge);
  }

  Revision revision;
  revision.number = head + 1;
  revision.created_ns = Now();
  revision.author = author;
  revision.kind = RevisionKind::kPromote;
  DreamCandidateRecord promoted = *record;
  promoted.promoted_as = revision.number;
  revision.report = DreamCandidateJson(promoted);
  GraphStore::Transaction transaction = store_->Begin();
  // First, so that of promotions of this candidate at once the one that marks it is the one
  // that appends; the others wait here for it and are told (PostgreSQL's row lock; SQLite's
  // write lock is taken by Begin already).
  candidates.MarkPromoted(record->id, revision.number);
  const Revision recorded = versions().AppendPromotion(revision, additions, hide);
  store_->Put(additions);
  transaction.Commit();
  return recorded;
}

}  // namespace fleetmap
