#include "push_plan.h"

#include <algorithm>
#include <filesystem>
#include <memory>
#include <span>
#include <unordered_map>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/proto_convert.h"
#include "fleetmap/map.pb.h"
#include "fleetmap/wire/sync_frame.h"
#include "install_rules.h"
#include "sorted_by_id.h"

namespace fleetmap::agent_internal {

namespace {

// fleetmapd's --max-submission-mib default (SyncServerOptions), for a server that does not say.
constexpr std::uint64_t kDefaultMaxSubmissionBytes = std::uint64_t{2048} << 20;
// Nodes read from map.db at a time: a few MB of landmarks at most for ordinary nodes.
constexpr std::size_t kNodeBatch = 64;
// Nodes whose edges are read from map.db at a time, when the plan gathers them.
constexpr std::size_t kPlanEdgeBatch = 4096;
// What an element adds to a chunk beyond its own encoding, at most: its field tag and length
// prefix (map_chunks.cc counts the same 8), so a submission's bytes never pass its budget.
constexpr std::size_t kElementOverhead = 8;

// The chunk writer of map_chunks.cc (EncodeMapChunks), emitting each chunk as it is cut
// instead of keeping them: the same Write calls give the same chunks.
class ChunkStream {
 public:
  using Emit = std::function<void(std::string&&)>;
  explicit ChunkStream(Emit emit) : emit_(std::move(emit)) {}

  template <typename Message, typename Add>
  void Write(Message&& message, std::size_t size, Add add) {
    if (size_ > 0 && size_ + size > kDefaultMapChunkBytes) Flush();
    *add(current_) = std::forward<Message>(message);
    size_ += size + kElementOverhead;
  }

  void Finish() {
    if (size_ > 0 || emitted_ == 0) Flush();
  }

 private:
  void Flush() {
    std::string chunk = current_.SerializeAsString();
    current_.Clear();
    size_ = 0;
    ++emitted_;
    emit_(std::move(chunk));
  }

  Emit emit_;
  v1::MapChunk current_;
  std::size_t size_ = 0;
  std::size_t emitted_ = 0;
};

v1::Path* NewPath(v1::MapChunk& chunk) {
  return chunk.add_paths();
}
v1::Node* NewNode(v1::MapChunk& chunk) {
  return chunk.add_nodes();
}
v1::Edge* NewEdge(v1::MapChunk& chunk) {
  return chunk.add_edges();
}

// What a sequence of chunks adds up to (PushBegin's fields).
struct ChunkTally {
  std::uint32_t count = 0;
  std::uint64_t bytes = 0;
  std::uint64_t largest = 0;
  MapContentDigest digest;

  void Add(const std::string& chunk) {
    ++count;
    bytes += chunk.size();
    largest = std::max<std::uint64_t>(largest, chunk.size());
    digest.Add(chunk);
  }
  void Into(PlannedSubmission& submission) const {
    submission.chunk_count = count;
    submission.total_bytes = bytes;
    submission.largest_chunk_bytes = largest;
    submission.digest = digest.value();
  }
};

// Calls `fn` with each node of `ids` (ordered by UUID), landmarks included, read kNodeBatch at
// a time. Throws Error(kNotFound) naming a node map.db does not hold.
template <typename Fn>
void ForEachNode(GraphStore& store, const std::vector<Uuid>& ids, Fn fn) {
  for (std::size_t i = 0; i < ids.size(); i += kNodeBatch) {
    const std::span<const Uuid> batch(ids.data() + i, std::min(kNodeBatch, ids.size() - i));
    std::vector<Node> nodes = store.GetNodes(batch);
    SortById(nodes);
    for (std::size_t k = 0; k < batch.size(); ++k) {
      if (k >= nodes.size() || nodes[k].id != batch[k]) {
        throw Error(ErrorCode::kNotFound, store.uri() + " no longer holds node " +
                                              batch[k].ToString() + " (planned for a push)");
      }
    }
    for (Node& node : nodes) fn(std::move(node));
  }
}

// Edge `id` of `store`. Throws Error(kNotFound) when map.db no longer holds it.
Edge ReadEdge(GraphStore& store, const Uuid& id) {
  try {
    return store.GetEdge(id);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kNotFound) throw;
    throw Error(ErrorCode::kNotFound,
                store.uri() + " no longer holds edge " + id.ToString() + " (planned for a push)");
  }
}

// Encodes `submission` from `store` as PlanPush did, giving each chunk to `emit`.
void Encode(GraphStore& store, const PlannedSubmission& submission, const ChunkStream::Emit& emit) {
  ChunkStream stream(emit);
  for (const Path& path : submission.paths) {
    v1::Path message = ToProto(path);
    const std::size_t size = message.ByteSizeLong();
    stream.Write(std::move(message), size, NewPath);
  }
  ForEachNode(store, submission.nodes, [&](Node&& node) {
    v1::Node message = ToProto(std::move(node));
    const std::size_t size = message.ByteSizeLong();
    stream.Write(std::move(message), size, NewNode);
  });
  for (const std::uint32_t i : submission.edges) {
    v1::Edge message = ToProto(ReadEdge(store, (*submission.edge_pool)[i].id));
    const std::size_t size = message.ByteSizeLong();
    stream.Write(std::move(message), size, NewEdge);
  }
  stream.Finish();
}

bool Fits(const PlannedSubmission& submission, const ServerLimits& limits) {
  return submission.total_bytes <= limits.max_submission_bytes &&
         submission.largest_chunk_bytes + kPushChunkEnvelopeBytes <= limits.max_frame_bytes;
}

// A node of `bytes` (encoded) fits a submission of its own under `limits`.
bool NodeFits(std::uint64_t bytes, const ServerLimits& limits) {
  return bytes + kElementOverhead <= limits.max_submission_bytes &&
         bytes + kElementOverhead + kPushChunkEnvelopeBytes <= limits.max_frame_bytes;
}

// Cuts new content into submissions of at most the limit's bytes, in the order it is given:
// paths, then nodes (each encoded as it comes), with each edge given once both its ends are
// placed; a submission's edges are encoded when it closes. An edge thus never goes before a
// submission holding one of its ends.
class Partitioner {
 public:
  Partitioner(GraphStore& store, const ServerLimits& limits,
              std::shared_ptr<const std::vector<PlannedEdge>> edge_pool, PushPlan& plan)
      : store_(store), limits_(limits), edge_pool_(std::move(edge_pool)), plan_(plan) {
    Start();
  }

  void AddPath(const Path& path) {
    v1::Path message = ToProto(path);
    const std::size_t size = message.ByteSizeLong();
    Room(size);
    stream_->Write(std::move(message), size, NewPath);
    current_.paths.push_back(path);
  }
  void AddNode(const Uuid& id, v1::Node&& message, std::size_t size) {
    Room(size);
    stream_->Write(std::move(message), size, NewNode);
    current_.nodes.push_back(id);
  }
  void AddEdge(std::uint32_t i) {
    Room((*edge_pool_)[i].bytes);
    current_.edges.push_back(i);
  }
  void Finish() { Close(); }

 private:
  void Start() {
    current_ = PlannedSubmission();
    current_.edge_pool = edge_pool_;
    tally_ = std::make_unique<ChunkTally>();
    stream_ = std::make_unique<ChunkStream>(
        [tally = tally_.get()](std::string&& chunk) { tally->Add(chunk); });
    used_ = 0;
  }
  // Makes room for an element of `size`: closes the current submission when it would pass
  // the limit (a submission always takes its first element: PlanPush holds what cannot fit).
  void Room(std::size_t size) {
    const std::uint64_t cost = size + kElementOverhead;
    if (used_ > 0 && used_ + cost > limits_.max_submission_bytes) {
      Close();
      Start();
    }
    used_ += cost;
  }
  void Close() {
    if (used_ == 0) return;
    std::sort(current_.edges.begin(), current_.edges.end());  // the pool is by UUID
    for (const std::uint32_t i : current_.edges) {
      v1::Edge message = ToProto(ReadEdge(store_, (*edge_pool_)[i].id));
      const std::size_t size = message.ByteSizeLong();
      stream_->Write(std::move(message), size, NewEdge);
    }
    stream_->Finish();
    tally_->Into(current_);
    plan_.submissions.push_back(std::move(current_));
    used_ = 0;
  }

  GraphStore& store_;
  ServerLimits limits_;
  std::shared_ptr<const std::vector<PlannedEdge>> edge_pool_;
  PushPlan& plan_;
  PlannedSubmission current_;
  std::unique_ptr<ChunkTally> tally_;
  std::unique_ptr<ChunkStream> stream_;
  std::uint64_t used_ = 0;  // bytes the current submission will take, at most
};

[[noreturn]] void ThrowGone(const Uuid& submission, const std::string& map, const char* what,
                            const Uuid& id) {
  throw Error(ErrorCode::kNotFound, "submission " + submission.ToString() + ": " + map +
                                        " no longer holds " + what + " " + id.ToString());
}

// The pending submission as recorded, encoded once for its count, bytes and digest.
PlannedSubmission PlanPending(GraphStore& store, const PendingSubmission& pending,
                              const std::vector<Path>& paths,
                              std::shared_ptr<const std::vector<PlannedEdge>> edge_pool) {
  PlannedSubmission submission;
  for (const Path& path : paths) {
    if (pending.content.paths.contains(path.id)) submission.paths.push_back(path);
  }
  for (std::size_t i = 0; i < edge_pool->size(); ++i) {
    if (pending.content.edges.contains((*edge_pool)[i].id)) {
      submission.edges.push_back(static_cast<std::uint32_t>(i));
    }
  }
  submission.edge_pool = std::move(edge_pool);
  submission.nodes.assign(pending.content.nodes.begin(), pending.content.nodes.end());
  const ElementIds found = submission.Ids();
  for (const Uuid& id : pending.content.paths) {
    if (!found.paths.contains(id)) ThrowGone(pending.id, store.uri(), "path", id);
  }
  for (const Uuid& id : pending.content.edges) {
    if (!found.edges.contains(id)) ThrowGone(pending.id, store.uri(), "edge", id);
  }
  ChunkTally tally;
  Encode(store, submission, [&tally](std::string&& chunk) { tally.Add(chunk); });
  tally.Into(submission);
  return submission;
}

// Only the edges a plan may send (not installed, not pushed: new or pending), ordered by UUID:
// the pool of them all, from map.db's `all_nodes`. Read a batch of nodes at a time, each edge
// with the batch holding its `from` node (its `to`, when map.db lacks the `from`): memory holds
// the pool, not every edge's content.
std::shared_ptr<std::vector<PlannedEdge>> ReadEdgePool(GraphStore& store,
                                                       std::vector<Uuid> all_nodes,
                                                       const SyncState& state) {
  auto edge_pool = std::make_shared<std::vector<PlannedEdge>>();
  std::sort(all_nodes.begin(), all_nodes.end());
  for (std::size_t from = 0; from < all_nodes.size(); from += kPlanEdgeBatch) {
    const std::span<const Uuid> batch(all_nodes.data() + from,
                                      std::min(kPlanEdgeBatch, all_nodes.size() - from));
    const auto in_batch = [&](const Uuid& id) {
      return std::binary_search(batch.begin(), batch.end(), id);
    };
    for (const Edge& edge : store.EdgesTouching(batch)) {
      const bool here =
          in_batch(edge.from) ||
          (!std::binary_search(all_nodes.begin(), all_nodes.end(), edge.from) && in_batch(edge.to));
      if (!here || OfKind(state.installed, 1).contains(edge.id) ||
          OfKind(state.pushed, 1).contains(edge.id)) {
        continue;
      }
      edge_pool->push_back(PlannedEdge{edge.id, edge.from, edge.to,
                                       static_cast<std::uint32_t>(ToProto(edge).ByteSizeLong())});
    }
  }
  SortById(*edge_pool);
  edge_pool->shrink_to_fit();
  return edge_pool;
}

}  // namespace

ServerLimits EffectiveLimits(const ServerLimits& said) {
  ServerLimits limits = said;
  if (limits.max_submission_bytes == 0) limits.max_submission_bytes = kDefaultMaxSubmissionBytes;
  if (limits.max_frame_bytes == 0) limits.max_frame_bytes = kMaxSyncFrameBytes;
  return limits;
}

ElementIds PlannedSubmission::Ids() const {
  ElementIds ids;
  for (const Path& path : paths) ids.paths.insert(path.id);
  ids.nodes.insert(nodes.begin(), nodes.end());
  for (const std::uint32_t i : edges) ids.edges.insert((*edge_pool)[i].id);
  return ids;
}

PushPlan PlanPush(const LocalMap& map, const ServerLimits& said) {
  PushPlan plan;
  plan.limits = EffectiveLimits(said);
  if (!std::filesystem::exists(map.map_path())) return plan;
  const std::unique_ptr<GraphStore> store = GraphStore::Open(map.map_uri());
  const SyncState& state = map.state();
  const ElementIds* pending = state.submission ? &state.submission->content : nullptr;
  // Neither on the server nor in the pending submission: what the new submissions carry.
  const auto is_new = [&](const Uuid& id, int kind) {
    return !OfKind(state.installed, kind).contains(id) &&
           !OfKind(state.pushed, kind).contains(id) &&
           (pending == nullptr || !OfKind(*pending, kind).contains(id));
  };

  // Ids of every node (no landmarks), every edge touching them and every path: what is new is
  // chosen from these; the landmarks are read a batch at a time below.
  std::vector<Uuid> all_nodes;
  std::vector<Uuid> new_nodes;
  {
    NodeFilter bare;
    bare.with_landmarks = false;
    for (const Node& node : store->ListNodes(bare)) {
      all_nodes.push_back(node.id);
      if (is_new(node.id, 0)) new_nodes.push_back(node.id);
    }
  }
  std::sort(new_nodes.begin(), new_nodes.end());
  const std::shared_ptr<std::vector<PlannedEdge>> edge_pool =
      ReadEdgePool(*store, std::move(all_nodes), state);
  std::vector<Path> paths = store->ListPaths({});
  SortById(paths);

  if (state.submission) {
    PlannedSubmission submission = PlanPending(*store, *state.submission, paths, edge_pool);
    if (!Fits(submission, plan.limits)) {
      plan.pending_does_not_fit = true;
      return plan;
    }
    plan.submissions.push_back(std::move(submission));
    plan.pending_first = true;
  }

  Partitioner parts(*store, plan.limits, edge_pool, plan);
  for (const Path& path : paths) {
    if (is_new(path.id, 2)) parts.AddPath(path);
  }
  // An edge goes once its new ends are placed (-1: held with a node it ends at; -2: pending).
  const std::vector<PlannedEdge>& pool = *edge_pool;
  std::vector<int> waiting(pool.size(), 0);
  std::unordered_map<Uuid, std::vector<std::uint32_t>> edges_at;
  for (std::uint32_t i = 0; i < pool.size(); ++i) {
    const PlannedEdge& edge = pool[i];
    if (!is_new(edge.id, 1)) {
      waiting[i] = -2;
      continue;
    }
    const Uuid ends[2] = {edge.from, edge.to};
    for (int k = 0; k < (edge.from == edge.to ? 1 : 2); ++k) {
      if (std::binary_search(new_nodes.begin(), new_nodes.end(), ends[k])) {
        ++waiting[i];
        edges_at[ends[k]].push_back(i);
      }
    }
    if (waiting[i] == 0) parts.AddEdge(i);
  }
  ForEachNode(*store, new_nodes, [&](Node&& node) {
    const Uuid id = node.id;
    v1::Node message = ToProto(std::move(node));
    const std::size_t size = message.ByteSizeLong();
    const auto at = edges_at.find(id);
    if (!NodeFits(size, plan.limits)) {
      plan.held.push_back(HeldNode{id, size});
      if (at != edges_at.end()) {
        for (const std::uint32_t i : at->second) {
          if (waiting[i] >= 0) ++plan.held_edges;
          waiting[i] = -1;
        }
      }
      return;
    }
    parts.AddNode(id, std::move(message), size);
    if (at == edges_at.end()) return;
    for (const std::uint32_t i : at->second) {
      if (waiting[i] > 0 && --waiting[i] == 0) parts.AddEdge(i);
    }
  });
  parts.Finish();
  return plan;
}

bool PlanHoldsUnder(const PushPlan& plan, const ServerLimits& said) {
  const ServerLimits limits = EffectiveLimits(said);
  for (const PlannedSubmission& submission : plan.submissions) {
    if (!Fits(submission, limits)) return false;
  }
  for (const HeldNode& node : plan.held) {
    if (NodeFits(node.bytes, limits)) return false;
  }
  return true;
}

void StreamSubmission(GraphStore& store, const PlannedSubmission& submission, std::uint32_t from,
                      const std::function<void(std::uint32_t, const std::string&)>& send) {
  ChunkTally tally;
  Encode(store, submission, [&](std::string&& chunk) {
    const std::uint32_t seq = tally.count;
    tally.Add(chunk);
    if (seq >= from) send(seq, chunk);
  });
  if (tally.count != submission.chunk_count || tally.digest.value() != submission.digest) {
    throw Error(ErrorCode::kCorrupt,
                store.uri() + " changed under a planned push: its content now encodes to " +
                    std::to_string(tally.count) + " chunks, not the " +
                    std::to_string(submission.chunk_count) + " announced, or to another digest");
  }
}

}  // namespace fleetmap::agent_internal
