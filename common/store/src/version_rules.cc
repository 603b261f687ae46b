#include "version_rules.h"

#include <algorithm>
#include <unordered_map>

namespace fleetmap::internal {

const char* VersionedKindName(VersionedKind kind) {
  switch (kind) {
    case VersionedKind::kNode:
      return "node";
    case VersionedKind::kEdge:
      return "edge";
    case VersionedKind::kPath:
      return "path";
  }
  return "element";
}

VersionedKind StoredVersionedKind(std::int64_t kind, const Uuid& id) {
  if (kind < 1 || kind > 3) {
    throw Error(ErrorCode::kCorrupt, "element " + id.ToString() + " has a stored version kind " +
                                         std::to_string(kind) + " (expected 1, 2 or 3)");
  }
  return static_cast<VersionedKind>(kind);
}

std::vector<VersionedElement> VersionedElementsOf(const GraphBatch& additions, Revision& counts) {
  std::vector<VersionedElement> elements;
  elements.reserve(additions.nodes.size() + additions.edges.size() + additions.paths.size());
  std::unordered_map<Uuid, VersionedKind> seen;
  seen.reserve(elements.capacity());
  std::int64_t added[4] = {0, 0, 0, 0};
  auto add = [&](const Uuid& id, VersionedKind kind) {
    const auto [it, inserted] = seen.emplace(id, kind);
    if (!inserted) {
      if (it->second == kind) return;
      throw Error(ErrorCode::kInvalidArgument, "revision " + std::to_string(counts.number) +
                                                   " adds " + id.ToString() + " both as a " +
                                                   VersionedKindName(it->second) + " and as a " +
                                                   VersionedKindName(kind));
    }
    elements.push_back({id, kind});
    ++added[static_cast<int>(kind)];
  };
  for (const Node& n : additions.nodes) {
    Validate(n);
    add(n.id, VersionedKind::kNode);
  }
  for (const Edge& e : additions.edges) {
    Validate(e);
    add(e.id, VersionedKind::kEdge);
  }
  for (const Path& p : additions.paths) {
    Validate(p);
    add(p.id, VersionedKind::kPath);
  }
  counts.nodes_added = added[static_cast<int>(VersionedKind::kNode)];
  counts.edges_added = added[static_cast<int>(VersionedKind::kEdge)];
  counts.paths_added = added[static_cast<int>(VersionedKind::kPath)];
  return elements;
}

Error AlreadyStored(VersionedKind kind, const Uuid& id, RevisionNumber number) {
  return Error(ErrorCode::kConflict, std::string(VersionedKindName(kind)) + " " + id.ToString() +
                                         " is already stored: revision " + std::to_string(number) +
                                         " may add only what is new");
}

void RequireMergeInTransaction(const Revision& revision, bool in_transaction) {
  const std::string name = "revision " + std::to_string(revision.number);
  if (revision.kind != RevisionKind::kMerge) {
    throw Error(ErrorCode::kInvalidArgument,
                name + ": AppendRevision records merges only (use AppendRevert for a revert)");
  }
  if (!in_transaction) {
    throw Error(ErrorCode::kInvalidArgument,
                name +
                    ": AppendRevision needs a Transaction open on its GraphStore, in which "
                    "the caller also Puts the additions");
  }
}

void RequireNextRevision(RevisionNumber number, RevisionNumber head) {
  if (number == head + 1) return;
  throw Error(ErrorCode::kConflict, "revision " + std::to_string(number) +
                                        " cannot be appended: the head is " + std::to_string(head) +
                                        ", so the next revision is " + std::to_string(head + 1) +
                                        " (another writer may have committed first)");
}

void RequireInHistory(RevisionNumber r, RevisionNumber head) {
  if (r >= 0 && r <= head) return;
  throw Error(ErrorCode::kNotFound, "revision " + std::to_string(r) +
                                        " is not in the history (the head is " +
                                        std::to_string(head) + ")");
}

Revision PromotionAsRecorded(const Revision& revision, const GraphBatch& additions,
                             const std::vector<Uuid>& hide_nodes, bool in_transaction) {
  const std::string name = "revision " + std::to_string(revision.number);
  if (revision.kind != RevisionKind::kPromote) {
    throw Error(ErrorCode::kInvalidArgument,
                name + ": AppendPromotion records promotions only (kind promote)");
  }
  if (!in_transaction) {
    throw Error(ErrorCode::kInvalidArgument,
                name +
                    ": AppendPromotion needs a Transaction open on its GraphStore, in which "
                    "the caller also Puts the additions");
  }
  std::vector<Uuid> hidden = hide_nodes;
  std::sort(hidden.begin(), hidden.end());
  for (const Node& node : additions.nodes) {
    if (std::binary_search(hidden.begin(), hidden.end(), node.id)) {
      throw Error(ErrorCode::kInvalidArgument,
                  name + ": node " + node.id.ToString() + " is both added and hidden");
    }
  }
  Revision recorded = revision;
  recorded.submission = Uuid();
  recorded.reverted = 0;
  recorded.nodes_hidden = recorded.edges_hidden = recorded.paths_hidden = 0;
  return recorded;
}

void SetHiddenCount(Revision& recorded, VersionedKind kind, std::int64_t count) {
  switch (kind) {
    case VersionedKind::kNode:
      recorded.nodes_hidden = count;
      break;
    case VersionedKind::kEdge:
      recorded.edges_hidden = count;
      break;
    case VersionedKind::kPath:
      recorded.paths_hidden = count;
      break;
  }
}

Revision RetirementAsRecorded(const Revision& revision) {
  if (revision.kind != RevisionKind::kRetire) {
    throw Error(ErrorCode::kInvalidArgument,
                "revision " + std::to_string(revision.number) +
                    ": AppendRetirement records retirements only (kind retire)");
  }
  Revision recorded = revision;
  recorded.submission = Uuid();
  recorded.reverted = 0;
  recorded.nodes_added = recorded.edges_added = recorded.paths_added = 0;
  recorded.nodes_hidden = recorded.edges_hidden = recorded.paths_hidden = 0;
  return recorded;
}

void SetRestoredCount(Revision& recorded, VersionedKind kind, std::int64_t count) {
  switch (kind) {
    case VersionedKind::kNode:
      recorded.nodes_added = count;
      break;
    case VersionedKind::kEdge:
      recorded.edges_added = count;
      break;
    case VersionedKind::kPath:
      recorded.paths_added = count;
      break;
  }
}

void RequireValidUsage(const NodeUsage& usage) {
  if (usage.frames < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "node use of " + usage.node.ToString() + ": negative frames");
  }
  if (usage.source != UsageSource::kReplay && usage.source != UsageSource::kRobot) {
    throw Error(ErrorCode::kInvalidArgument,
                "node use of " + usage.node.ToString() + ": unknown source");
  }
}

Revision RevertAsRecorded(const Revision& revision) {
  Revision recorded = revision;
  recorded.kind = RevisionKind::kRevert;
  recorded.submission = Uuid();
  recorded.nodes_added = recorded.edges_added = recorded.paths_added = 0;
  recorded.nodes_hidden = recorded.edges_hidden = recorded.paths_hidden = 0;
  return recorded;
}

void RequireRevertable(RevisionNumber reverted, const std::optional<Revision>& target,
                       std::optional<RevisionNumber> reverted_by) {
  const std::string name = "revision " + std::to_string(reverted);
  if (reverted == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "revision 0 (the map before the first revision) cannot be reverted");
  }
  if (!target) throw Error(ErrorCode::kNotFound, "no " + name + " to revert");
  if (target->kind == RevisionKind::kPromote) {
    throw Error(ErrorCode::kInvalidArgument,
                name +
                    " is a promotion; it cannot be reverted (it hid nodes, and nothing un-hides): "
                    "promote another candidate instead");
  }
  if (target->kind == RevisionKind::kRevert) {
    throw Error(ErrorCode::kInvalidArgument,
                name + " is a revert; a revert cannot be reverted (nothing un-hides)");
  }
  if (reverted_by) {
    throw Error(ErrorCode::kConflict,
                name + " is already reverted by revision " + std::to_string(*reverted_by));
  }
}

Error NoSubmission(const Uuid& id) {
  return Error(ErrorCode::kNotFound, "no submission " + id.ToString());
}

std::int64_t ClaimLeaseNs(const std::string& instance, std::chrono::milliseconds lease) {
  if (instance.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "a claim needs the name of the instance making it");
  }
  if (lease.count() <= 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "a claim's lease must be positive, not " + std::to_string(lease.count()) + " ms");
  }
  return std::chrono::duration_cast<std::chrono::nanoseconds>(lease).count();
}

void RequireSameRobot(const Submission& stored, const Submission& header) {
  if (stored.robot == header.robot) return;
  throw Error(ErrorCode::kConflict, "submission " + stored.id.ToString() + " belongs to robot " +
                                        stored.robot.ToString() + ", not to robot " +
                                        header.robot.ToString());
}

bool ChunkIsStored(const Submission& stored, std::int64_t seq) {
  const std::string name =
      "chunk " + std::to_string(seq) + " of submission " + stored.id.ToString();
  if (seq < 0) throw Error(ErrorCode::kInvalidArgument, name + ": negative sequence number");
  if (seq < stored.chunk_count) return true;
  if (stored.state != SubmissionState::kReceiving) {
    throw Error(ErrorCode::kConflict, name + " is new, but the submission is complete with " +
                                          std::to_string(stored.chunk_count) + " chunks");
  }
  if (seq > stored.chunk_count) {
    throw Error(ErrorCode::kInvalidArgument,
                name + " skips ahead: chunks come in order and the next is " +
                    std::to_string(stored.chunk_count));
  }
  return false;
}

Error ChunkConflict(const Uuid& id, std::int64_t seq) {
  return Error(ErrorCode::kConflict, "chunk " + std::to_string(seq) + " of submission " +
                                         id.ToString() + " is stored with other bytes");
}

bool CompleteAlready(const Submission& stored, std::uint64_t digest) {
  if (stored.state == SubmissionState::kReceiving) return false;
  if (stored.digest == digest) return true;
  throw Error(ErrorCode::kConflict,
              "submission " + stored.id.ToString() + " is complete already with digest " +
                  std::to_string(stored.digest) + ", not " + std::to_string(digest));
}

Submission WithState(Submission stored, SubmissionState state, RevisionNumber revision,
                     const std::string& error) {
  const std::string name = "submission " + stored.id.ToString();
  if (stored.state == SubmissionState::kReceiving) {
    throw Error(ErrorCode::kInvalidArgument, name + " is still receiving; complete it first");
  }
  if (state != SubmissionState::kQueued && state != SubmissionState::kMerged &&
      state != SubmissionState::kFailed) {
    throw Error(ErrorCode::kInvalidArgument, name + " cannot move to state " +
                                                 std::to_string(static_cast<int>(state)) +
                                                 " (only queued, merged or failed)");
  }
  stored.state = state;
  stored.revision = state == SubmissionState::kMerged ? revision : 0;
  stored.error = state == SubmissionState::kMerged ? std::string() : error;
  return stored;
}

bool VisibleAt(RevisionNumber added, std::optional<RevisionNumber> hidden, RevisionNumber r) {
  return added <= r && (!hidden || *hidden > r);
}

bool VisibleAt(const ElementVersionRow& row, RevisionNumber r) {
  if (!VisibleAt(row.added, row.hidden, r)) return false;
  for (const RetirementSpan& span : row.retirements) {
    if (span.retired <= r && (!span.restored || *span.restored > r)) return false;
  }
  return true;
}

RevisionChanges ChangesFromRows(RevisionNumber from, RevisionNumber to,
                                const std::vector<ElementVersionRow>& rows) {
  RevisionChanges changes;
  changes.from = from;
  changes.to = to;
  for (const ElementVersionRow& row : rows) {
    const bool at_from = VisibleAt(row, from);
    const bool at_to = VisibleAt(row, to);
    if (at_from == at_to) continue;
    std::vector<Uuid>* list = nullptr;
    switch (row.kind) {
      case VersionedKind::kNode:
        list = at_to ? &changes.nodes_added : &changes.nodes_removed;
        break;
      case VersionedKind::kEdge:
        list = at_to ? &changes.edges_added : &changes.edges_removed;
        break;
      case VersionedKind::kPath:
        list = at_to ? &changes.paths_added : &changes.paths_removed;
        break;
    }
    list->push_back(row.id);
  }
  for (std::vector<Uuid>* list :
       {&changes.nodes_added, &changes.edges_added, &changes.paths_added, &changes.nodes_removed,
        &changes.edges_removed, &changes.paths_removed}) {
    std::sort(list->begin(), list->end());
  }
  return changes;
}

void OrderNodesAt(std::vector<Node>& nodes) {
  std::sort(nodes.begin(), nodes.end(), [](const Node& a, const Node& b) {
    return a.stamp_ns != b.stamp_ns ? a.stamp_ns < b.stamp_ns : a.id < b.id;
  });
}

}  // namespace fleetmap::internal
