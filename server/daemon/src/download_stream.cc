#include "download_stream.h"

#include <algorithm>
#include <unordered_set>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/proto_convert.h"
#include "fleetmap/map.pb.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::daemon {
namespace {

// Node batches stay within these counts whatever the mean size says: at least one node, and
// not so many bare ids that one GetNodes call is a long stall of its own.
constexpr std::size_t kMaxNodesPerBatch = 16'384;
// A node's encoding beyond its landmarks (pose, stamps, ids, camera), roughly.
constexpr std::size_t kNodeOverheadBytes = 256;
// Positions a route may have: a 10 km drive at a metre apart.
constexpr int kMaxRoutePositions = 10'000;
// Edges and paths are small (about 100 bytes encoded): this many make a batch of a few MB.
constexpr std::size_t kSmallElementsPerBatch = 32'768;

// The selection at one revision, bare: ids of what it holds.
struct BareSelection {
  std::vector<Path> paths;  // by start then id
  std::vector<Uuid> nodes;  // by stamp then id
  std::vector<Edge> edges;  // by id
  DownloadReport report;
};

// Repository::SelectForDownload's choice at `revision`, without keeping a landmark.
BareSelection SelectBare(Repository& repository, const DownloadPolicy& policy,
                         RevisionNumber revision) {
  VersionStore& versions = repository.versions();
  // SelectDownload weighs nodes by their blobs; without a budget it needs none.
  const bool weigh = policy.budget_bytes.has_value();
  std::vector<Node> nodes = versions.NodesAt(revision, weigh);
  std::vector<Edge> edges = versions.EdgesAt(revision);
  std::vector<Path> paths = versions.PathsAt(revision);
  const DownloadSelection selection = SelectDownload(nodes, edges, paths, policy);
  BareSelection bare;
  bare.report = selection.report;
  const std::unordered_set<Uuid> keep(selection.nodes.begin(), selection.nodes.end());
  bare.nodes.reserve(selection.nodes.size());
  for (const Node& node : nodes) {  // NodesAt's order: by stamp, then id
    if (keep.contains(node.id)) bare.nodes.push_back(node.id);
  }
  nodes = {};  // with a budget, the whole map's landmarks: let them go now
  const std::unordered_set<Uuid> keep_edges(selection.edges.begin(), selection.edges.end());
  for (Edge& edge : edges) {
    if (keep_edges.contains(edge.id)) bare.edges.push_back(std::move(edge));
  }
  // The path edges contracted over the nodes left out (subset_contraction.h) join them by id.
  if (!selection.derived_edges.empty()) {
    bare.edges.insert(bare.edges.end(), selection.derived_edges.begin(),
                      selection.derived_edges.end());
    std::sort(bare.edges.begin(), bare.edges.end(),
              [](const Edge& a, const Edge& b) { return a.id < b.id; });
  }
  const std::unordered_set<Uuid> keep_paths(selection.paths.begin(), selection.paths.end());
  for (Path& path : paths) {
    if (keep_paths.contains(path.id)) bare.paths.push_back(std::move(path));
  }
  return bare;
}

std::unordered_set<Uuid> IdSet(const std::vector<Uuid>& ids) {
  return std::unordered_set<Uuid>(ids.begin(), ids.end());
}

template <typename Element>
std::unordered_set<Uuid> IdSet(const std::vector<Element>& elements) {
  std::unordered_set<Uuid> ids;
  ids.reserve(elements.size());
  for (const Element& element : elements) ids.insert(element.id);
  return ids;
}

const Uuid& IdOf(const Uuid& id) {
  return id;
}
template <typename Element>
const Uuid& IdOf(const Element& element) {
  return element.id;
}

// The elements of `head` whose id is not in `base`, in their order.
template <typename Element>
std::vector<Element> NotIn(std::vector<Element>& head, const std::unordered_set<Uuid>& base) {
  std::vector<Element> kept;
  for (Element& element : head) {
    if (!base.contains(IdOf(element))) kept.push_back(std::move(element));
  }
  return kept;
}

// Ids in `base` and not in `head`, as 16-byte strings, ascending.
template <typename Element>
void AddRemoved(const std::vector<Element>& base, const std::unordered_set<Uuid>& head,
                google::protobuf::RepeatedPtrField<std::string>* removed) {
  std::vector<Uuid> ids;
  for (const Element& element : base) {
    if (!head.contains(IdOf(element))) ids.push_back(IdOf(element));
  }
  std::sort(ids.begin(), ids.end());
  for (const Uuid& id : ids) *removed->Add() = id.ToBytesString();
}

// Up to kSmallElementsPerBatch of `all` (paths or edges) from `next` on; `next` moves past them.
template <typename Element>
std::vector<Element> NextSlice(const std::vector<Element>& all, std::size_t& next) {
  const std::size_t end = std::min(all.size(), next + kSmallElementsPerBatch);
  std::vector<Element> slice(all.begin() + static_cast<std::ptrdiff_t>(next),
                             all.begin() + static_cast<std::ptrdiff_t>(end));
  next = end;
  return slice;
}

// SelectionDigest of what `base` holds and `now` does not: the removed nodes read with their
// landmarks (hidden elements stay stored), edges (derived ones too) and paths as selected.
std::uint64_t RemovedDigest(Repository& repository, const BareSelection& base,
                            const BareSelection& now) {
  SelectionDigest digest;
  const std::unordered_set<Uuid> nodes_now = IdSet(now.nodes);
  std::vector<Uuid> removed_nodes;
  for (const Uuid& id : base.nodes) {
    if (!nodes_now.contains(id)) removed_nodes.push_back(id);
  }
  for (const Node& node : repository.store().GetNodes(removed_nodes)) digest.Add(node);
  const std::unordered_set<Uuid> edges_now = IdSet(now.edges);
  for (const Edge& edge : base.edges) {
    if (!edges_now.contains(edge.id)) digest.Add(edge);
  }
  const std::unordered_set<Uuid> paths_now = IdSet(now.paths);
  for (const Path& path : base.paths) {
    if (!paths_now.contains(path.id)) digest.Add(path);
  }
  return digest.value();
}

std::string FrameOf(const v1::SyncFrame& frame) {
  return EncodeSyncFrame(frame);
}

}  // namespace

DownloadPolicy PolicyOfRequest(const v1::DownloadRequest& request) {
  DownloadPolicy policy = ParseDownloadPolicy(request.policy());
  policy.mission_start_min = request.mission_start_min();
  if (request.window_min() > 0) policy.window_min = request.window_min();
  if (request.best_percent() > 0) policy.best_percent = request.best_percent();
  if (request.epoch_min() > 0) policy.epoch_min = request.epoch_min();
  if (request.budget_bytes() > 0 && policy.budget_bytes) {
    policy.budget_bytes = request.budget_bytes();
  }
  for (const std::string& node : request.include_nodes()) {
    policy.include.push_back(Uuid::FromBytes(node));
  }
  // The route (issue 38 item 3), when the request gives one.
  const bool has_route = !request.route_outing().empty() || !request.route_anchor().empty() ||
                         request.route_xyz_size() > 0;
  if (has_route) {
    DownloadRoute& route = policy.route ? *policy.route : policy.route.emplace();
    for (const std::string* id : {&request.route_outing(), &request.route_anchor()}) {
      if (!id->empty() && id->size() != Uuid::kSize) {
        throw Error(ErrorCode::kInvalidArgument, "route: a node or outing id of " +
                                                     std::to_string(id->size()) +
                                                     " bytes (ids are 16 bytes)");
      }
    }
    if (!request.route_outing().empty()) route.outing = Uuid::FromBytes(request.route_outing());
    if (!request.route_anchor().empty()) route.anchor = Uuid::FromBytes(request.route_anchor());
    // An authenticated robot still gets a bounded amount of the server's work per request.
    if (request.route_xyz_size() > 3 * kMaxRoutePositions) {
      throw Error(ErrorCode::kInvalidArgument,
                  "route: " + std::to_string(request.route_xyz_size() / 3) +
                      " positions, over this server's " + std::to_string(kMaxRoutePositions));
    }
    if (request.route_xyz_size() % 3 != 0) {
      throw Error(ErrorCode::kInvalidArgument,
                  "route: " + std::to_string(request.route_xyz_size()) +
                      " coordinates, not a whole number of x y z positions");
    }
    for (int i = 0; i + 2 < request.route_xyz_size(); i += 3) {
      route.anchor_p_m.emplace_back(request.route_xyz(i), request.route_xyz(i + 1),
                                    request.route_xyz(i + 2));
    }
    if (request.route_radius_m() > 0) route.radius_m = request.route_radius_m();
  }
  ValidateDownloadPolicy(policy);
  ValidateChannelName(ChannelOfRequest(request));
  return policy;
}

std::string ChannelOfRequest(const v1::DownloadRequest& request) {
  return request.channel().empty() ? std::string(kHeadChannel) : request.channel();
}

std::shared_ptr<const DownloadPlan> PlanDownload(Repository& repository,
                                                 const v1::DownloadRequest& request,
                                                 RevisionNumber head,
                                                 std::uint32_t protocol_version) {
  DownloadPolicy policy = PolicyOfRequest(request);
  policy.contract = protocol_version >= kFirstContractingSyncProtocolVersion;
  BareSelection selection = SelectBare(repository, policy, head);
  auto plan = std::make_shared<DownloadPlan>();
  plan->report = selection.report;
  const StoreStats stats = repository.versions().StatsAt(head);
  plan->report.map_bytes = stats.landmark_bytes;
  plan->report.bytes = 0;  // the landmark bytes sent, counted as they are read (DownloadEncoder)
  plan->mean_node_bytes = stats.nodes > 0 ? stats.landmark_bytes / stats.nodes : 0;

  v1::DownloadHeader& header = plan->header;
  header.set_revision(head);
  header.set_channel(ChannelOfRequest(request));
  header.set_route_length_m(selection.report.route_length_m);
  header.set_route_covered_m(selection.report.route_covered_m);
  header.set_nodes(selection.nodes.size());
  header.set_edges(selection.edges.size());
  header.set_paths(selection.paths.size());
  header.set_components_before(selection.report.integrity.fragments_before);
  header.set_components_after(selection.report.integrity.components_after);

  const std::int64_t base = request.base_revision();
  if (base > 0 && base <= head) {
    header.set_base_revision(base);
    const BareSelection at_base = SelectBare(repository, policy, base);
    AddRemoved(at_base.nodes, IdSet(selection.nodes), header.mutable_removed_nodes());
    AddRemoved(at_base.edges, IdSet(selection.edges), header.mutable_removed_edges());
    AddRemoved(at_base.paths, IdSet(selection.paths), header.mutable_removed_paths());
    plan->removed_digest = RemovedDigest(repository, at_base, selection);
    plan->nodes = NotIn(selection.nodes, IdSet(at_base.nodes));
    plan->edges = NotIn(selection.edges, IdSet(at_base.edges));
    plan->paths = NotIn(selection.paths, IdSet(at_base.paths));
  } else {
    plan->nodes = std::move(selection.nodes);
    plan->edges = std::move(selection.edges);
    plan->paths = std::move(selection.paths);
  }
  return plan;
}

DownloadEncoder::DownloadEncoder(std::shared_ptr<const DownloadPlan> plan, std::size_t batch_bytes)
    : plan_(std::move(plan)), batch_bytes_(std::max<std::size_t>(batch_bytes, 1)) {
  const std::size_t mean =
      static_cast<std::size_t>(std::max<std::int64_t>(plan_->mean_node_bytes, 1));
  nodes_per_batch_ = std::clamp<std::size_t>(batch_bytes_ / mean, 1, kMaxNodesPerBatch);
  digest_known_ = plan_->whole_sent_digest_known.load(std::memory_order_acquire);
}

std::uint64_t DownloadEncoder::sent_digest() const {
  return digest_known_ ? plan_->whole_sent_digest.load(std::memory_order_relaxed)
                       : sent_digest_.value();
}

void DownloadEncoder::Encode(GraphBatch map, std::vector<std::string>& frames) {
  if (!digest_known_) sent_digest_.Add(map);  // before the chunks take the landmarks
  // EncodeMapChunks's chunks (the same elements, order and cuts), but each serialised straight
  // into its frame: a chunk's bytes are written once, not into a string and then into a frame
  // (issue 39 item 3: a pull shares its two cores with the server).
  v1::MapChunk chunk;
  std::size_t chunk_bytes = 0;
  bool flushed = false;
  const auto flush = [&] {
    DownloadChunkFrame frame = EncodeDownloadChunkFrame(chunks_++, chunk);
    digest_.Add(frame.data());
    bytes_ += frame.data_size;
    frames.push_back(std::move(frame.bytes));
    chunk.Clear();
    chunk_bytes = 0;
    flushed = true;
  };
  const auto write = [&](auto& elements, auto add) {
    for (auto& element : elements) {
      auto message = ToProto(std::move(element));  // a node's landmarks move, not copied
      const std::size_t size = message.ByteSizeLong();
      if (chunk_bytes > 0 && chunk_bytes + size > kDefaultMapChunkBytes) flush();
      *add(chunk) = std::move(message);
      chunk_bytes += size + 8;  // field tag and length prefix, roughly (as EncodeMapChunks)
    }
  };
  write(map.paths, [](v1::MapChunk& c) { return c.add_paths(); });
  write(map.nodes, [](v1::MapChunk& c) { return c.add_nodes(); });
  write(map.edges, [](v1::MapChunk& c) { return c.add_edges(); });
  write(map.annotations, [](v1::MapChunk& c) { return c.add_annotations(); });
  if (chunk_bytes > 0 || !flushed) flush();  // an empty map is one empty chunk
}

std::vector<std::string> DownloadEncoder::NextBatch(Repository& repository) {
  std::vector<std::string> frames;
  const DownloadPlan& plan = *plan_;
  while (frames.empty() && stage_ != Stage::kDone) {
    switch (stage_) {
      case Stage::kPaths: {
        if (next_ < plan.paths.size()) {
          GraphBatch map;
          map.paths = NextSlice(plan.paths, next_);
          Encode(std::move(map), frames);
        } else {
          stage_ = Stage::kNodes;
          next_ = 0;
        }
        break;
      }
      case Stage::kNodes: {
        if (next_ < plan.nodes.size()) {
          const std::size_t end = std::min(plan.nodes.size(), next_ + nodes_per_batch_);
          std::vector<Node> nodes = repository.store().GetNodes(
              std::span<const Uuid>(plan.nodes.data() + next_, plan.nodes.data() + end));
          // Encoded about a chunk's worth of nodes at a time, each group's landmarks freed as
          // soon as its frames exist: a batch is in memory about twice (nodes, frames), not
          // three times (nodes, chunks, frames).
          GraphBatch group;
          std::size_t group_bytes = 0;
          for (Node& node : nodes) {
            landmark_bytes_ += static_cast<std::int64_t>(node.landmarks_blob.size());
            group_bytes += node.landmarks_blob.size() + kNodeOverheadBytes;
            group.nodes.push_back(std::move(node));
            if (group_bytes >= kDefaultMapChunkBytes) {
              Encode(std::move(group), frames);
              group = GraphBatch{};
              group_bytes = 0;
            }
          }
          if (!group.nodes.empty()) Encode(std::move(group), frames);
          next_ = end;
        } else {
          stage_ = Stage::kEdges;
          next_ = 0;
        }
        break;
      }
      case Stage::kEdges: {
        if (next_ < plan.edges.size()) {
          GraphBatch map;
          map.edges = NextSlice(plan.edges, next_);
          Encode(std::move(map), frames);
        } else {
          stage_ = Stage::kDone;
          // A download with nothing in it is still one (empty) chunk, as EncodeMapChunks gives
          // an empty map: every download has content to digest.
          if (chunks_ == 0) Encode(GraphBatch{}, frames);
        }
        break;
      }
      case Stage::kDone:
        break;
    }
  }
  if (frames.empty() && !done_) {
    done_ = true;
    if (!digest_known_) {  // the whole plan was digested: the next encoders need not
      plan_->whole_sent_digest.store(sent_digest_.value(), std::memory_order_relaxed);
      plan_->whole_sent_digest_known.store(true, std::memory_order_release);
    }
  }
  return frames;
}

v1::DownloadEnd DownloadEncoder::End() const {
  v1::DownloadEnd end;
  end.set_chunk_count(chunks_);
  end.set_total_bytes(bytes_);
  end.set_digest(digest_.value());
  return end;
}

std::string HeaderFrame(const v1::DownloadHeader& header) {
  v1::SyncFrame frame;
  *frame.mutable_download_header() = header;
  return FrameOf(frame);
}

std::string EndFrame(const v1::DownloadEnd& end) {
  v1::SyncFrame frame;
  *frame.mutable_download_end() = end;
  return FrameOf(frame);
}

std::shared_ptr<const EncodedDownload> EncodeDownload(Repository& repository,
                                                      const v1::DownloadRequest& request,
                                                      RevisionNumber head,
                                                      std::uint32_t protocol_version) {
  DownloadEncoder encoder(PlanDownload(repository, request, head, protocol_version));
  std::vector<std::string> chunks;
  for (std::vector<std::string> batch = encoder.NextBatch(repository); !batch.empty();
       batch = encoder.NextBatch(repository)) {
    for (std::string& frame : batch) chunks.push_back(std::move(frame));
  }
  auto encoded = std::make_shared<EncodedDownload>();
  encoded->protocol_version = protocol_version;
  encoded->header = encoder.plan().header;
  encoded->end = encoder.End();
  encoded->report = encoder.plan().report;
  encoded->removed_digest = encoder.plan().removed_digest;
  encoded->report.bytes += encoder.landmark_bytes();
  encoded->sent_digest = encoder.sent_digest();
  v1::DownloadEnd sent_end = encoded->end;
  if (protocol_version < 3) {
    encoded->header.set_chunk_count(encoded->end.chunk_count());
    encoded->header.set_total_bytes(encoded->end.total_bytes());
    encoded->header.set_digest(encoded->end.digest());
    sent_end.Clear();
  }
  encoded->frames.reserve(chunks.size() + 2);
  encoded->frames.push_back(HeaderFrame(encoded->header));
  for (std::string& frame : chunks) encoded->frames.push_back(std::move(frame));
  encoded->frames.push_back(EndFrame(sent_end));
  for (const std::string& bytes : encoded->frames) encoded->frame_bytes += bytes.size();
  return encoded;
}

}  // namespace fleetmap::daemon
