// How a robot's unsynced content goes to a server: as submissions
// that each fit the server's limits, planned before the agent says hello and sent chunk by
// chunk, so that neither the size of the content nor the time to read it can wedge a robot.
//
// - Items 3: content over the server's --max-submission-mib goes as several submissions, each
//   of whole nodes with the edges whose ends are in it or in an earlier one. The server merges
//   a robot's submissions in order (an edge to a node of one still queued waits for it:
//   Repository::Merge, waits_for), so the parts join up. A node over the limits on its own
//   (with its chunk envelope) is held: not pushed, kept in map.db, listed in the state; edges
//   to it wait with it.
// - Item 4: the planning reads the nodes in batches and encodes them once to learn each
//   submission's chunk count, bytes and digest (what PushBegin announces), keeping none of the
//   chunks; StreamSubmission encodes them again as they are sent. Memory holds ids, each
//   edge's ends and encoded size (PlannedEdge) and a batch of nodes, never the content: an
//   edge is read again by id each time it is encoded.
//
// A submission's chunks are exactly EncodeMapChunks of its content with each kind ordered by
// UUID (paths, nodes, edges), as LocalMap::SubmissionContent gives it: a submission recorded by
// an earlier agent resumes under its id with the same chunks.
#pragma once

#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap::agent_internal {

// Room a PushChunk frame takes beyond its chunk (the frame's envelope, seq and digest).
inline constexpr std::uint32_t kPushChunkEnvelopeBytes = 64;

// `said` with what a server that did not say is taken to take: fleetmapd's defaults.
ServerLimits EffectiveLimits(const ServerLimits& said);

// An edge a plan may send, as the plan holds it: its ends and encoded size, not its content
// (a pose is 128 bytes; a backlog has millions of edges), which is read again, by id, when the
// edge is encoded.
struct PlannedEdge {
  Uuid id;
  Uuid from;
  Uuid to;
  std::uint32_t bytes = 0;  // encoded
};

struct PlannedSubmission {
  // Each kind ordered by UUID. Nodes and edges by id only: their content is read again when
  // sent. Edges as positions in `edge_pool`, which is ordered by UUID and shared by the
  // submissions of a plan: a backlog's millions of edges are held once.
  std::vector<Path> paths;
  std::vector<Uuid> nodes;
  std::shared_ptr<const std::vector<PlannedEdge>> edge_pool;
  std::vector<std::uint32_t> edges;
  // What PushBegin announces.
  std::uint32_t chunk_count = 0;
  std::uint64_t total_bytes = 0;
  std::uint64_t digest = 0;
  std::uint64_t largest_chunk_bytes = 0;
  // The id it goes under once recorded (LocalMap::StageSubmission); none for the pending one.
  std::optional<Uuid> staged;

  ElementIds Ids() const;
};

struct PushPlan {
  ServerLimits limits;  // effective: what it was planned for
  // In push order: the pending submission first when there is one, then the new content.
  std::deque<PlannedSubmission> submissions;
  bool pending_first = false;
  // The pending submission does not fit `limits`: the server refuses it at push_begin (before
  // storing a byte) and always will. The caller abandons it and plans again.
  bool pending_does_not_fit = false;
  std::vector<HeldNode> held;  // nodes over `limits` on their own, by UUID
  std::size_t held_edges = 0;  // unsynced edges to them, held with them
};

// Plans the push of `map`'s pending submission and unsynced content under `limits`
// (effective). Throws Error(kNotFound) when map.db no longer holds an element of the pending
// submission, and what GraphStore throws.
PushPlan PlanPush(const LocalMap& map, const ServerLimits& limits);

// Whether a plan made for `plan.limits` still holds under `limits` (effective): every
// submission fits, and no node is held that `limits` would take.
bool PlanHoldsUnder(const PushPlan& plan, const ServerLimits& limits);

// Encodes `submission`'s content from `store` again, chunk by chunk, and gives chunks
// [from, chunk_count) to `send` (seq, data) as they are made. Throws Error(kNotFound) naming a
// node map.db no longer holds, and Error(kCorrupt) when the chunks no longer add up to the
// planned count and digest (map.db changed under the plan); `send` has then been given chunks
// of the changed content, and the caller must not complete the push.
void StreamSubmission(GraphStore& store, const PlannedSubmission& submission, std::uint32_t from,
                      const std::function<void(std::uint32_t, const std::string&)>& send);

}  // namespace fleetmap::agent_internal
