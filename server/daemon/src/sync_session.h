// One robot's connection to fleetmapd (sync.proto): reads frames one at a time, answers each
// exchange, and closes with an ErrorFrame on anything wrong — its own connection only.
//
// Beast's server layout: the session lives in shared_ptrs held by its pending handlers (it
// frees itself when the last completes); every handler runs on the session's strand, so the
// session needs no mutex; do_x starts an operation, on_x handles its completion and checks the
// error first. Every read and write has a deadline. Store calls run on the StoreWorkers and
// post their result back to the strand, so an io thread never waits on the store.
//
// Until its hello is accepted a connection is a stranger: its frames are at most 4 KiB, the
// hello deadline (from the accept) bounds its handshake and reads, it lingers only briefly
// after an ErrorFrame, and the server may push it out to make room (Evict;
// connection_admission.h). A frame's body is read a piece at a time into a buffer that grows
// as the bytes arrive, so an announced length costs nothing until its bytes come.
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
#include <utility>
#include <vector>

#include "connection_admission.h"
#include "download_cache.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/daemon/sync_server.h"
#include "fleetmap/sync.pb.h"
#include "fleetmap/wire/sync_frame.h"
#include "merge_queue.h"
#include "robot_allowance.h"
#include "server_activity.h"
#include "session_tracker.h"
#include "store_workers.h"

namespace fleetmap::daemon {

// What every session of one server shares; owned by the server, outlives its sessions.
struct SessionContext {
  const SyncServerOptions& options;
  StoreWorkers& store;
  MergeQueue& merges;
  DownloadCache& downloads;
  ServerActivity& activity;
  SessionTracker& tracker;
  ConnectionAdmission& admission;
  RobotAllowance& robots;
  const std::atomic<bool>& draining;
};

template <typename Stream>
class SyncSession : public SessionControl,
                    public std::enable_shared_from_this<SyncSession<Stream>> {
 public:
  // `stream`'s executor must be a strand.
  SyncSession(Stream stream, SessionContext& context, std::string peer);
  ~SyncSession() override;

  // Starts the session (the TLS handshake first, if any). Call once, right after make_shared
  // and context.admission.Admit: `admission_ticket` is what Admit gave, 0 when it refused the
  // connection (the session then says BUSY and closes).
  void Start(std::uint64_t admission_ticket);
  void Shutdown() override;
  void Evict(const std::string& why) override;

 private:
  enum class Phase { kHello, kReady, kPushing, kClosing };
  using ErrorCodeV1 = v1::ErrorFrame::Code;

  struct Push {
    Uuid submission;
    std::uint32_t chunk_count = 0;  // announced
    std::uint64_t digest = 0;       // announced
    std::uint64_t total_bytes = 0;  // announced
    std::uint32_t next_seq = 0;     // chunks [0, next_seq) are stored
    std::uint64_t bytes = 0;        // of chunks [0, next_seq)
    bool complete = false;          // stored whole before this session
  };

  boost::asio::ip::tcp::socket& Socket();

  void do_handshake();
  void on_handshake(const boost::system::error_code& ec);
  void do_read_prefix();
  void on_read_prefix(const boost::system::error_code& ec, std::size_t bytes);
  void do_read_body(std::uint32_t length);
  void do_read_body_piece();
  void on_read_body_piece(const boost::system::error_code& ec, std::size_t had, std::size_t bytes);
  void on_read_body(const boost::system::error_code& ec);
  void do_write(std::shared_ptr<const std::string> frame, std::function<void()> next);
  void on_write(const boost::system::error_code& ec, std::size_t bytes);
  void do_write_download(std::size_t index);
  // A streamed download (protocol version 3; see the .cc).
  void StartStreaming(std::shared_ptr<const DownloadPlan> plan, std::string key, bool plan_cached);
  void PumpStream();
  void ReadStreamBatch();
  void WriteStreamBatch(std::vector<std::string> frames);
  void on_stream_write(const boost::system::error_code& ec, std::size_t bytes);
  void FinishStreaming();
  // The per-download log line and metric.
  void LogDownload(const DownloadReport& report, const v1::DownloadHeader& header,
                   std::uint32_t chunks, std::uint64_t frame_bytes, std::uint64_t sent_digest,
                   std::uint64_t removed_digest, const char* how);
  // Records the download sent (RobotRegistry::RecordSent) on a store worker, without waiting.
  void RecordSent(const v1::DownloadHeader& header, std::uint64_t sent_digest,
                  std::uint64_t removed_digest);
  void do_close();
  void CloseSocket();
  void do_drain();
  void on_drain(const boost::system::error_code& ec, std::size_t bytes);

  // Deadline for the next operation: on expiry the socket's operations are cancelled and the
  // session knows it timed out.
  void Arm(std::chrono::milliseconds deadline);
  void Disarm();
  // The deadline of the next read: io_deadline, and before the hello no later than the hello
  // deadline (counted from the accept).
  std::chrono::milliseconds ReadDeadline() const;
  // The session starts closing: it no longer counts against the server's limits, nor against
  // its robot's (robot_allowance.h).
  void LeaveAdmission();
  // The session is done with the frame it reserved room for (robot_allowance.h): released.
  void ReleaseFrame();

  void Handle(const v1::SyncFrame& frame);
  void OnHello(const v1::Hello& hello);
  void OnPushBegin(const v1::PushBegin& begin);
  void OnPushChunk(v1::PushChunk chunk);
  void OnPushEnd();
  void OnMergeStatusRequest(const v1::MergeStatusRequest& request);
  void QueryMergeStatus(const Uuid& submission, bool may_wait, std::uint32_t wait_ms);
  // A robot restoring its own work (lost map or state): what of it a revision lacks, and its
  // chunks as pushed. Only its own submissions, complete ones only.
  void OnOwnSubmissionsRequest(const v1::OwnSubmissionsRequest& request);
  void OnSubmissionChunkRequest(const v1::SubmissionChunkRequest& request);
  void OnDownloadRequest(const v1::DownloadRequest& request);
  // Records `error` as the robot's last (RobotRegistry::RecordError) on a store worker, without
  // waiting: the session is closing anyway.
  void RecordRobotError(const std::string& error);

  // Sends `frame` then reads the next one (or closes when shutting down).
  void Reply(const v1::SyncFrame& frame);
  // Sends an ErrorFrame, logs it, and closes.
  void Fail(ErrorCodeV1 code, const std::string& text);
  // Fail with BUSY: admission refused this connection, the server holds max_sessions.
  void FailFull();
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
  std::uint64_t admission_ticket_ = 0;  // 0: not counted (refused, or released)
  bool refused_ = false;                // the server was full at the accept
  bool hello_received_ = false;         // a hello frame arrived whole
  bool evicted_ = false;                // Evict() came before the hello arrived whole
  std::string evicted_why_;
  std::chrono::steady_clock::time_point hello_by_;  // the hello deadline
  boost::asio::steady_timer deadline_;
  std::uint64_t deadline_generation_ = 0;
  bool timed_out_ = false;
  boost::asio::steady_timer merge_wait_;
  bool shutting_down_ = false;
  bool idle_ = false;  // waiting for the first byte of a frame

  Phase phase_ = Phase::kHello;
  bool welcomed_ = false;  // past the hello: a robot, authenticated
  Uuid robot_;
  std::string robot_name_;
  bool robot_joined_ = false;         // counted among robot_'s sessions (robot_allowance.h)
  std::uint64_t frame_reserved_ = 0;  // bytes of the frame being read or handled, reserved
  std::optional<Push> push_;

  std::array<char, 4> prefix_{};
  // The frame being read. It grows as the bytes arrive, a piece at a time, never to the length
  // the prefix announced before they have: memory follows what was received.
  std::string body_;
  std::size_t body_length_ = 0;  // announced
  std::shared_ptr<const std::string> out_;
  std::function<void()> after_write_;
  std::uint32_t protocol_version_ = kSyncProtocolVersion;  // the hello's, once accepted
  std::shared_ptr<const EncodedDownload> download_;
  // A download being streamed: touched on the strand only (the encoder on a store worker, one
  // batch at a time, handed over through the job queue and the strand).
  struct Streaming {
    std::shared_ptr<DownloadEncoder> encoder;
    std::string cache_key;
    std::vector<std::string> frames;                // being written
    std::optional<std::vector<std::string>> ready;  // read, waiting for the write to end
    bool writing = false;
    bool reading = false;   // a batch is being read on a store worker
    bool read_all = false;  // the encoder is done
    bool end_sent = false;  // DownloadEnd is written or being written
    std::optional<std::pair<ErrorCode, std::string>> failed;  // a read failed: say so, close
    std::uint64_t frame_bytes = 0;                            // written so far
    bool keep_all = true;           // small so far: the frames are kept for the cache
    bool plan_cached = false;       // the plan came from the cache
    std::vector<std::string> kept;  // written frames, while keep_all
  };
  std::optional<Streaming> streaming_;
  std::chrono::steady_clock::time_point download_start_;
  std::string download_channel_;  // of the download in progress
  bool download_cached_ = false;
  std::array<char, 16 * 1024> drain_buffer_{};
  std::size_t drained_ = 0;
  std::string close_reason_ = "closed by the robot";
  std::uint64_t frames_ = 0;
};

using PlainSyncSession = SyncSession<boost::asio::ip::tcp::socket>;
using TlsSyncSession = SyncSession<boost::asio::ssl::stream<boost::asio::ip::tcp::socket>>;

}  // namespace fleetmap::daemon
