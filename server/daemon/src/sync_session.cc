#include "sync_session.h"

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <type_traits>

#include "fleetmap/core/printable_text.h"
#include "fleetmap/protocol/protocol_error.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::daemon {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

// After an ErrorFrame or a Bye, what the robot still sends is read and dropped for a moment
// before the socket closes: closing with unread bytes would reset the connection and could
// destroy the ErrorFrame before the robot reads it.
constexpr std::chrono::milliseconds kLingerDeadline{2000};
constexpr std::size_t kLingerBytes = std::size_t{1} << 20;
// Before a hello is accepted the peer may be anyone, and a flood of them reconnects as fast
// as it is closed: each gets a short linger, so closing ones cannot pile up.
constexpr std::chrono::milliseconds kPreHelloLingerDeadline{250};
constexpr std::size_t kPreHelloLingerBytes = std::size_t{64} << 10;
// An ErrorFrame is small; a robot that does not read it for this long gets no more patience.
constexpr std::chrono::milliseconds kErrorWriteDeadline{5000};
constexpr std::chrono::milliseconds kPreHelloErrorWriteDeadline{1000};
// Until a hello is accepted, a frame is at most this long: a Hello is a 16-byte id, a 64-digit
// token and an agent string. Larger frames (chunks up to kMaxSyncFrameBytes) only from robots.
constexpr std::uint32_t kMaxPreHelloFrameBytes = 4096;
// A frame's body is read at most this much at a time, into a buffer that grows by what
// arrived: a prefix announcing 64 MiB costs nothing until 64 MiB come.
constexpr std::size_t kBodyPieceBytes = std::size_t{64} << 10;

// A TLS connection opens with a handshake record (content type 22) of major version 3: what a
// plain listener sees first from an agent that speaks TLS to it.
constexpr unsigned char kTlsHandshakeRecord = 0x16;
constexpr unsigned char kTlsMajorVersion = 0x03;

std::string Seconds(std::chrono::milliseconds d) {
  return fmt::format("{:g} s", static_cast<double>(d.count()) / 1000.0);
}

// The TLS handshake failed on its first record, which was no TLS record at all: the peer spoke
// plain bytes (an agent without TLS, whose hello starts with a frame's length).
bool NotTls(const boost::system::error_code& ec) {
  if (ec.category() != asio::error::get_ssl_category()) return false;
  const int reason = ERR_GET_REASON(static_cast<unsigned long>(ec.value()));
  return reason == SSL_R_WRONG_VERSION_NUMBER || reason == SSL_R_HTTP_REQUEST ||
         reason == SSL_R_UNKNOWN_PROTOCOL;
}

}  // namespace

template <typename Stream>
SyncSession<Stream>::SyncSession(Stream stream, SessionContext& context, std::string peer)
    : stream_(std::move(stream)),
      executor_(Socket().get_executor()),
      context_(context),
      peer_(std::move(peer)),
      handler_(context, *this),
      peer_state_(std::is_same_v<Stream, tcp::socket> ? Peer::kStranger : Peer::kHandshaking),
      hello_by_(std::chrono::steady_clock::now() + context.options.hello_deadline),
      deadline_(executor_) {
  context_.activity.SessionOpened();
}

template <typename Stream>
SyncSession<Stream>::~SyncSession() {
  spdlog::info("session {} closed: {}; {} frames", Who(), PrintableText(close_reason_), frames_);
  LeaveAdmission();
  context_.activity.SessionClosed();
  context_.tracker.Closed();
}

template <typename Stream>
tcp::socket& SyncSession<Stream>::Socket() {
  if constexpr (std::is_same_v<Stream, tcp::socket>) {
    return stream_;
  } else {
    return stream_.next_layer();
  }
}

template <typename Stream>
std::string SyncSession<Stream>::Who() const {
  if (robot_name_.empty()) return peer_;
  return peer_ + " (robot " + robot_name_ + ")";
}

template <typename Stream>
void SyncSession<Stream>::Start(std::uint64_t admission_ticket) {
  admission_ticket_ = admission_ticket;
  asio::post(executor_, [self = this->shared_from_this()] {
    if constexpr (std::is_same_v<Stream, tcp::socket>) {
      if (self->admission_ticket_ == 0) return self->FailFull();
      self->do_read_prefix();
    } else {
      self->do_handshake();
    }
  });
}

template <typename Stream>
void SyncSession<Stream>::Shutdown() {
  asio::post(executor_, [self = this->shared_from_this()] {
    if (self->shutting_down_) return;
    self->shutting_down_ = true;
    boost::system::error_code ignored;
    if (self->idle_) self->Socket().cancel(ignored);  // on_read_prefix says SHUTTING_DOWN
    self->handler_.Shutdown();
  });
}

template <typename Stream>
void SyncSession<Stream>::Evict(const std::string& why) {
  asio::post(executor_, [self = this->shared_from_this(), why] {
    const bool evictable =
        self->peer_state_ == Peer::kHandshaking || self->peer_state_ == Peer::kStranger;
    if (!evictable || self->evicted_ || self->closing_) return;
    self->evicted_ = why;
    // Before the hello there is always a handshake or a read pending: its handler sees
    // evicted_ and closes.
    boost::system::error_code ignored;
    self->Socket().cancel(ignored);
  });
}

template <typename Stream>
void SyncSession<Stream>::FailFull() {
  Fail(v1::ErrorFrame::BUSY, "the server holds its maximum of " +
                                 std::to_string(context_.options.max_sessions) +
                                 " sessions; retry later");
}

template <typename Stream>
void SyncSession<Stream>::LeaveAdmission() {
  context_.admission.Release(admission_ticket_);
  admission_ticket_ = 0;
  ReleaseFrame();
  if (joined_robot_) context_.robots.LeaveSession(*joined_robot_);
  joined_robot_.reset();
}

template <typename Stream>
void SyncSession<Stream>::ReleaseFrame() {
  if (frame_reserved_ > 0) context_.robots.ReleaseFrame(robot_, frame_reserved_);
  frame_reserved_ = 0;
}

// ---- The link the protocol handler answers through ----

template <typename Stream>
void SyncSession<Stream>::HelloArrived() {
  peer_state_ = Peer::kAuthenticating;
  context_.admission.HelloReceived(admission_ticket_);  // it can no longer be evicted
}

template <typename Stream>
bool SyncSession<Stream>::JoinRobot(const Uuid& robot, const std::string& name) {
  robot_name_ = name;
  if (!context_.robots.JoinSession(robot)) return false;
  robot_ = robot;
  joined_robot_ = robot;
  peer_state_ = Peer::kRobot;
  return true;
}

template <typename Stream>
void SyncSession<Stream>::Reply(const v1::SyncFrame& frame) {
  do_write(std::make_shared<const std::string>(EncodeSyncFrame(frame)),
           [self = this->shared_from_this()] { self->do_read_prefix(); });
}

template <typename Stream>
void SyncSession<Stream>::Fail(v1::ErrorFrame::Code code, const std::string& text) {
  if (closing_) return;
  closing_ = true;
  const bool was_robot = welcomed();
  LeaveAdmission();
  const std::string name = v1::ErrorFrame::Code_Name(code);
  close_reason_ = name + ": " + text;
  spdlog::warn("session {} refused: {}: {}", Who(), name, PrintableText(text));
  context_.activity.ErrorSent(name);
  if (was_robot) handler_.SessionFailed(name + ": " + text);
  do_write(std::make_shared<const std::string>(EncodeSyncFrame(ErrorFrameOf(code, text))),
           [self = this->shared_from_this()] { self->do_close(); });
}

template <typename Stream>
void SyncSession<Stream>::CloseAfterBye() {
  close_reason_ = "bye";
  do_close();
}

// ---- Deadlines ----

template <typename Stream>
void SyncSession<Stream>::Arm(std::chrono::milliseconds deadline) {
  timed_out_ = false;
  const std::uint64_t generation = ++deadline_generation_;
  deadline_.expires_after(deadline);
  deadline_.async_wait([self = this->shared_from_this(), generation](boost::system::error_code ec) {
    if (ec || generation != self->deadline_generation_) return;
    self->timed_out_ = true;
    boost::system::error_code ignored;
    self->Socket().cancel(ignored);
  });
}

template <typename Stream>
void SyncSession<Stream>::Disarm() {
  ++deadline_generation_;
  deadline_.cancel();
}

template <typename Stream>
std::chrono::milliseconds SyncSession<Stream>::ReadDeadline() const {
  if (welcomed()) return context_.options.io_deadline;
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
      hello_by_ - std::chrono::steady_clock::now());
  return std::clamp(left, std::chrono::milliseconds(1), context_.options.io_deadline);
}

// ---- TLS ----

template <typename Stream>
void SyncSession<Stream>::do_handshake() {
  if constexpr (!std::is_same_v<Stream, tcp::socket>) {
    Arm(std::min(context_.options.handshake_deadline, ReadDeadline()));
    stream_.async_handshake(asio::ssl::stream_base::server,
                            [self = this->shared_from_this()](boost::system::error_code ec) {
                              self->on_handshake(ec);
                            });
  }
}

template <typename Stream>
void SyncSession<Stream>::on_handshake(const boost::system::error_code& ec) {
  Disarm();
  peer_state_ = Peer::kStranger;
  if (evicted_) {
    // Under TLS nothing can be said before the handshake ends: it just closes.
    if (ec) {
      close_reason_ = "BUSY (before the TLS handshake ended): " + *evicted_;
      spdlog::warn("session {} refused: {}", peer_, close_reason_);
      return CloseSocket();
    }
    return Fail(v1::ErrorFrame::BUSY, *evicted_);
  }
  if (ec) {
    close_reason_ = timed_out_ ? "no TLS handshake within " +
                                     Seconds(std::min(context_.options.handshake_deadline,
                                                      context_.options.hello_deadline))
                    : NotTls(ec) ? "it sent plain bytes, not a TLS handshake, to this TLS server: "
                                   "an agent without TLS? (fleetmap-agent --tls-ca FILE)"
                                 : "TLS handshake failed: " + ec.message();
    spdlog::warn("session {} refused: {}", peer_, close_reason_);
    return CloseSocket();
  }
  if (admission_ticket_ == 0) return FailFull();
  do_read_prefix();
}

// ---- Reading frames ----

template <typename Stream>
void SyncSession<Stream>::do_read_prefix() {
  ReleaseFrame();  // the last frame is handled
  if (shutting_down_ || context_.draining.load()) {
    return Fail(v1::ErrorFrame::SHUTTING_DOWN, "the server is shutting down; retry later");
  }
  idle_ = true;
  Arm(ReadDeadline());
  asio::async_read(
      stream_, asio::buffer(prefix_),
      [self = this->shared_from_this()](boost::system::error_code ec, std::size_t bytes) {
        self->on_read_prefix(ec, bytes);
      });
}

template <typename Stream>
void SyncSession<Stream>::on_read_prefix(const boost::system::error_code& ec, std::size_t bytes) {
  idle_ = false;
  Disarm();
  context_.activity.BytesReceived(bytes);
  if (evicted_) return Fail(v1::ErrorFrame::BUSY, *evicted_);
  if (ec) {
    if (timed_out_ && !welcomed()) {
      return Fail(v1::ErrorFrame::TIMEOUT, "no complete hello within " +
                                               Seconds(context_.options.hello_deadline) +
                                               " of connecting");
    }
    if (timed_out_) {
      return Fail(v1::ErrorFrame::TIMEOUT,
                  "no frame within " + Seconds(context_.options.io_deadline));
    }
    if (ec == asio::error::operation_aborted && shutting_down_) {
      return Fail(v1::ErrorFrame::SHUTTING_DOWN, "the server is shutting down; retry later");
    }
    if (bytes > 0) {
      close_reason_ = "truncated frame: the connection ended after " + std::to_string(bytes) +
                      " of the 4 bytes of a frame's length (" + ec.message() + ")";
      spdlog::warn("session {}: {}", Who(), close_reason_);
    } else if (ec != asio::error::eof) {
      close_reason_ = "read failed: " + ec.message();
    }
    return CloseSocket();
  }
  const auto* p = reinterpret_cast<const unsigned char*>(prefix_.data());
  if constexpr (std::is_same_v<Stream, tcp::socket>) {
    if (!welcomed() && p[0] == kTlsHandshakeRecord && p[1] == kTlsMajorVersion) {
      // Said in the log; a frame back would only garble the peer's handshake.
      close_reason_ =
          "it opened with a TLS ClientHello, but this server runs without TLS: drop --tls-ca "
          "(or --tls-insecure) from the agent, or give fleetmapd --tls-cert and --tls-key";
      spdlog::warn("session {} refused: {}", peer_, close_reason_);
      return CloseSocket();
    }
  }
  const std::uint32_t announced = (std::uint32_t{p[0]} << 24) | (std::uint32_t{p[1]} << 16) |
                                  (std::uint32_t{p[2]} << 8) | std::uint32_t{p[3]};
  if (announced == 0) return Fail(v1::ErrorFrame::BAD_FRAME, "a frame of 0 bytes (no body)");
  std::uint32_t length = 0;
  try {
    // The cap is checked here, before a byte of the body is read or a buffer allocated.
    length = DecodeSyncFrameLength(std::string_view(prefix_.data(), prefix_.size()));
  } catch (const Error& error) {
    return Fail(v1::ErrorFrame::FRAME_TOO_LARGE, error.message());
  }
  if (AdmitFrame(length)) do_read_body(length);
}

template <typename Stream>
bool SyncSession<Stream>::AdmitFrame(std::uint32_t length) {
  if (!welcomed()) {
    if (length <= kMaxPreHelloFrameBytes) return true;
    Fail(v1::ErrorFrame::FRAME_TOO_LARGE,
         "a frame of " + std::to_string(length) +
             " bytes before a hello was accepted: until then a frame is at most " +
             std::to_string(kMaxPreHelloFrameBytes) + " bytes");
    return false;
  }
  // Room for the whole frame among the robot's, before a byte of it.
  std::uint64_t in_flight = 0;
  if (!context_.robots.ReserveFrame(robot_, length, in_flight)) {
    Fail(v1::ErrorFrame::BUSY,
         "a frame of " + BytesText(length) + " while robot " + robot_name_ + " has " +
             BytesText(in_flight) + " of frames in flight across its sessions, over its cap of " +
             BytesText(context_.robots.limits().frame_bytes) +
             " (fleetmapd --max-inflight-mib-per-robot); retry when they are done");
    return false;
  }
  frame_reserved_ = length;
  return true;
}

template <typename Stream>
void SyncSession<Stream>::do_read_body(std::uint32_t length) {
  body_.clear();
  body_length_ = length;
  // One deadline for the whole body: a robot that trickles it does not renew it.
  Arm(ReadDeadline());
  do_read_body_piece();
}

template <typename Stream>
void SyncSession<Stream>::do_read_body_piece() {
  const std::size_t had = body_.size();
  const std::size_t want = std::min(kBodyPieceBytes, body_length_ - had);
  body_.resize(had + want);
  stream_.async_read_some(
      asio::buffer(body_.data() + had, want),
      [self = this->shared_from_this(), had](boost::system::error_code ec, std::size_t bytes) {
        self->on_read_body_piece(ec, had, bytes);
      });
}

template <typename Stream>
void SyncSession<Stream>::on_read_body_piece(const boost::system::error_code& ec, std::size_t had,
                                             std::size_t bytes) {
  body_.resize(had + bytes);
  context_.activity.BytesReceived(bytes);
  if (!ec && !evicted_ && body_.size() < body_length_) return do_read_body_piece();
  on_read_body(ec);
}

template <typename Stream>
void SyncSession<Stream>::on_read_body(const boost::system::error_code& ec) {
  Disarm();
  if (evicted_) return Fail(v1::ErrorFrame::BUSY, *evicted_);
  if (ec) {
    const std::string got = std::to_string(body_.size()) + " of the " +
                            std::to_string(body_length_) + " bytes announced";
    if (timed_out_ && !welcomed()) {
      return Fail(v1::ErrorFrame::TIMEOUT, "no complete hello within " +
                                               Seconds(context_.options.hello_deadline) +
                                               " of connecting: " + got);
    }
    if (timed_out_) {
      return Fail(v1::ErrorFrame::TIMEOUT, "a frame's body did not arrive within " +
                                               Seconds(context_.options.io_deadline) + ": " + got);
    }
    close_reason_ =
        "truncated frame: the connection ended after " + got + " (" + ec.message() + ")";
    spdlog::warn("session {}: {}", Who(), close_reason_);
    return CloseSocket();
  }
  v1::SyncFrame frame;
  try {
    frame = DecodeSyncFrameBody(body_);
  } catch (const Error& error) {
    return Fail(v1::ErrorFrame::BAD_FRAME, error.message());
  }
  // Chunks are up to 64 MiB: give the memory back rather than keep the largest for the session.
  if (body_.capacity() > (std::size_t{1} << 16)) {
    std::string().swap(body_);
  }
  ++frames_;
  handler_.Handle(frame);
}

// ---- Writing ----

template <typename Stream>
void SyncSession<Stream>::do_write(std::shared_ptr<const std::string> frame,
                                   std::function<void()> next) {
  out_ = std::move(frame);
  after_write_ = std::move(next);
  const std::chrono::milliseconds error_deadline =
      welcomed() ? kErrorWriteDeadline : kPreHelloErrorWriteDeadline;
  Arm(closing_ ? std::min(error_deadline, context_.options.io_deadline)
               : context_.options.io_deadline);
  asio::async_write(
      stream_, asio::buffer(*out_),
      [self = this->shared_from_this()](boost::system::error_code ec, std::size_t bytes) {
        self->on_write(ec, bytes);
      });
}

template <typename Stream>
void SyncSession<Stream>::on_write(const boost::system::error_code& ec, std::size_t bytes) {
  Disarm();
  context_.activity.BytesSent(bytes);
  out_.reset();
  if (ec) {
    close_reason_ = timed_out_ ? "the robot did not take a frame within " +
                                     Seconds(context_.options.io_deadline)
                               : "write failed: " + ec.message();
    spdlog::warn("session {}: {}", Who(), close_reason_);
    return CloseSocket();
  }
  std::function<void()> next = std::move(after_write_);
  next();
}

template <typename Stream>
void SyncSession<Stream>::DownloadWriteFailed(const boost::system::error_code& ec) {
  close_reason_ = timed_out_ ? "the robot did not take a download frame within " +
                                   Seconds(context_.options.io_deadline)
                             : "download write failed: " + ec.message();
  spdlog::warn("session {}: {}", Who(), close_reason_);
  CloseSocket();
}

template <typename Stream>
void SyncSession<Stream>::SendFrames(std::shared_ptr<const std::vector<std::string>> frames,
                                     std::function<void(std::uint64_t bytes)> written) {
  frames_out_ = std::move(frames);
  frames_written_ = std::move(written);
  frames_out_bytes_ = 0;
  do_write_frames(0);
}

template <typename Stream>
void SyncSession<Stream>::do_write_frames(std::size_t index) {
  if (index == frames_out_->size()) {
    const std::function<void(std::uint64_t)> written = std::move(frames_written_);
    frames_out_.reset();
    written(frames_out_bytes_);
    return do_read_prefix();
  }
  Arm(context_.options.io_deadline);
  asio::async_write(
      stream_, asio::buffer((*frames_out_)[index]),
      [self = this->shared_from_this(), index](boost::system::error_code ec, std::size_t bytes) {
        self->Disarm();
        self->context_.activity.BytesSent(bytes);
        if (ec) return self->DownloadWriteFailed(ec);
        self->frames_out_bytes_ += bytes;
        self->do_write_frames(index + 1);
      });
}

// ---- A stream of frames ----
//
// Two batches at most are alive: the one being written and the next, being read on a store
// worker meanwhile. The read after that starts only when the write ends (back-pressure: a slow
// robot slows the reads, it does not pile batches up in memory).

template <typename Stream>
void SyncSession<Stream>::StreamFrames(std::vector<std::string> first,
                                       std::shared_ptr<FrameSource> source) {
  Streaming& s = streaming_.emplace();
  s.source = std::move(source);
  s.ready = std::move(first);
  PumpStream();
}

template <typename Stream>
void SyncSession<Stream>::PumpStream() {
  Streaming& s = *streaming_;
  if (!s.writing.empty()) return;  // on_stream_write pumps again
  if (s.failed) {
    // Only now, with no write in flight: the ErrorFrame must not land inside a chunk.
    const auto [code, text] = *s.failed;
    streaming_.reset();
    return handler_.FailStore(code, text);
  }
  if (s.ready) {
    std::vector<std::string> frames = std::move(*s.ready);
    s.ready.reset();
    if (s.read == Streaming::Read::kIdle) ReadStreamBatch();
    return WriteStreamBatch(std::move(frames));
  }
  if (s.read == Streaming::Read::kReading) return;  // the next batch is on its way
  if (s.read == Streaming::Read::kIdle) return ReadStreamBatch();
  const std::shared_ptr<FrameSource> source = std::move(s.source);
  streaming_.reset();
  source->Finished();
  do_read_prefix();
}

template <typename Stream>
void SyncSession<Stream>::ReadStreamBatch() {
  Streaming& s = *streaming_;
  s.read = Streaming::Read::kReading;
  context_.store.Post([self = this->shared_from_this(), source = s.source](Repository& repository) {
    std::vector<std::string> batch;
    std::optional<std::pair<ErrorCode, std::string>> error;
    try {
      batch = source->NextBatch(repository);
    } catch (const Error& e) {
      error.emplace(e.code(), e.message());
    } catch (const std::exception& e) {
      error.emplace(ErrorCode::kBackend, e.what());
    }
    asio::post(self->executor_,
               [self, batch = std::move(batch), error = std::move(error)]() mutable {
                 if (!self->streaming_) return;
                 Streaming& stream = *self->streaming_;
                 if (error) {
                   stream.read = Streaming::Read::kAllRead;
                   stream.failed = std::move(error);
                 } else if (batch.empty()) {
                   stream.read = Streaming::Read::kAllRead;
                 } else {
                   stream.read = Streaming::Read::kIdle;
                   stream.ready = std::move(batch);
                 }
                 self->PumpStream();
               });
  });
}

template <typename Stream>
void SyncSession<Stream>::WriteStreamBatch(std::vector<std::string> frames) {
  Streaming& s = *streaming_;
  s.writing = std::move(frames);
  std::vector<asio::const_buffer> buffers;
  buffers.reserve(s.writing.size());
  for (const std::string& frame : s.writing) buffers.push_back(asio::buffer(frame));
  Arm(context_.options.io_deadline);
  asio::async_write(
      stream_, buffers,
      [self = this->shared_from_this()](boost::system::error_code ec, std::size_t bytes) {
        self->on_stream_write(ec, bytes);
      });
}

template <typename Stream>
void SyncSession<Stream>::on_stream_write(const boost::system::error_code& ec, std::size_t bytes) {
  Disarm();
  context_.activity.BytesSent(bytes);
  Streaming& s = *streaming_;
  if (ec) {
    streaming_.reset();  // a read in flight finds no stream and drops its batch
    return DownloadWriteFailed(ec);
  }
  std::vector<std::string> written = std::move(s.writing);
  s.writing.clear();
  s.source->Written(written, bytes);
  PumpStream();
}

// ---- Closing ----

template <typename Stream>
void SyncSession<Stream>::do_close() {
  closing_ = true;
  LeaveAdmission();
  // Our side is done: FIN (under TLS too; the robot reads the frames it has, then the end),
  // then what the robot still sends is drained briefly so the close does not reset.
  boost::system::error_code ignored;
  Socket().shutdown(tcp::socket::shutdown_send, ignored);
  drained_ = 0;
  Arm(welcomed() ? kLingerDeadline : kPreHelloLingerDeadline);
  do_drain();
}

template <typename Stream>
void SyncSession<Stream>::do_drain() {
  Socket().async_read_some(
      asio::buffer(drain_buffer_),
      [self = this->shared_from_this()](boost::system::error_code ec, std::size_t bytes) {
        self->on_drain(ec, bytes);
      });
}

template <typename Stream>
void SyncSession<Stream>::on_drain(const boost::system::error_code& ec, std::size_t bytes) {
  drained_ += bytes;
  const std::size_t cap = welcomed() ? kLingerBytes : kPreHelloLingerBytes;
  if (ec || drained_ > cap) {
    Disarm();
    return CloseSocket();
  }
  do_drain();
}

template <typename Stream>
void SyncSession<Stream>::CloseSocket() {
  closing_ = true;
  LeaveAdmission();
  boost::system::error_code ignored;
  Socket().shutdown(tcp::socket::shutdown_both, ignored);
  Socket().close(ignored);
}

template class SyncSession<tcp::socket>;
template class SyncSession<asio::ssl::stream<tcp::socket>>;

}  // namespace fleetmap::daemon
