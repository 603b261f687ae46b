#include "download_cache.h"

namespace fleetmap::daemon {

std::string DownloadCache::Key(RevisionNumber revision, const DownloadAsk& ask,
                               std::uint32_t protocol_version) {
  return std::to_string(revision) + "/v" + std::to_string(protocol_version) + "/" + ask.canonical;
}

DownloadCache::Entry DownloadCache::Find(const std::string& key) {
  MutexLock lock(mutex_);
  for (auto entry = entries_.begin(); entry != entries_.end(); ++entry) {
    if (entry->key == key) {
      entries_.splice(entries_.begin(), entries_, entry);
      return entries_.front().entry;
    }
  }
  return {};
}

std::uint64_t DownloadCache::BytesOf(const DownloadToSend& plan) {
  return sizeof(DownloadToSend) + plan.header.ByteSizeLong() +
         plan.plan.nodes.size() * sizeof(Uuid) + plan.plan.edges.size() * sizeof(Edge) +
         plan.plan.paths.size() * sizeof(Path);
}

void DownloadCache::Put(const std::string& key, std::shared_ptr<const EncodedDownload> download) {
  if (download->frame_bytes > max_entry_bytes_) return;
  const std::uint64_t bytes = download->frame_bytes;
  MutexLock lock(mutex_);
  Keep(key, Entry{std::move(download), nullptr}, bytes);
}

std::shared_ptr<const DownloadToSend> DownloadCache::PlanOnce(
    const std::string& key, const std::function<std::shared_ptr<const DownloadToSend>()>& make) {
  std::promise<std::shared_ptr<const DownloadToSend>> promise;
  {
    MutexLock lock(mutex_);
    for (const Kept& kept : entries_) {
      if (kept.key == key && kept.entry.plan) return kept.entry.plan;
    }
    if (const auto making = planning_.find(key); making != planning_.end()) {
      // Waits on a selection that is already running on another thread, never on one that is
      // only queued: no store thread can wait for itself.
      std::shared_future<std::shared_ptr<const DownloadToSend>> plan = making->second;
      lock.Unlock();
      return plan.get();
    }
    planning_.emplace(key, promise.get_future().share());
  }
  std::shared_ptr<const DownloadToSend> plan;
  try {
    plan = make();
  } catch (...) {
    MutexLock lock(mutex_);
    planning_.erase(key);
    promise.set_exception(std::current_exception());
    throw;
  }
  {
    MutexLock lock(mutex_);
    planning_.erase(key);
    const std::uint64_t bytes = BytesOf(*plan);
    if (bytes <= max_entry_bytes_) Keep(key, Entry{nullptr, plan}, bytes);
  }
  promise.set_value(plan);
  return plan;
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

}  // namespace fleetmap::daemon
