// fleetmapd's sync server (docs/sync-protocol.md; proto/fleetmap/sync.proto): robots
// connect over TCP (optionally TLS 1.2+), say Hello with their token, push submissions in
// chunks, ask how their merge went, and download a policy's selection of the map.
//
// Inside: io threads run the sessions (one per connection, each on its own strand, never
// blocking on the store); a few store threads, each with its own connection, do the store
// calls sessions ask for; one merge thread merges the queued submissions one at a time
// (merge_queue.h). Every frame error closes only its own session, after an ErrorFrame saying
// what was wrong; nothing stored changes.
//
// Threading: construct, Start() and Stop() from one thread; Status() and bound_address() from
// any thread.
#pragma once

#include <chrono>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "fleetmap/daemon/fleet_status.h"
#include "fleetmap/repository/nightly_dream.h"
#include "fleetmap/repository/retirement.h"

namespace fleetmap {

struct SyncServerOptions {
  std::string store_uri = "sqlite:fleetmap.db";
  // HOST:PORT ([HOST]:PORT for IPv6); port 0 takes an ephemeral port (see bound_address()).
  std::string listen = "127.0.0.1:7420";
  int io_threads = 2;
  int store_threads = 2;  // store connections for sessions (plus one for merges)
  // Both set: TLS (1.2 or later) on every connection; PEM files. The key must be readable by
  // its owner only (chmod 600), as ssh requires of keys.
  std::string tls_cert_path;
  std::string tls_key_path;
  // Without TLS, a `listen` address other than loopback is refused unless this is set: robots'
  // tokens and maps would cross the network in clear. Set, it is allowed
  // with a warning in the log (a depot network trusted as a cable).
  bool allow_plaintext = false;
  // Waiting for a frame's length, reading its body (the whole body, however it trickles in),
  // writing a frame: each within this.
  std::chrono::milliseconds io_deadline{30'000};
  std::chrono::milliseconds handshake_deadline{10'000};  // the TLS handshake
  // Sessions at most. At the limit a connection that has not said hello is closed to make
  // room; when every session is past its hello, a new connection is refused (ErrorFrame BUSY).
  std::size_t max_sessions = 256;
  // A connection must deliver its hello frame (after the TLS handshake, if any) within this.
  // A real agent sends it at once; what does not is closed with TIMEOUT.
  std::chrono::milliseconds hello_deadline{5'000};
  // Connections that have not yet delivered a complete hello, from one address and in all.
  // Past either cap the OLDEST such connection is closed (BUSY), never the new one: a real
  // agent says hello within milliseconds, so a flood of idle connections pushes out its own
  // oldest, not the robots (connection_admission.h says why).
  std::size_t max_pending_hello_per_address = 32;
  std::size_t max_pending_hello = 128;
  // One robot, once authenticated, holds this many sessions at most, and this many bytes of
  // frames announced and not yet handled across them (robot_allowance.h).
  // Past either the newcomer, a session or a frame, is refused (BUSY) and the robot's other
  // sessions go on. An agent uses one session at a time; 2 frames of the 64 MiB cap in flight.
  std::size_t max_sessions_per_robot = 4;
  std::uint64_t max_inflight_bytes_per_robot = std::uint64_t{128} << 20;
  // Route downloads one robot may have queued or being planned on the store workers at once
  // (robot_allowance.h); past this its route request is refused (BUSY). Below store_threads, so
  // one robot's routes never hold every store worker.
  std::size_t max_route_plans_per_robot = 1;
  // The bytes of one submission at most, as announced at push_begin (total_bytes) and as
  // received; more is refused with INVALID. Every chunk of a submission is read back at once
  // to decode it when the push ends, so this bounds the memory of that step.
  std::uint64_t max_submission_bytes = std::uint64_t{2048} << 20;
  std::chrono::milliseconds merge_wait_cap{60'000};  // MergeStatusRequest.wait_ms at most
  std::chrono::milliseconds drain_deadline{10'000};  // Stop() waits this long for sessions
  // A test knob: each merge holds its transaction open this long before it commits.
  std::chrono::milliseconds debug_merge_delay{0};
  // A test knob: each merge waits this long after its claim, before MERGE starts.
  std::chrono::milliseconds debug_merge_pause{0};
  // How long a store call waits for a lock another writer holds before it fails (SQLite's
  // busy timeout, PostgreSQL's lock_timeout). A merge that fails so is retried, not failed.
  std::chrono::milliseconds store_busy_timeout{10'000};
  // A merge that failed transiently (store busy, disk full, connection lost) is retried after
  // merge_first_retry, doubling up to merge_max_retry, until it goes through.
  std::chrono::milliseconds merge_first_retry{500};
  std::chrono::milliseconds merge_max_retry{30'000};
  // A test knob: each pushed chunk waits this long before it is stored, so that tests can
  // SIGKILL the server in the middle of a push.
  std::chrono::milliseconds debug_chunk_delay{0};
  // This server's name among the fleetmapd sharing its store (the merge claims, metrics and
  // logs). Empty: HOSTNAME:PORT as bound, the same across a restart on the same port, so a
  // restarted server takes back at once the merge it held.
  std::string instance;
  // A merge's claim lasts this long unless renewed (every third of it while the merge runs):
  // another instance takes a submission over this long after its merger died.
  std::chrono::milliseconds merge_lease{30'000};
  // How often an idle server looks in the store for queued submissions (pushed to another
  // instance, or left by one that died) and for merges other instances finished.
  std::chrono::milliseconds merge_poll{1'000};
  // Downloads kept in memory once encoded, so the same one asked again (many robots on one
  // mission, a robot retrying) streams without touching the store: only those of at most
  // download_cache_entry_bytes each (a big map is streamed from the store every time, so the
  // server's memory stays bounded whatever the map's size), the newest first, up to
  // download_cache_bytes together.
  std::uint64_t download_cache_bytes = std::uint64_t{256} << 20;
  std::uint64_t download_cache_entry_bytes = std::uint64_t{32} << 20;
  // The status page's pictures are relaxed (fleetmap/relaxation/relaxed_layout.h) up to this many
  // nodes and composed beyond (0: always composed). The relaxation runs on a store thread: about
  // 3-4 s and little memory at 10^4 nodes, 80 s and 0.75 GB at 10^5
  // (tests/benchmarks/relaxation_benchmark.cc).
  std::size_t picture_relax_max_nodes = 10'000;
  // Whether the status page's pictures are drawn at all: only where a status page shows them
  // (fleetmapd --http). Each is drawn when the head moves, on a store thread beside the copy's
  // plan, and holds the map's layout, SVG and facts of every node while it is drawn: a server
  // without a page neither spends that CPU on each merge nor adds that peak to its memory.
  bool draw_status_pictures = false;
  // A streamed download is read, encoded and written about this many bytes at a time (two such
  // batches in memory per download at most).
  std::size_t download_batch_bytes = std::size_t{4} << 20;
  // The nightly dream (nightly_dream.h): run daily at this UTC second of the day (0 to 86399;
  // fleetmapd --dream-at, read by ParseDailyTime), on a store connection of its own. None: never.
  std::optional<int> dream_at_second;
  NightlyDreamOptions dream;
  // Retirement (retirement.h) on schedule, on a store connection of its own: nodes unused for
  // retire->retire_after_ns are hidden as a revision (fleetmapd --retire-after). None: never.
  std::optional<RetireOptions> retire;
  // When: daily at this UTC second of the day (--retire-at); none: right after each nightly
  // dream, which then must be scheduled (else the constructor throws).
  std::optional<int> retire_at_second;
};

class SyncServer {
 public:
  // Opens the store (creating and migrating it), loads the TLS files and binds the listening
  // socket; serves nothing until Start(). Throws Error(kInvalidArgument) for a bad listen
  // address, a plain-text listen address off loopback without allow_plaintext, unreadable TLS
  // files or a key others can read, a retirement with neither a time nor a dream to follow,
  // Error(kBackend) when the address cannot be bound, and as GraphStore::Open for the store.
  explicit SyncServer(SyncServerOptions options);
  ~SyncServer();  // Stop()
  SyncServer(const SyncServer&) = delete;
  SyncServer& operator=(const SyncServer&) = delete;

  // Queues the stored kQueued submissions for merging, starts the threads and accepts.
  void Start();
  // Drains: stops accepting; abandons a running merge (it stays queued in the store); lets each
  // session finish the exchange in progress and tells idle ones SHUTTING_DOWN; waits up to the
  // drain deadline for them to close, closes the rest, and joins every thread. Idempotent.
  void Stop();

  // "HOST:PORT" as bound (the real port when 0 was asked for).
  std::string bound_address() const;
  std::uint16_t bound_port() const;
  bool tls() const;

  // A consistent snapshot of what the server knows (fleet_status.h). Cheap: it reads memory
  // only (robot registrations are refreshed from the store in the background).
  FleetStatus Status() const;

 private:
  class Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace fleetmap
