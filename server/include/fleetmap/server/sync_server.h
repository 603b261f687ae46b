// fleetmapd's sync server (DESIGN.md "Sync protocol"; proto/fleetmap/sync.proto): robots
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
#include <cstdint>
#include <memory>
#include <string>

#include "fleetmap/server/fleet_status.h"

namespace fleetmap {

struct SyncServerOptions {
  std::string store_uri = "sqlite:fleetmap.db";
  // HOST:PORT ([HOST]:PORT for IPv6); port 0 takes an ephemeral port (see bound_address()).
  std::string listen = "127.0.0.1:7420";
  int io_threads = 2;
  int store_threads = 2;  // store connections for sessions (plus one for merges)
  // Both set: TLS (1.2 or later) on every connection; PEM files.
  std::string tls_cert_path;
  std::string tls_key_path;
  std::chrono::milliseconds io_deadline{30'000};         // each frame read or written
  std::chrono::milliseconds handshake_deadline{10'000};  // the TLS handshake
  std::size_t max_sessions = 256;  // more are refused with an ErrorFrame (INTERNAL)
  std::chrono::milliseconds merge_wait_cap{60'000};  // MergeStatusRequest.wait_ms at most
  std::chrono::milliseconds drain_deadline{10'000};  // Stop() waits this long for sessions
  // A test knob: each merge holds its transaction open this long before it commits.
  std::chrono::milliseconds debug_merge_delay{0};
  // A test knob: each pushed chunk waits this long before it is stored, so that tests can
  // SIGKILL the server in the middle of a push.
  std::chrono::milliseconds debug_chunk_delay{0};
  // Encoded downloads kept in memory (the newest is always kept, whatever its size).
  std::uint64_t download_cache_bytes = std::uint64_t{1} << 30;
};

class SyncServer {
 public:
  // Opens the store (creating and migrating it), loads the TLS files and binds the listening
  // socket; serves nothing until Start(). Throws Error(kInvalidArgument) for a bad listen
  // address or unreadable TLS files, Error(kBackend) when the address cannot be bound, and as
  // GraphStore::Open for the store.
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
