#include "download_stream.h"

#include <algorithm>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/core/proto_convert.h"
#include "fleetmap/map.pb.h"
#include "fleetmap/protocol/download_exchange.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::daemon {
namespace {

// Node batches stay within these counts whatever the mean size says: at least one node, and
// not so many bare ids that one GetNodes call is a long stall of its own.
constexpr std::size_t kMaxNodesPerBatch = 16'384;
// A node's encoding beyond its landmarks (pose, stamps, ids, camera), roughly.
constexpr std::size_t kNodeOverheadBytes = 256;
// Edges and paths are small (about 100 bytes encoded): this many make a batch of a few MB.
constexpr std::size_t kSmallElementsPerBatch = 32'768;

// Up to kSmallElementsPerBatch of `all` (paths or edges) from `next` on; `next` moves past them.
template <typename Element>
std::vector<Element> NextSlice(const std::vector<Element>& all, std::size_t& next) {
  const std::size_t end = std::min(all.size(), next + kSmallElementsPerBatch);
  std::vector<Element> slice(all.begin() + static_cast<std::ptrdiff_t>(next),
                             all.begin() + static_cast<std::ptrdiff_t>(end));
  next = end;
  return slice;
}

void AddIds(const std::vector<Uuid>& ids, google::protobuf::RepeatedPtrField<std::string>* to) {
  for (const Uuid& id : ids) *to->Add() = id.ToBytesString();
}

}  // namespace

std::shared_ptr<const DownloadToSend> PlanDownloadToSend(Repository& repository,
                                                         DownloadPolicy policy,
                                                         const std::string& channel,
                                                         RevisionNumber head, RevisionNumber base,
                                                         std::uint32_t protocol_version) {
  policy.contract = protocol_version >= kFirstContractingSyncProtocolVersion;
  auto download = std::make_shared<DownloadToSend>();
  download->plan = repository.PlanDownload(policy, head, base);
  const DownloadPlan& plan = download->plan;
  v1::DownloadHeader& header = download->header;
  header.set_revision(head);
  header.set_channel(channel);
  header.set_route_length_m(plan.report.route_length_m);
  header.set_route_covered_m(plan.report.route_covered_m);
  header.set_nodes(plan.selected_nodes);
  header.set_edges(plan.selected_edges);
  header.set_paths(plan.selected_paths);
  header.set_components_before(plan.report.integrity.fragments_before);
  header.set_components_after(plan.report.integrity.components_after);
  if (plan.base_revision != 0) {
    header.set_base_revision(plan.base_revision);
    AddIds(plan.removed_nodes, header.mutable_removed_nodes());
    AddIds(plan.removed_edges, header.mutable_removed_edges());
    AddIds(plan.removed_paths, header.mutable_removed_paths());
  }
  return download;
}

DownloadEncoder::DownloadEncoder(std::shared_ptr<const DownloadToSend> download,
                                 std::size_t batch_bytes)
    : download_(std::move(download)), batch_bytes_(std::max<std::size_t>(batch_bytes, 1)) {
  const std::size_t mean =
      static_cast<std::size_t>(std::max<std::int64_t>(download_->plan.mean_node_bytes, 1));
  nodes_per_batch_ = std::clamp<std::size_t>(batch_bytes_ / mean, 1, kMaxNodesPerBatch);
  digest_known_ = download_->whole_sent_digest_known.load(std::memory_order_acquire);
}

std::uint64_t DownloadEncoder::sent_digest() const {
  return digest_known_ ? download_->whole_sent_digest.load(std::memory_order_relaxed)
                       : sent_digest_.value();
}

void DownloadEncoder::Encode(GraphBatch map, std::vector<std::string>& frames) {
  if (!digest_known_) sent_digest_.Add(map);  // before the chunks take the landmarks
  // EncodeMapChunks's chunks (the same elements, order and cuts), but each serialised straight
  // into its frame: a chunk's bytes are written once, not into a string and then into a frame
  // (a pull shares its two cores with the server).
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

void DownloadEncoder::EncodeNodes(Repository& repository, std::vector<std::string>& frames) {
  const DownloadPlan& plan = download_->plan;
  const std::size_t end = std::min(plan.nodes.size(), next_ + nodes_per_batch_);
  std::vector<Node> nodes = repository.ReadNodes(
      std::span<const Uuid>(plan.nodes.data() + next_, plan.nodes.data() + end));
  // Encoded about a chunk's worth of nodes at a time, each group's landmarks freed as soon as
  // its frames exist: a batch is in memory about twice (nodes, frames), not three times (nodes,
  // chunks, frames).
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
}

std::vector<std::string> DownloadEncoder::NextBatch(Repository& repository) {
  std::vector<std::string> frames;
  const DownloadPlan& plan = download_->plan;
  while (frames.empty() && stage_ != Stage::kDone) {
    switch (stage_) {
      case Stage::kPaths:
        if (next_ < plan.paths.size()) {
          GraphBatch map;
          map.paths = NextSlice(plan.paths, next_);
          Encode(std::move(map), frames);
        } else {
          stage_ = Stage::kNodes;
          next_ = 0;
        }
        break;
      case Stage::kNodes:
        if (next_ < plan.nodes.size()) {
          EncodeNodes(repository, frames);
        } else {
          stage_ = Stage::kEdges;
          next_ = 0;
        }
        break;
      case Stage::kEdges:
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
      case Stage::kDone:
        break;
    }
  }
  if (frames.empty() && !done_) {
    done_ = true;
    if (!digest_known_) {  // the whole plan was digested: the next encoders need not
      download_->whole_sent_digest.store(sent_digest_.value(), std::memory_order_relaxed);
      download_->whole_sent_digest_known.store(true, std::memory_order_release);
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

std::shared_ptr<const EncodedDownload> EncodeDownload(
    Repository& repository, std::shared_ptr<const DownloadToSend> download,
    std::uint32_t protocol_version) {
  DownloadEncoder encoder(std::move(download));
  std::vector<std::string> chunks;
  for (std::vector<std::string> batch = encoder.NextBatch(repository); !batch.empty();
       batch = encoder.NextBatch(repository)) {
    for (std::string& frame : batch) chunks.push_back(std::move(frame));
  }
  auto encoded = std::make_shared<EncodedDownload>();
  encoded->protocol_version = protocol_version;
  encoded->header = encoder.download().header;
  encoded->end = encoder.End();
  encoded->report = encoder.download().plan.report;
  encoded->removed_digest = encoder.download().plan.removed_digest;
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
  encoded->frames.push_back(DownloadHeaderFrameBytes(encoded->header));
  for (std::string& frame : chunks) encoded->frames.push_back(std::move(frame));
  encoded->frames.push_back(DownloadEndFrameBytes(sent_end));
  for (const std::string& bytes : encoded->frames) encoded->frame_bytes += bytes.size();
  return encoded;
}

}  // namespace fleetmap::daemon
