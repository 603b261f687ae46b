// One robot's connection to fleetmapd: the transport under the sync protocol. It does the TLS
// handshake, reads frames (a 4-byte length, then the body, checked against the caps before a
// byte of it is buffered), writes frames, keeps a deadline on every read and write, and holds
// the connection's place in the server's admission (connection_admission.h) and its robot's
// allowance (robot_allowance.h). Each decoded frame goes to the connection's protocol handler
// (sync_protocol_handler.h), which answers through the SessionLink this class implements.
//
// Beast's server layout: the session lives in shared_ptrs held by its pending handlers (it
// frees itself when the last completes); every handler runs on the session's strand, so the
// session needs no mutex; do_x starts an operation, on_x handles its completion and checks the
// error first.
//
// Until its hello is accepted a connection is a stranger: its frames are at most 4 KiB, the
// hello deadline (from the accept) bounds its handshake and reads, it lingers only briefly
// after an ErrorFrame, and the server may push it out to make room (Evict). A frame's body is
// read a piece at a time into a buffer that grows as the bytes arrive, so an announced length
// costs nothing until its bytes come.
//
// Stream is a TCP socket or a TLS stream over one (explicitly instantiated in the .cc).
#pragma once

#include <array>
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

#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/sync.pb.h"
#include "session_link.h"
#include "session_tracker.h"
#include "sync_protocol_handler.h"

namespace fleetmap::daemon {

template <typename Stream>
class SyncSession : public SessionControl,
                    public SessionLink,
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

  // SessionLink
  void Reply(const v1::SyncFrame& frame) override;
  void Fail(v1::ErrorFrame::Code code, const std::string& text) override;
  void CloseAfterBye() override;
  void HelloArrived() override;
  bool JoinRobot(const Uuid& robot, const std::string& name) override;
  void SendFrames(std::shared_ptr<const std::vector<std::string>> frames,
                  std::function<void(std::uint64_t bytes)> written) override;
  void StreamFrames(std::vector<std::string> first, std::shared_ptr<FrameSource> source) override;
  std::shared_ptr<void> KeepAlive() override { return this->shared_from_this(); }
  boost::asio::any_io_executor executor() const override { return executor_; }
  std::string Who() const override;
  bool shutting_down() const override { return shutting_down_; }

 private:
  // Who is on the other end: one state, moving forward only.
  enum class Peer {
    kHandshaking,     // the TLS handshake is under way
    kStranger,        // no hello yet: small frames, the hello deadline, may be evicted
    kAuthenticating,  // its hello arrived whole and is being checked: no longer evictable
    kRobot,           // welcomed: a robot's frames and deadlines, counted among its sessions
  };

  boost::asio::ip::tcp::socket& Socket();

  void do_handshake();
  void on_handshake(const boost::system::error_code& ec);
  void do_read_prefix();
  void on_read_prefix(const boost::system::error_code& ec, std::size_t bytes);
  // Whether the announced frame may be read: the caps and the robot's allowance; else fails.
  bool AdmitFrame(std::uint32_t length);
  void do_read_body(std::uint32_t length);
  void do_read_body_piece();
  void on_read_body_piece(const boost::system::error_code& ec, std::size_t had, std::size_t bytes);
  void on_read_body(const boost::system::error_code& ec);
  void do_write(std::shared_ptr<const std::string> frame, std::function<void()> next);
  void on_write(const boost::system::error_code& ec, std::size_t bytes);
  void do_write_frames(std::size_t index);
  // A stream of frames (StreamFrames): its pump, a read on a store worker beside a write.
  void PumpStream();
  void ReadStreamBatch();
  void WriteStreamBatch(std::vector<std::string> frames);
  void on_stream_write(const boost::system::error_code& ec, std::size_t bytes);
  void do_close();
  void CloseSocket();
  void do_drain();
  void on_drain(const boost::system::error_code& ec, std::size_t bytes);
  // The write of a download frame failed: closes.
  void DownloadWriteFailed(const boost::system::error_code& ec);

  // Deadline for the next operation: on expiry the socket's operations are cancelled and the
  // session knows it timed out.
  void Arm(std::chrono::milliseconds deadline);
  void Disarm();
  // The deadline of the next read: io_deadline, and before the hello no later than the hello
  // deadline (counted from the accept).
  std::chrono::milliseconds ReadDeadline() const;
  // The session starts closing: it no longer counts against the server's limits, nor against
  // its robot's.
  void LeaveAdmission();
  // The session is done with the frame it reserved room for (robot_allowance.h): released.
  void ReleaseFrame();
  // Fail with BUSY: admission refused this connection, the server holds max_sessions.
  void FailFull();
  bool welcomed() const { return peer_state_ == Peer::kRobot; }

  Stream stream_;
  boost::asio::any_io_executor executor_;  // the session's strand
  SessionContext& context_;
  std::string peer_;
  SyncProtocolHandler handler_;
  Peer peer_state_;
  std::uint64_t admission_ticket_ = 0;  // 0: not counted (refused, or released)
  std::optional<std::string> evicted_;  // Evict()'s reason, before the hello arrived whole
  std::chrono::steady_clock::time_point hello_by_;  // the hello deadline
  boost::asio::steady_timer deadline_;
  std::uint64_t deadline_generation_ = 0;
  bool timed_out_ = false;            // the last deadline expired
  bool shutting_down_ = false;        // Shutdown() came
  bool idle_ = false;                 // waiting for the first byte of a frame
  bool closing_ = false;              // an ErrorFrame or a bye: nothing more is handled
  Uuid robot_;                        // when welcomed
  std::optional<Uuid> joined_robot_;  // the robot whose sessions this one counts among
  std::string robot_name_;
  std::uint64_t frame_reserved_ = 0;  // bytes of the frame being read or handled, reserved

  std::array<char, 4> prefix_{};
  // The frame being read. It grows as the bytes arrive, a piece at a time, never to the length
  // the prefix announced before they have: memory follows what was received.
  std::string body_;
  std::size_t body_length_ = 0;  // announced
  std::shared_ptr<const std::string> out_;
  std::function<void()> after_write_;
  // Frames sent whole (SendFrames).
  std::shared_ptr<const std::vector<std::string>> frames_out_;
  std::function<void(std::uint64_t)> frames_written_;
  std::uint64_t frames_out_bytes_ = 0;
  // A stream being written (StreamFrames): touched on the strand only, the source's batches
  // read on a store worker one at a time and handed over through the job queue and the strand.
  struct Streaming {
    std::shared_ptr<FrameSource> source;
    std::vector<std::string> writing;               // being written
    std::optional<std::vector<std::string>> ready;  // read, waiting for the write to end
    enum class Read { kIdle, kReading, kAllRead } read = Read::kIdle;
    std::optional<std::pair<ErrorCode, std::string>> failed;  // a read failed: say so, close
  };
  std::optional<Streaming> streaming_;
  std::array<char, 16 * 1024> drain_buffer_{};
  std::size_t drained_ = 0;
  std::string close_reason_ = "closed by the robot";
  std::uint64_t frames_ = 0;
};

using PlainSyncSession = SyncSession<boost::asio::ip::tcp::socket>;
using TlsSyncSession = SyncSession<boost::asio::ssl::stream<boost::asio::ip::tcp::socket>>;

}  // namespace fleetmap::daemon
