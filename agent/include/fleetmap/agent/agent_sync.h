// One sync of a robot with fleetmapd (seed 004 §V; the exchanges in docs/sync-protocol.md and
// fleetmap/protocol/*.h; src/sync_run.h runs them as named steps):
//
//   plan      before the connect (a large backlog read after the hello let the server's frame
//             timeout close the session): what the server lacks, read from map.db a
//             batch of nodes at a time and cut into submissions that fit the server's limits
//             as its last welcome said them (src/push_plan.h); a node over
//             them on its own is held: kept in map.db unpushed, reported, tried every sync
//   connect, Hello (protocol version, robot id, token); Welcome (the server's limits: when the
//             plan does not fit them, or they would take a held node, plan again and reconnect,
//             once)
//   push      each planned submission under a new v7 UUID, recorded in the map's state before
//             its first byte, so a retry after a dropped link sends the same content under the
//             same id and resumes at PushReady.next_chunk; its chunks are encoded again as
//             they are sent; skipped when nothing is unsynced. A submission left pending by an
//             earlier run goes first, then whatever is new since. The server merges a robot's
//             submissions in order, so edges between them join up.
//   merge     MergeStatusRequest for each accepted submission whose merge no download has
//             reflected yet (LocalMap: unmerged): a glance (wait_ms 0), or with wait_merge
//             repeated until merged or failed or merge_timeout passes (then the download goes
//             ahead without it). The install keeps the content of those not merged by the
//             downloaded revision, so the robot never drops what it just built.
//   download  DownloadRequest with base_revision = the installed revision when the parameters
//             are those of the installed download, else 0 (full); header, chunks, end
//             (protocol version 3: the end carries the chunk count, bytes and digest, checked
//             against what arrived; the counts are checked at the install). A full download is
//             written into the next map as its chunks arrive (LocalMap::BeginInstall, on a
//             writer thread beside the link), so download_seconds includes that writing
//   install   MapInstallation::Commit for a full download, LocalMap::Install for changes
//             (after the link is closed); nothing is installed unless the end matched
//
// Retries: a failure of the link (refused, reset, timed out) or a server's SHUTTING_DOWN,
// INTERNAL or TIMEOUT restarts the sync from the connect after a backoff (first_backoff
// doubling to max_backoff, each with ±25 % jitter), until retry_for has passed since the first
// failure; what was done before (a push accepted) is not redone. Any other refusal
// (BAD_TOKEN, UNKNOWN_ROBOT, UNSUPPORTED_VERSION, INVALID, CONFLICT, ...) is thrown at once.
//
// Threading: blocking; one sync of a LocalMap at a time.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/agent/sync_client.h"

namespace fleetmap {

struct AgentSyncOptions {
  // HOST:PORT, or several separated by commas (fleetmapd instances sharing one store): each
  // retry goes to the next one, so a robot whose server died syncs through another.
  std::string server;
  Uuid robot;
  std::string token;
  std::string author = "fleetmap-agent";  // recorded with each submission
  SyncLinkOptions link;
  DownloadParams download;
  bool wait_merge = false;
  // Read every installed landmark byte back before the hello (LocalMap::CheckInstalledDigest),
  // not only what the map holds of the selection: a map damaged in place shows too.
  bool verify_map = false;
  std::chrono::milliseconds merge_timeout{300'000};
  // The longest one MergeStatusRequest asks the server to wait (it may cap it lower).
  std::chrono::milliseconds merge_poll{10'000};
  // For the DownloadHeader, which the server sends after choosing the selection.
  std::chrono::milliseconds download_timeout{300'000};
  std::chrono::milliseconds retry_for{120'000};
  std::chrono::milliseconds first_backoff{200};
  std::chrono::milliseconds max_backoff{5'000};
  // One line per step (pushing chunk k/n, waiting for merge, downloading k/n, installed ...);
  // null: silent.
  std::function<void(const std::string&)> progress;
  // Raised: abandon the sync (SyncStopped); the map is left as the last completed step left it.
  const std::atomic<bool>* stop = nullptr;
};

struct SyncResult {
  // Push (all submissions of this sync; `submission` is the last one, nil when none).
  std::size_t submissions = 0;  // accepted in this sync
  std::size_t pushed_nodes = 0;
  std::size_t pushed_edges = 0;
  std::size_t pushed_paths = 0;
  Uuid submission;
  std::string push_state;  // PushAccepted.state of the last submission: queued, merged, failed
  // Held: nodes over the server's limits on their own, kept in the map unpushed, and the
  // unsynced edges to them.
  std::size_t held_nodes = 0;
  std::size_t held_edges = 0;
  std::uint64_t held_bytes = 0;
  // The merge of `submission`: merged, failed, or its state when asked (queued, merging);
  // "" when nothing was pushed.
  std::string merge_state;
  std::int64_t merged_revision = 0;
  std::string merge_error;
  // Download and install.
  std::int64_t revision = 0;
  bool incremental = false;
  std::size_t nodes = 0;  // the installed selection
  std::size_t edges = 0;
  std::size_t paths = 0;
  std::size_t downloaded_nodes = 0;  // in the chunks received
  std::size_t downloaded_edges = 0;
  std::size_t downloaded_paths = 0;
  std::size_t removed_nodes = 0;       // incremental: dropped from the selection
  std::uint64_t downloaded_bytes = 0;  // chunk bytes
  // With a route (--route): its length and the length of it with a downloaded node within 5 m,
  // as the server measured them in the map's layout.
  double route_length_m = 0.0;
  double route_covered_m = 0.0;
  std::size_t kept_unsynced = 0;  // local elements kept through the install
  std::size_t kept_unmerged = 0;  // pushed elements kept: their merge is not in the download
  std::size_t kept_failed = 0;    // of those, elements of submissions the server refused (kept
                                  // until `fleetmap-agent discard`)
  // A map that started over (map.db or sync.json lost): the robot's own submissions the
  // installed revision lacks, written back into map.db from the server.
  std::size_t restored_submissions = 0;
  std::size_t restored_elements = 0;
  // The link, over every attempt.
  std::uint64_t bytes_sent = 0;
  std::uint64_t bytes_received = 0;
  int retries = 0;
  std::string last_retry_reason;
  double prepare_seconds = 0.0;  // planning the push, before the connect
  double push_seconds = 0.0;
  double merge_wait_seconds = 0.0;
  double download_seconds = 0.0;
  double install_seconds = 0.0;
  double seconds = 0.0;
};

// Runs one sync (see the file comment). Throws SyncServerError for a refusal that is not
// retried, SyncStopped, SyncLinkError (or a retryable SyncServerError) when retries ran out,
// Error(kCorrupt) when the server broke the exchange or sent a download that does not check,
// and what LocalMap throws.
SyncResult RunSync(LocalMap& map, const AgentSyncOptions& options);

}  // namespace fleetmap
