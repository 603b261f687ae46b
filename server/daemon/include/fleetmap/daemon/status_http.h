// The status HTTP server of fleetmapd (`--http HOST:PORT`): a small HTTP/1.1 server
// (Boost.Beast) that shows a person and a Prometheus scraper what the sync server is doing.
//
// Routes (GET only; any other method is answered 405, any other path 404):
//   GET /         the status page: self-contained HTML (status_page.h); ?r=R shows the map of
//                 revision R, ?change=R what revision R changed
//   GET /metrics  Prometheus text exposition format 0.0.4, metrics named fleetmap_*
//                 (Content-Type "text/plain; version=0.0.4; charset=utf-8")
//   GET /healthz  "ok"
//   GET /map.svg  the picture of the head (FleetStatus::head_picture_svg, drawn once per
//                 revision), or of revision R with ?r=R; image/svg+xml
//   GET /map.json the same picture's nodes' facts (fleet_status.h ServedPicture)
//   GET /change.svg, /change.json   what revision R (?r=R, default the head) changed
// A picture not drawn yet is 503 with Retry-After (it is drawn off this thread: ask again).
// The rest of a query string is ignored for routing.
//
// Who may read it: the page and /metrics name every robot, its UUID, channel and last error.
// So, as the sync server refuses plain text off loopback, an address other than loopback is
// refused unless StatusHttpOptions::allow_plaintext says the network is trusted (this server
// speaks no TLS: off loopback, put it behind a TLS reverse proxy or an SSH tunnel). With a
// token every request must carry it, else 401 (status_access.h: "Authorization: Bearer", or
// "?token=" for a browser, then a cookie), compared in constant time.
//
// Limits: request headers up to 8 KiB and bodies up to 8 KiB (larger: 431/413 and the
// connection closes); 3 s to receive a whole request, counted from when the server starts
// waiting for it (a keep-alive connection waiting for its next request included), so a client
// that connects and sends nothing, or trickles, holds its connection no longer; 10 s for every
// write; at most 64 connections at once: a new one beyond that pushes out the connection that
// has waited longest for a request (so idle connections cannot keep /metrics from a scraper),
// and is closed at accept only when all 64 are answering requests.
//
// Threading: the server runs on its own io_context and one thread, started by the
// constructor; each connection has its own strand. `status_source` is called on that thread,
// once per request to any path but /healthz, and must be thread-safe with respect to the sync
// server (SyncServer::Status() is); if it throws, the request gets 500 with the message. Stop() and
// the destructor may be called from any one thread other than the server's own.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "fleetmap/daemon/fleet_status.h"

namespace fleetmap {

struct StatusHttpOptions {
  // Serve in plain text on an address other than loopback (fleetmapd --allow-plaintext-http).
  bool allow_plaintext = false;
  // Not empty: every request must carry it (see above).
  std::string token;
};

class StatusHttpServer {
 public:
  using StatusSource = std::function<FleetStatus()>;

  // Binds `address` ("HOST:PORT", "[IPv6]:PORT"; HOST an address or a name that resolves;
  // PORT 0 picks a free one) and starts serving. A snapshot whose now_ns is 0 is stamped
  // with the system clock before rendering.
  // Throws Error(kInvalidArgument) for a malformed address, a host that does not resolve, or
  // an address other than loopback without options.allow_plaintext (naming the ways out),
  // Error(kBackend) when the address cannot be bound (in use, not ours, no permission).
  StatusHttpServer(const std::string& address, StatusSource status_source,
                   StatusHttpOptions options = {});
  // Stop().
  ~StatusHttpServer();
  StatusHttpServer(const StatusHttpServer&) = delete;
  StatusHttpServer& operator=(const StatusHttpServer&) = delete;

  // The bound port (the one picked when the address said 0).
  std::uint16_t port() const;
  // "HOST:PORT" as bound, e.g. "127.0.0.1:40123".
  std::string address() const;

  // Stops accepting, lets a response being written finish, closes every connection and
  // joins the thread. Returns within about 3 s even with clients that do not read: after
  // that deadline the remaining connections are dropped. Idempotent.
  void Stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// The fleetmapd main's entry point for `--http HOST:PORT`: a running StatusHttpServer.
// Throws as the constructor.
std::unique_ptr<StatusHttpServer> StartStatusHttp(const std::string& address,
                                                  StatusHttpServer::StatusSource status_source,
                                                  StatusHttpOptions options = {});

// The token in the file at `path` (fleetmapd --http-token-file): its first line, trailing
// whitespace cut. Throws Error(kInvalidArgument) when others can read the file (chmod 600, as
// for a TLS key), it cannot be read, or the token is shorter than 16 characters or holds
// characters other than A-Z a-z 0-9 - . _ ~ (so a URL and a cookie carry it as it is).
std::string ReadStatusHttpToken(const std::string& path);

}  // namespace fleetmap
