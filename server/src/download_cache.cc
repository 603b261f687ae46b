#include "download_cache.h"

namespace fleetmap::server {

std::string DownloadCache::Key(RevisionNumber revision, const v1::DownloadRequest& request,
                               std::uint32_t protocol_version) {
  std::string key = std::to_string(revision) + "/v" + std::to_string(protocol_version) + "/";
  request.AppendToString(&key);
  return key;
}

DownloadCache::Entry DownloadCache::Find(const std::string& key) {
  std::lock_guard lock(mutex_);
  for (auto entry = entries_.begin(); entry != entries_.end(); ++entry) {
    if (entry->key == key) {
      entries_.splice(entries_.begin(), entries_, entry);
      return entries_.front().entry;
    }
  }
  return {};
}

std::uint64_t DownloadCache::BytesOf(const DownloadPlan& plan) {
  return sizeof(DownloadPlan) + plan.header.ByteSizeLong() + plan.nodes.size() * sizeof(Uuid) +
         plan.edges.size() * sizeof(Edge) + plan.paths.size() * sizeof(Path);
}

void DownloadCache::Put(const std::string& key, std::shared_ptr<const EncodedDownload> download) {
  if (download->frame_bytes > max_entry_bytes_) return;
  const std::uint64_t bytes = download->frame_bytes;
  std::lock_guard lock(mutex_);
  Keep(key, Entry{std::move(download), nullptr}, bytes);
}

void DownloadCache::PutPlan(const std::string& key, std::shared_ptr<const DownloadPlan> plan) {
  const std::uint64_t bytes = BytesOf(*plan);
  if (bytes > max_entry_bytes_) return;
  std::lock_guard lock(mutex_);
  Keep(key, Entry{nullptr, std::move(plan)}, bytes);
}

void DownloadCache::Keep(const std::string& key, Entry entry, std::uint64_t bytes) {
  entries_.remove_if([&](const Kept& kept) { return kept.key == key; });
  entries_.push_front(Kept{key, std::move(entry), bytes});
  std::uint64_t total = 0;
  for (auto kept = entries_.begin(); kept != entries_.end();) {
    total += kept->bytes;
    if (total > max_bytes_) {
      total -= kept->bytes;
      kept = entries_.erase(kept);
    } else {
      ++kept;
    }
  }
}

}  // namespace fleetmap::server
