// The rules both VersionStore backends apply the same way (version_store.h; schema in
// */migrations/0002_versions.sql), so that they agree by construction and not only by passing
// one conformance suite.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap::internal {

// element_versions.kind.
enum class VersionedKind : int { kNode = 1, kEdge = 2, kPath = 3 };

const char* VersionedKindName(VersionedKind kind);

// A kind read back from element_versions; anything else is a damaged store.
VersionedKind StoredVersionedKind(std::int64_t kind, const Uuid& id);

struct VersionedElement {
  Uuid id;
  VersionedKind kind;
};

// The distinct nodes, edges and paths of `additions` (annotations are not versioned), each
// checked by Validate; their numbers go into `counts`. An id repeated within one kind counts
// once (as GraphStore::Put stores it once); one id under two kinds throws
// Error(kInvalidArgument).
std::vector<VersionedElement> VersionedElementsOf(const GraphBatch& additions, Revision& counts);

Error AlreadyStored(VersionedKind kind, const Uuid& id, RevisionNumber number);

// AppendRevision's checks that need no database: a merge, inside a Transaction.
void RequireMergeInTransaction(const Revision& revision, bool in_transaction);

// Revision numbers are strictly head + 1: a writer that lost the race learns it here.
void RequireNextRevision(RevisionNumber number, RevisionNumber head);

// Reads at a revision: 0 <= r <= head.
void RequireInHistory(RevisionNumber r, RevisionNumber head);

// Puts the nodes of a revision in NodesAt's order (stamp_ns, then id). Both backends sort in
// memory, not with ORDER BY: a database sorter carries whole rows, landmark blobs included,
// and for a large map (500 MB) that sort (spilled to disk) was most of a cold download.
void OrderNodesAt(std::vector<Node>& nodes);

// AppendPromotion's checks: a kPromote inside a Transaction, no node both added and hidden.
// Returns the revision as recorded before its hidden counts are known (no revert, no
// submission).
Revision PromotionAsRecorded(const Revision& revision, const GraphBatch& additions,
                             const std::vector<Uuid>& hide_nodes, bool in_transaction);

// Records that a revision hid `count` elements of `kind` (the store's hidden counts, per kind).
void SetHiddenCount(Revision& recorded, VersionedKind kind, std::int64_t count);

// AppendRetirement's check: a kRetire. Returns the revision as recorded before its hidden
// counts are known (nothing added, no revert, no submission).
Revision RetirementAsRecorded(const Revision& revision);

// Records that a revert of a retirement brought back `count` elements of `kind`.
void SetRestoredCount(Revision& recorded, VersionedKind kind, std::int64_t count);

// PutNodeUsage's check of one record.
void RequireValidUsage(const NodeUsage& usage);

// AppendRevert's revision before its hidden counts are known: a kRevert with no submission
// and nothing counted yet, whatever the caller filled in.
Revision RevertAsRecorded(const Revision& revision);

// AppendRevert's checks of the revision to revert: `target` as stored (nullopt when unknown)
// and `reverted_by`, the revert that already reverted it, if any.
void RequireRevertable(RevisionNumber reverted, const std::optional<Revision>& target,
                       std::optional<RevisionNumber> reverted_by);

// ---- Submission rules ----

Error NoSubmission(const Uuid& id);

// A claim's lease in nanoseconds, and who claims. Throws Error(kInvalidArgument) for a lease
// that is not positive or an empty instance name (a claim must say who holds it).
std::int64_t ClaimLeaseNs(const std::string& instance, std::chrono::milliseconds lease);

// BeginSubmission of a stored id: a resumed push from the same robot, else a conflict.
void RequireSameRobot(const Submission& stored, const Submission& header);

// PutSubmissionChunk against the stored submission: true when chunk `seq` is stored already
// (the caller compares bytes: the same is a no-op, others ChunkConflict), false when it is
// the next chunk to store. Throws Error(kInvalidArgument) for a negative seq or a gap, and
// Error(kConflict) for a new chunk of a complete submission.
bool ChunkIsStored(const Submission& stored, std::int64_t seq);

Error ChunkConflict(const Uuid& id, std::int64_t seq);

// CompleteSubmission: true when the submission is complete already with this digest (a
// no-op), false when it is still receiving. Throws Error(kConflict) for another digest.
bool CompleteAlready(const Submission& stored, std::uint64_t digest);

// SetSubmissionState: the submission as it becomes (the revision kept only for kMerged, the
// error only for kFailed). Throws Error(kInvalidArgument) for a submission still receiving,
// a move to kReceiving or a state that is none of the four.
Submission WithState(Submission stored, SubmissionState state, RevisionNumber revision,
                     const std::string& error);

// ---- The map at a revision ----

// 0002_versions.sql: added at or before r and not hidden at or before r.
bool VisibleAt(RevisionNumber added, std::optional<RevisionNumber> hidden, RevisionNumber r);

// One retirement of an element (0009_retirement.sql): hidden from `retired` until `restored`.
struct RetirementSpan {
  RevisionNumber retired = 0;
  std::optional<RevisionNumber> restored;
};

// One element_versions row of an element that is stored, and its retirements.
struct ElementVersionRow {
  Uuid id;
  VersionedKind kind;
  RevisionNumber added;
  std::optional<RevisionNumber> hidden;
  std::vector<RetirementSpan> retirements;
};

// Visible at r by its element_versions row and not retired at r.
bool VisibleAt(const ElementVersionRow& row, RevisionNumber r);

// Changes(from, to) from the rows of every element a revision between them added, hid,
// retired or restored (elements outside that range are visible at both or at neither), each
// with all its retirements. Lists come sorted.
RevisionChanges ChangesFromRows(RevisionNumber from, RevisionNumber to,
                                const std::vector<ElementVersionRow>& rows);

}  // namespace fleetmap::internal
