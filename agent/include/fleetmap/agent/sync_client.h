// A blocking client for the sync protocol (proto/fleetmap/sync.proto; framing in
// common/wire/include/fleetmap/wire/sync_frame.h): one TCP connection to fleetmapd, optionally
// over TLS, sending and receiving whole SyncFrames.
//
// Every connect, handshake, read and write has a deadline (async operations driven by
// io_context::run_for), and a stop flag, when given, is looked at every 100 ms, so a call
// never blocks longer than its deadline and a daemon asked to stop abandons the exchange
// promptly. A frame's 4-byte length is checked against the cap before its body is read.
//
// Failures, each a fleetmap::Error (what() names the server and what was being done):
// - SyncLinkError: the link failed (refused, reset, closed, timed out, TLS handshake); after
//   it the client is unusable. retryable() tells a transient failure from one that will not
//   go away by itself (a certificate that does not verify, an address that does not resolve,
//   a server that speaks TLS to a client without it: the first reply on a plain link that
//   ends at once or comes in TLS is checked with a TLS handshake alone, and said so).
// - SyncServerError: the server sent an ErrorFrame; its code and text are in the message.
// - SyncStopped: the stop flag was raised.
// - Error(kCorrupt): the server sent bytes that are not a frame, or a frame over the cap.
//
// Threading: one thread at a time. Not copyable.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>

#include "fleetmap/core/error.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap {

enum class TlsMode {
  kNone,      // plain TCP (inside the depot)
  kVerify,    // TLS; the server's certificate must chain to the CA and name the host
  kInsecure,  // TLS without verifying the server (tests only)
};

struct SyncLinkOptions {
  TlsMode tls = TlsMode::kNone;
  std::filesystem::path tls_ca_file;                  // kVerify: PEM CA bundle; empty: the system's
  std::chrono::milliseconds connect_timeout{10'000};  // resolve + connect + TLS handshake
  std::chrono::milliseconds io_timeout{30'000};       // one frame read or written
  std::uint32_t max_frame_bytes = kMaxSyncFrameBytes;
  const std::atomic<bool>* stop = nullptr;  // raised: abandon the current call
};

class SyncLinkError : public Error {
 public:
  SyncLinkError(const std::string& message, bool retryable)
      : Error(ErrorCode::kBackend, message), retryable_(retryable) {}
  bool retryable() const { return retryable_; }

 private:
  bool retryable_;
};

class SyncServerError : public Error {
 public:
  // `context`: what the client was doing, e.g. "hello to 127.0.0.1:7000".
  SyncServerError(const v1::ErrorFrame& frame, const std::string& context);
  v1::ErrorFrame::Code server_code() const { return server_code_; }
  const std::string& server_text() const { return server_text_; }
  // Worth retrying later: the server is draining, failed internally or timed us out.
  bool retryable() const;

 private:
  v1::ErrorFrame::Code server_code_;
  std::string server_text_;
};

class SyncStopped : public Error {
 public:
  explicit SyncStopped(const std::string& message) : Error(ErrorCode::kBackend, message) {}
};

class SyncClient {
 public:
  // Connects to `host_port` ("HOST:PORT", "[v6]:PORT"), with the TLS handshake when asked.
  // Throws Error(kInvalidArgument) for a malformed address, SyncLinkError, SyncStopped.
  SyncClient(std::string_view host_port, const SyncLinkOptions& options);
  ~SyncClient();
  SyncClient(const SyncClient&) = delete;
  SyncClient& operator=(const SyncClient&) = delete;

  // Sends one frame. Throws SyncLinkError, SyncStopped, Error(kInvalidArgument) for a frame
  // over the cap.
  void Send(const v1::SyncFrame& frame);
  // The next frame, waiting up to `timeout` for all of it (0: the options' io_timeout).
  // An ErrorFrame is thrown as SyncServerError, with `during` as its context.
  v1::SyncFrame Receive(std::string_view during, std::chrono::milliseconds timeout = {});
  // Receive() in two steps, for a caller that reads some frames in place (a download's chunks,
  // ViewDownloadChunk): the next frame's body as it came (its length checked against the cap,
  // nothing else), a view into the client's buffer valid until the next call on this client;
  // then DecodeBody, which checks and parses it as Receive does. The buffer is reused, so a
  // frame costs no allocation and no clearing; it keeps the largest frame so far (at most the
  // cap) until the client is destroyed. Throws as Receive (ReceiveBody: not SyncServerError).
  std::string_view ReceiveBody(std::string_view during, std::chrono::milliseconds timeout = {});
  v1::SyncFrame DecodeBody(std::string_view body, std::string_view during);
  // Receive() that requires a body of kind `expected`; another kind throws Error(kCorrupt)
  // naming both (the server broke the exchange).
  v1::SyncFrame Expect(v1::SyncFrame::BodyCase expected, std::string_view during,
                       std::chrono::milliseconds timeout = {});
  // Closes the link (a TLS close_notify first, within a short deadline). Never throws.
  void Close();

  const std::string& server() const { return server_; }
  std::uint64_t bytes_sent() const { return bytes_sent_; }
  std::uint64_t bytes_received() const { return bytes_received_; }

 private:
  struct Link;

  // A plain link to a TLS server ends (or answers in TLS) at the first reply.
  // True while no byte has come back on a link without TLS.
  bool FirstReplyWithoutTls() const;
  // Whether a TLS handshake with the server succeeds (a second connection, closed at once).
  bool ServerSpeaksTls() const;
  // Throws the SyncLinkError (not retryable) that says so and what to do.
  [[noreturn]] void ThrowTlsMismatch(const std::string& context) const;

  std::string server_;
  SyncLinkOptions options_;
  std::unique_ptr<Link> link_;
  std::string receive_buffer_;  // the last frame's body is its first receive_size_ bytes
  std::size_t receive_size_ = 0;
  std::uint64_t bytes_sent_ = 0;
  std::uint64_t bytes_received_ = 0;
};

}  // namespace fleetmap
