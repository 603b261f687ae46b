// One robot's connection to fleetmapd (sync.proto): reads frames one at a time, answers each
// exchange, and closes with an ErrorFrame on anything wrong — its own connection only.
//
// Beast's server layout: the session lives in shared_ptrs held by its pending handlers (it
// frees itself when the last completes); every handler runs on the session's strand, so the
// session needs no mutex; do_x starts an operation, on_x handles its completion and checks the
// error first. Every read and write has a deadline. Store calls run on the StoreWorkers and
// post their result back to the strand, so an io thread never waits on the store.
//
// Stream is a TCP socket or a TLS stream over one (explicitly instantiated in the .cc).
#pragma once

#include <atomic>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/ssl/stream.hpp>
#include <boost/asio/steady_timer.hpp>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "download_cache.h"
#include "fleetmap/common/error.h"
#include "fleetmap/common/uuid.h"
#include "fleetmap/server/sync_server.h"
#include "fleetmap/sync.pb.h"
#include "merge_queue.h"
#include "server_activity.h"
#include "session_tracker.h"
#include "store_workers.h"

namespace fleetmap::server {

// What every session of one server shares; owned by the server, outlives its sessions.
struct SessionContext {
  const SyncServerOptions& options;
  StoreWorkers& store;
  MergeQueue& merges;
  DownloadCache& downloads;
  ServerActivity& activity;
  SessionTracker& tracker;
  const std::atomic<bool>& draining;
};

template <typename Stream>
class SyncSession : public SessionControl,
                    public std::enable_shared_from_this<SyncSession<Stream>> {
 public:
  // `stream`'s executor must be a strand. `refuse` (non-empty): the server is full; the session
  // sends an ErrorFrame saying so and closes.
  SyncSession(Stream stream, SessionContext& context, std::string peer, std::string refuse);
  ~SyncSession() override;

  // Starts the session (the TLS handshake first, if any). Call once, right after make_shared.
  void Start();
  void Shutdown() override;

 private:
  enum class Phase { kHello, kReady, kPushing, kClosing };
  using ErrorCodeV1 = v1::ErrorFrame::Code;

  struct Push {
    Uuid submission;
    std::uint32_t chunk_count = 0;  // announced
    std::uint64_t digest = 0;       // announced
    std::uint32_t next_seq = 0;     // chunks [0, next_seq) are stored
    bool complete = false;          // stored whole before this session
  };

  boost::asio::ip::tcp::socket& Socket();

  void do_handshake();
  void on_handshake(const boost::system::error_code& ec);
  void do_read_prefix();
  void on_read_prefix(const boost::system::error_code& ec, std::size_t bytes);
  void do_read_body(std::uint32_t length);
  void on_read_body(const boost::system::error_code& ec, std::size_t bytes);
  void do_write(std::shared_ptr<const std::string> frame, std::function<void()> next);
  void on_write(const boost::system::error_code& ec, std::size_t bytes);
  void do_write_download(std::size_t index);
  void do_close();
  void CloseSocket();
  void do_drain();
  void on_drain(const boost::system::error_code& ec, std::size_t bytes);

  // Deadline for the next operation: on expiry the socket's operations are cancelled and the
  // session knows it timed out.
  void Arm(std::chrono::milliseconds deadline);
  void Disarm();

  void Handle(const v1::SyncFrame& frame);
  void OnHello(const v1::Hello& hello);
  void OnPushBegin(const v1::PushBegin& begin);
  void OnPushChunk(v1::PushChunk chunk);
  void OnPushEnd();
  void OnMergeStatusRequest(const v1::MergeStatusRequest& request);
  void QueryMergeStatus(const Uuid& submission, bool may_wait, std::uint32_t wait_ms);
  void OnDownloadRequest(const v1::DownloadRequest& request);

  // Sends `frame` then reads the next one (or closes when shutting down).
  void Reply(const v1::SyncFrame& frame);
  // Sends an ErrorFrame, logs it, and closes.
  void Fail(ErrorCodeV1 code, const std::string& text);
  // A store call failed: the ErrorFrame for its Error code.
  void FailStore(ErrorCode code, const std::string& text);
  // Runs `work(Repository&)` on a store thread; `done(result)` on the strand after. An Error
  // it throws closes the session via FailStore.
  template <typename Work, typename Done>
  void OnStore(Work work, Done done);

  std::string Who() const;

  Stream stream_;
  boost::asio::any_io_executor executor_;  // the session's strand
  SessionContext& context_;
  std::string peer_;
  std::string refuse_;
  boost::asio::steady_timer deadline_;
  std::uint64_t deadline_generation_ = 0;
  bool timed_out_ = false;
  boost::asio::steady_timer merge_wait_;
  bool shutting_down_ = false;
  bool idle_ = false;  // waiting for the first byte of a frame

  Phase phase_ = Phase::kHello;
  Uuid robot_;
  std::string robot_name_;
  std::optional<Push> push_;

  std::array<char, 4> prefix_{};
  std::string body_;
  std::shared_ptr<const std::string> out_;
  std::function<void()> after_write_;
  std::shared_ptr<const EncodedDownload> download_;
  std::chrono::steady_clock::time_point download_start_;
  bool download_cached_ = false;
  std::array<char, 16 * 1024> drain_buffer_{};
  std::size_t drained_ = 0;
  std::string close_reason_ = "closed by the robot";
  std::uint64_t frames_ = 0;
};

using PlainSyncSession = SyncSession<boost::asio::ip::tcp::socket>;
using TlsSyncSession = SyncSession<boost::asio::ssl::stream<boost::asio::ip::tcp::socket>>;

}  // namespace fleetmap::server
