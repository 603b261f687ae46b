#include "download_stream.h"

#include <algorithm>
#include <unordered_set>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::server {
namespace {

template <typename Element>
std::unordered_set<Uuid> IdsOf(const std::vector<Element>& elements) {
  std::unordered_set<Uuid> ids;
  ids.reserve(elements.size());
  for (const Element& element : elements) ids.insert(element.id);
  return ids;
}

// The elements of `head` whose id is not in `base`.
template <typename Element>
std::vector<Element> NotIn(std::vector<Element>& head, const std::unordered_set<Uuid>& base) {
  std::vector<Element> kept;
  for (Element& element : head) {
    if (!base.contains(element.id)) kept.push_back(std::move(element));
  }
  return kept;
}

// Ids in `base` and not in `head`, as 16-byte strings, ascending.
template <typename Element>
void AddRemoved(const std::vector<Element>& base, const std::unordered_set<Uuid>& head,
                google::protobuf::RepeatedPtrField<std::string>* removed) {
  std::vector<Uuid> ids;
  for (const Element& element : base) {
    if (!head.contains(element.id)) ids.push_back(element.id);
  }
  std::sort(ids.begin(), ids.end());
  for (const Uuid& id : ids) *removed->Add() = id.ToBytesString();
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
  ValidateDownloadPolicy(policy);
  return policy;
}

std::shared_ptr<const EncodedDownload> EncodeDownload(Repository& repository,
                                                      const v1::DownloadRequest& request,
                                                      RevisionNumber head) {
  const DownloadPolicy policy = PolicyOfRequest(request);
  Download download = repository.SelectForDownload(policy, head);
  auto encoded = std::make_shared<EncodedDownload>();
  encoded->report = download.report;
  v1::DownloadHeader& header = encoded->header;
  header.set_revision(download.revision);
  header.set_nodes(download.map.nodes.size());
  header.set_edges(download.map.edges.size());
  header.set_paths(download.map.paths.size());
  header.set_components_before(download.report.integrity.fragments_before);
  header.set_components_after(download.report.integrity.components_after);

  GraphBatch send;
  const std::int64_t base = request.base_revision();
  if (base > 0 && base <= head) {
    header.set_base_revision(base);
    const Download at_base = repository.SelectForDownload(policy, base);
    const auto head_nodes = IdsOf(download.map.nodes);
    const auto head_edges = IdsOf(download.map.edges);
    const auto head_paths = IdsOf(download.map.paths);
    AddRemoved(at_base.map.nodes, head_nodes, header.mutable_removed_nodes());
    AddRemoved(at_base.map.edges, head_edges, header.mutable_removed_edges());
    AddRemoved(at_base.map.paths, head_paths, header.mutable_removed_paths());
    send.nodes = NotIn(download.map.nodes, IdsOf(at_base.map.nodes));
    send.edges = NotIn(download.map.edges, IdsOf(at_base.map.edges));
    send.paths = NotIn(download.map.paths, IdsOf(at_base.map.paths));
  } else {
    send = std::move(download.map);
  }

  std::vector<std::string> chunks = EncodeMapChunks(send);
  send = {};
  header.set_chunk_count(static_cast<std::uint32_t>(chunks.size()));
  header.set_digest(DigestOfChunks(chunks));
  std::uint64_t total = 0;
  for (const std::string& chunk : chunks) total += chunk.size();
  header.set_total_bytes(total);

  v1::SyncFrame frame;
  *frame.mutable_download_header() = header;
  encoded->frames.reserve(chunks.size() + 2);
  encoded->frames.push_back(EncodeSyncFrame(frame));
  for (std::size_t seq = 0; seq < chunks.size(); ++seq) {
    v1::SyncFrame chunk_frame;
    chunk_frame.mutable_download_chunk()->set_seq(static_cast<std::uint32_t>(seq));
    chunk_frame.mutable_download_chunk()->set_data(std::move(chunks[seq]));
    encoded->frames.push_back(EncodeSyncFrame(chunk_frame));
    chunks[seq] = std::string();  // moved-from: make sure its memory goes now
  }
  v1::SyncFrame end;
  end.mutable_download_end();
  encoded->frames.push_back(EncodeSyncFrame(end));
  for (const std::string& bytes : encoded->frames) encoded->frame_bytes += bytes.size();
  return encoded;
}

}  // namespace fleetmap::server
