#include "sync_session.h"

#ifdef __GLIBC__
#include <malloc.h>
#endif

#include <openssl/err.h>
#include <openssl/ssl.h>
#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <boost/asio/post.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/write.hpp>
#include <span>
#include <thread>
#include <type_traits>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::daemon {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

// The map a hello says the robot has, when it says one.
std::optional<v1::InstalledMap> InstalledOf(const v1::Hello& hello) {
  if (!hello.has_installed()) return std::nullopt;
  return hello.installed();
}

// A channel as a robot reports it (channel names are shorter: ValidateChannelName), and an
// author as a push names it.
constexpr std::size_t kMaxReportedChannelBytes = 64;
constexpr std::size_t kMaxAuthorBytes = 128;

// Records what a robot reports installed, and its agent's last error, after its hello was
// accepted. The text is the robot's: kept valid UTF-8, printable and short.
void RecordInstalledMap(RobotRegistry& registry, const Uuid& robot,
                        const v1::InstalledMap& installed) {
  RobotMapRecord map;
  map.channel = PrintableText(ReceivedText(installed.channel(), kMaxReportedChannelBytes));
  if (map.channel.empty()) map.channel = std::string(kHeadChannel);
  map.revision = std::max<std::int64_t>(installed.revision(), 0);
  map.digest = installed.digest();
  map.at_ns = WallClockNs();
  registry.RecordInstalled(robot, map);
  if (!installed.last_error().empty()) {
    registry.RecordError(robot, "agent: " + PrintableText(ValidUtf8(installed.last_error())),
                         map.at_ns);
  }
}

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

std::string Seconds(std::chrono::milliseconds d) {
  return fmt::format("{:g} s", static_cast<double>(d.count()) / 1000.0);
}

std::string Mib(std::uint64_t bytes) {
  return fmt::format("{:.1f} MiB", static_cast<double>(bytes) / double(1 << 20));
}

// A TLS connection opens with a handshake record (content type 22) of major version 3: what a
// plain listener sees first from an agent that speaks TLS to it.
// Of a robot's own submissions a revision lacks, listed at once (a frame of about 100 kB).
constexpr int kMaxOwnSubmissionsListed = 2000;

constexpr unsigned char kTlsHandshakeRecord = 0x16;
constexpr unsigned char kTlsMajorVersion = 0x03;

// The TLS handshake failed on its first record, which was no TLS record at all: the peer spoke
// plain bytes (an agent without TLS, whose hello starts with a frame's length).
bool NotTls(const boost::system::error_code& ec) {
  if (ec.category() != asio::error::get_ssl_category()) return false;
  const int reason = ERR_GET_REASON(static_cast<unsigned long>(ec.value()));
  return reason == SSL_R_WRONG_VERSION_NUMBER || reason == SSL_R_HTTP_REQUEST ||
         reason == SSL_R_UNKNOWN_PROTOCOL;
}

// Issue 35 item 11: a robot pushes in its own name only. A chunk whose node or path names
// another robot (or none) is refused whole, saying which, before it is stored; the robot keeps
// its content. A chunk that does not decode passes here: the push's end stores it failed with
// the reason, as any content MERGE cannot take.
void RequireOwnContent(const std::string& chunk, std::uint32_t seq, const Uuid& robot,
                       const std::string& robot_name) {
  GraphBatch content;
  try {
    content = DecodeMapChunks(std::span<const std::string>(&chunk, 1));
  } catch (const Error&) {
    return;
  }
  const auto refuse = [&](const char* kind, const Uuid& id, const Uuid& named) {
    throw Error(ErrorCode::kInvalidArgument,
                "push_chunk " + std::to_string(seq) + ": " + kind + " " + id.ToString() +
                    " names robot " + (named.IsNil() ? std::string("(none)") : named.ToString()) +
                    ", but this session is robot " + robot_name + " (" + robot.ToString() +
                    "): a robot pushes its own nodes only; nothing stored");
  };
  for (const Node& node : content.nodes) {
    if (node.robot != robot) refuse("node", node.id, node.robot);
  }
  for (const Path& path : content.paths) {
    if (path.robot != robot) refuse("path", path.id, path.robot);
  }
}

// Both refusals of a hello say this and nothing more: which of the two it was would tell a
// stranger which robot ids are registered. The log says which.
constexpr std::string_view kHelloRefused = "unknown robot or wrong token";

}  // namespace

template <typename Stream>
SyncSession<Stream>::SyncSession(Stream stream, SessionContext& context, std::string peer)
    : stream_(std::move(stream)),
      executor_(Socket().get_executor()),
      context_(context),
      peer_(std::move(peer)),
      hello_by_(std::chrono::steady_clock::now() + context.options.hello_deadline),
      deadline_(executor_),
      merge_wait_(executor_) {
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
  refused_ = admission_ticket == 0;
  asio::post(executor_, [self = this->shared_from_this()] {
    if constexpr (std::is_same_v<Stream, tcp::socket>) {
      if (self->refused_) return self->FailFull();
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
    self->merge_wait_.cancel();                       // answers the status now; then SHUTTING_DOWN
  });
}

template <typename Stream>
void SyncSession<Stream>::Evict(const std::string& why) {
  asio::post(executor_, [self = this->shared_from_this(), why] {
    if (self->hello_received_ || self->evicted_ || self->phase_ != Phase::kHello) return;
    self->evicted_ = true;
    self->evicted_why_ = why;
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
  if (robot_joined_) context_.robots.LeaveSession(robot_);
  robot_joined_ = false;
}

template <typename Stream>
void SyncSession<Stream>::ReleaseFrame() {
  if (frame_reserved_ > 0) context_.robots.ReleaseFrame(robot_, frame_reserved_);
  frame_reserved_ = 0;
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
  if (welcomed_) return context_.options.io_deadline;
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
  if (evicted_) {
    // Under TLS nothing can be said before the handshake ends: it just closes.
    if (ec) {
      close_reason_ = "BUSY (before the TLS handshake ended): " + evicted_why_;
      spdlog::warn("session {} refused: {}", peer_, close_reason_);
      return CloseSocket();
    }
    return Fail(v1::ErrorFrame::BUSY, evicted_why_);
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
  if (refused_) return FailFull();
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
  if (evicted_) return Fail(v1::ErrorFrame::BUSY, evicted_why_);
  if (ec) {
    if (timed_out_ && !welcomed_) {
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
    if (!welcomed_ && p[0] == kTlsHandshakeRecord && p[1] == kTlsMajorVersion) {
      // Issue 35 item 9: said in the log; a frame back would only garble the peer's handshake.
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
  if (!welcomed_ && length > kMaxPreHelloFrameBytes) {
    return Fail(v1::ErrorFrame::FRAME_TOO_LARGE,
                "a frame of " + std::to_string(length) +
                    " bytes before a hello was accepted: until then a frame is at most " +
                    std::to_string(kMaxPreHelloFrameBytes) + " bytes");
  }
  if (welcomed_) {
    // Issue 35 item 8: room for the whole frame among the robot's, before a byte of it.
    std::uint64_t in_flight = 0;
    if (!context_.robots.ReserveFrame(robot_, length, in_flight)) {
      return Fail(v1::ErrorFrame::BUSY,
                  "a frame of " + Mib(length) + " while robot " + robot_name_ + " has " +
                      Mib(in_flight) +
                      " of frames in flight across its sessions, over its cap of " +
                      Mib(context_.robots.limits().frame_bytes) +
                      " (fleetmapd --max-inflight-mib-per-robot); retry when they are done");
    }
    frame_reserved_ = length;
  }
  do_read_body(length);
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
  if (evicted_) return Fail(v1::ErrorFrame::BUSY, evicted_why_);
  if (ec) {
    const std::string got = std::to_string(body_.size()) + " of the " +
                            std::to_string(body_length_) + " bytes announced";
    if (timed_out_ && !welcomed_) {
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
  Handle(frame);
}

// ---- Writing ----

template <typename Stream>
void SyncSession<Stream>::do_write(std::shared_ptr<const std::string> frame,
                                   std::function<void()> next) {
  out_ = std::move(frame);
  after_write_ = std::move(next);
  const std::chrono::milliseconds error_deadline =
      welcomed_ ? kErrorWriteDeadline : kPreHelloErrorWriteDeadline;
  Arm(phase_ == Phase::kClosing ? std::min(error_deadline, context_.options.io_deadline)
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
void SyncSession<Stream>::Reply(const v1::SyncFrame& frame) {
  do_write(std::make_shared<const std::string>(EncodeSyncFrame(frame)),
           [self = this->shared_from_this()] { self->do_read_prefix(); });
}

template <typename Stream>
void SyncSession<Stream>::Fail(ErrorCodeV1 code, const std::string& text) {
  if (phase_ == Phase::kClosing) return;
  phase_ = Phase::kClosing;
  LeaveAdmission();
  const std::string name = v1::ErrorFrame::Code_Name(code);
  close_reason_ = name + ": " + text;
  spdlog::warn("session {} refused: {}: {}", Who(), name, PrintableText(text));
  context_.activity.ErrorSent(name);
  if (welcomed_) RecordRobotError(name + ": " + text);
  v1::SyncFrame frame;
  frame.mutable_error()->set_code(code);
  frame.mutable_error()->set_text(text);
  do_write(std::make_shared<const std::string>(EncodeSyncFrame(frame)),
           [self = this->shared_from_this()] { self->do_close(); });
}

template <typename Stream>
void SyncSession<Stream>::RecordRobotError(const std::string& error) {
  // Best effort, after the fact: the robot's listing shows it; a store that cannot write it
  // (the reason for the error, perhaps) only loses the line.
  context_.store.Post([robot = robot_, error = PrintableText(error)](Repository& repository) {
    try {
      RobotRegistry(repository.versions()).RecordError(robot, error, WallClockNs());
    } catch (const std::exception&) {
    }
  });
}

template <typename Stream>
void SyncSession<Stream>::FailStore(ErrorCode code, const std::string& text) {
  switch (code) {
    case ErrorCode::kNotFound:
      return Fail(v1::ErrorFrame::NOT_FOUND, text);
    case ErrorCode::kConflict:
      return Fail(v1::ErrorFrame::CONFLICT, text);
    case ErrorCode::kInvalidArgument:
    case ErrorCode::kCorrupt:
    case ErrorCode::kIntegrity:
      return Fail(v1::ErrorFrame::INVALID, text);
    default:
      spdlog::error("session {}: the store failed: {}", Who(), text);
      return Fail(v1::ErrorFrame::INTERNAL, "the server's store failed (retry later): " + text);
  }
}

// ---- Closing ----

template <typename Stream>
void SyncSession<Stream>::do_close() {
  phase_ = Phase::kClosing;
  LeaveAdmission();
  // Our side is done: FIN (under TLS too; the robot reads the frames it has, then the end),
  // then what the robot still sends is drained briefly so the close does not reset.
  boost::system::error_code ignored;
  Socket().shutdown(tcp::socket::shutdown_send, ignored);
  drained_ = 0;
  Arm(welcomed_ ? kLingerDeadline : kPreHelloLingerDeadline);
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
  if (ec || drained_ > (welcomed_ ? kLingerBytes : kPreHelloLingerBytes)) {
    Disarm();
    return CloseSocket();
  }
  do_drain();
}

template <typename Stream>
void SyncSession<Stream>::CloseSocket() {
  phase_ = Phase::kClosing;
  LeaveAdmission();
  boost::system::error_code ignored;
  Socket().shutdown(tcp::socket::shutdown_both, ignored);
  Socket().close(ignored);
}

// ---- Store calls ----

template <typename Stream>
template <typename Work, typename Done>
void SyncSession<Stream>::OnStore(Work work, Done done) {
  context_.store.Post([self = this->shared_from_this(), work = std::move(work),
                       done = std::move(done)](Repository& repository) mutable {
    using Result = decltype(work(repository));
    std::optional<Result> result;
    std::optional<std::pair<ErrorCode, std::string>> error;
    try {
      result.emplace(work(repository));
    } catch (const Error& e) {
      error.emplace(e.code(), e.message());
    } catch (const std::exception& e) {
      error.emplace(ErrorCode::kBackend, e.what());
    }
    asio::post(self->executor_, [self, result = std::move(result), error = std::move(error),
                                 done = std::move(done)]() mutable {
      if (error) return self->FailStore(error->first, error->second);
      done(std::move(*result));
    });
  });
}

// ---- Exchanges ----

template <typename Stream>
void SyncSession<Stream>::Handle(const v1::SyncFrame& frame) {
  const std::string name(SyncFrameName(frame));
  using F = v1::SyncFrame;
  if (frame.body_case() == F::kBye) {
    close_reason_ = "bye";
    return do_close();
  }
  switch (phase_) {
    case Phase::kHello:
      if (frame.body_case() != F::kHello) {
        return Fail(v1::ErrorFrame::OUT_OF_ORDER,
                    name + " before hello: a session opens with hello");
      }
      return OnHello(frame.hello());
    case Phase::kReady:
      switch (frame.body_case()) {
        case F::kPushBegin:
          return OnPushBegin(frame.push_begin());
        case F::kMergeStatusRequest:
          return OnMergeStatusRequest(frame.merge_status_request());
        case F::kDownloadRequest:
          return OnDownloadRequest(frame.download_request());
        case F::kOwnSubmissionsRequest:
          return OnOwnSubmissionsRequest(frame.own_submissions_request());
        case F::kSubmissionChunkRequest:
          return OnSubmissionChunkRequest(frame.submission_chunk_request());
        case F::kPushChunk:
        case F::kPushEnd:
          return Fail(v1::ErrorFrame::OUT_OF_ORDER,
                      name + " without a push in progress (push_begin first)");
        default:
          return Fail(v1::ErrorFrame::OUT_OF_ORDER,
                      name +
                          " does not start an exchange (push_begin, merge_status_request, "
                          "download_request, own_submissions_request, "
                          "submission_chunk_request or bye)");
      }
    case Phase::kPushing:
      switch (frame.body_case()) {
        case F::kPushChunk:
          return OnPushChunk(frame.push_chunk());
        case F::kPushEnd:
          return OnPushEnd();
        default:
          return Fail(v1::ErrorFrame::OUT_OF_ORDER,
                      name + " during a push (expected push_chunk or push_end)");
      }
    case Phase::kClosing:
      return;
  }
}

template <typename Stream>
void SyncSession<Stream>::OnHello(const v1::Hello& hello) {
  hello_received_ = true;
  context_.admission.HelloReceived(admission_ticket_);  // it can no longer be evicted
  if (hello.protocol_version() < kOldestSyncProtocolVersion ||
      hello.protocol_version() > kSyncProtocolVersion) {
    return Fail(v1::ErrorFrame::UNSUPPORTED_VERSION,
                "protocol version " + std::to_string(hello.protocol_version()) +
                    ": this server speaks versions " + std::to_string(kOldestSyncProtocolVersion) +
                    " to " + std::to_string(kSyncProtocolVersion));
  }
  // An older robot is answered in its own version (sync.proto "Versions").
  protocol_version_ = hello.protocol_version();
  if (hello.robot_id().size() != Uuid::kSize) {
    // The id's form, not whether it is registered: this says nothing a stranger may not know.
    return Fail(v1::ErrorFrame::INVALID, "hello: a robot id of " +
                                             std::to_string(hello.robot_id().size()) +
                                             " bytes: robot ids are 16 bytes (a UUID)");
  }
  const Uuid robot = Uuid::FromBytes(hello.robot_id());
  struct Result {
    RobotAuthenticationResult auth;
    RevisionNumber head = 0;
    std::string sync_not_recorded;  // why the last sync was not written, when it was not
  };
  OnStore(
      [robot, token = hello.token(), installed = InstalledOf(hello)](Repository& repository) {
        RobotRegistry registry(repository.versions());
        Result result{registry.Authenticate(robot, token), 0, {}};
        if (result.auth.outcome == RobotAuthentication::kAccepted) {
          result.head = repository.Head();
          // Best effort, and last: a store that cannot write (its disk full) must not stop a
          // robot from downloading; the time is kept in memory (ServerActivity) meanwhile.
          try {
            registry.RecordSync(robot, WallClockNs());
            if (installed) RecordInstalledMap(registry, robot, *installed);
          } catch (const std::exception& error) {
            result.sync_not_recorded = error.what();
          }
        }
        return result;
      },
      [self = this->shared_from_this(), robot, agent = hello.agent()](Result result) {
        switch (result.auth.outcome) {
          case RobotAuthentication::kUnknownRobot:
            spdlog::warn("session {}: hello refused: no robot {} is registered here", self->Who(),
                         robot.ToString());
            return self->Fail(v1::ErrorFrame::BAD_TOKEN, std::string(kHelloRefused));
          case RobotAuthentication::kBadToken:
            spdlog::warn("session {}: hello refused: wrong token for robot {}", self->Who(),
                         robot.ToString());
            return self->Fail(v1::ErrorFrame::BAD_TOKEN, std::string(kHelloRefused));
          case RobotAuthentication::kAccepted:
            break;
        }
        self->robot_ = robot;
        self->robot_name_ = result.auth.robot->name;
        if (!self->context_.robots.JoinSession(robot)) {  // issue 35 item 8
          return self->Fail(v1::ErrorFrame::BUSY,
                            "robot " + self->robot_name_ + " holds its maximum of " +
                                std::to_string(self->context_.robots.limits().sessions) +
                                " sessions (fleetmapd --max-sessions-per-robot); retry when one "
                                "ends");
        }
        self->robot_joined_ = true;
        self->phase_ = Phase::kReady;
        self->welcomed_ = true;
        self->context_.activity.RobotSynced(*result.auth.robot, WallClockNs());
        if (!result.sync_not_recorded.empty()) {
          self->context_.activity.LastSyncNotRecorded();
          spdlog::warn(
              "session {}: the last sync of robot {} was not written to the store ({}); "
              "kept in memory only, the hello goes on",
              self->Who(), robot.ToString(), result.sync_not_recorded);
        }
        spdlog::info("session {} opened: robot {} ({}), {}", self->Who(), self->robot_name_,
                     robot.ToString(), agent.empty() ? "agent unnamed" : PrintableText(agent));
        v1::SyncFrame frame;
        v1::Welcome& welcome = *frame.mutable_welcome();
        welcome.set_protocol_version(self->protocol_version_);
        welcome.set_head_revision(result.head);
        welcome.set_robot_name(self->robot_name_);
        welcome.set_max_frame_bytes(kMaxSyncFrameBytes);
        welcome.set_max_submission_bytes(self->context_.options.max_submission_bytes);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnPushBegin(const v1::PushBegin& begin) {
  if (begin.submission_id().size() != Uuid::kSize) {
    return Fail(v1::ErrorFrame::INVALID, "push_begin: a submission id of " +
                                             std::to_string(begin.submission_id().size()) +
                                             " bytes (ids are 16 bytes)");
  }
  if (begin.chunk_count() == 0) {
    return Fail(v1::ErrorFrame::INVALID,
                "push_begin: 0 chunks announced (even an empty map has one chunk)");
  }
  const std::uint64_t limit = context_.options.max_submission_bytes;
  if (begin.total_bytes() > limit) {
    return Fail(v1::ErrorFrame::INVALID, "push_begin: " + std::to_string(begin.total_bytes()) +
                                             " bytes announced (" + Mib(begin.total_bytes()) +
                                             "), over this server's limit of " +
                                             std::to_string(limit) + " bytes (" + Mib(limit) +
                                             ") a submission (fleetmapd --max-submission-mib)");
  }
  const Uuid id = Uuid::FromBytes(begin.submission_id());
  OnStore(
      [id, robot = robot_, author = begin.author()](Repository& repository) {
        return repository.BeginChunkedPush(
            id, robot, author.empty() ? robot.ToString() : ReceivedText(author, kMaxAuthorBytes));
      },
      [self = this->shared_from_this(), begin](Submission stored) {
        if (stored.robot != self->robot_) {  // issue 35 item 11: not another robot's to resume
          return self->Fail(v1::ErrorFrame::CONFLICT,
                            "push_begin: submission " + stored.id.ToString() +
                                " cannot be pushed from this robot; push under a new id");
        }
        const bool complete = stored.state != SubmissionState::kReceiving;
        if (complete && stored.digest != begin.digest()) {
          return self->Fail(v1::ErrorFrame::CONFLICT,
                            "submission " + stored.id.ToString() +
                                " is stored whole with another content (another digest)");
        }
        if (stored.chunk_count > begin.chunk_count()) {
          return self->Fail(v1::ErrorFrame::CONFLICT,
                            "submission " + stored.id.ToString() + " has " +
                                std::to_string(stored.chunk_count) +
                                " chunks stored, more than the " +
                                std::to_string(begin.chunk_count()) + " announced");
        }
        if (!complete && stored.chunk_count > 0) {
          spdlog::info("push {} from {}: resuming at chunk {} of {}", stored.id.ToString(),
                       self->Who(), stored.chunk_count, begin.chunk_count());
        }
        Push push;
        push.submission = stored.id;
        push.chunk_count = begin.chunk_count();
        push.digest = begin.digest();
        push.total_bytes = begin.total_bytes();
        push.next_seq = static_cast<std::uint32_t>(stored.chunk_count);
        push.bytes = static_cast<std::uint64_t>(stored.bytes);
        push.complete = complete;
        self->push_ = push;
        self->phase_ = Phase::kPushing;
        v1::SyncFrame frame;
        v1::PushReady& ready = *frame.mutable_push_ready();
        ready.set_submission_id(stored.id.ToBytesString());
        ready.set_next_chunk(push.next_seq);
        ready.set_complete(complete);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnPushChunk(v1::PushChunk chunk) {
  const std::uint32_t seq = chunk.seq();
  if (seq > push_->next_seq) {
    return Fail(
        v1::ErrorFrame::OUT_OF_ORDER,
        "push_chunk " + std::to_string(seq) + " before chunk " + std::to_string(push_->next_seq));
  }
  if (seq >= push_->chunk_count) {
    return Fail(v1::ErrorFrame::INVALID, "push_chunk " + std::to_string(seq) + " past the " +
                                             std::to_string(push_->chunk_count) +
                                             " chunks announced");
  }
  // What the robot encoded, checked before a byte is stored: a chunk damaged on the way (or in
  // the robot's memory) is refused whole, and the robot sends it again.
  if (chunk.digest() != DigestOfChunk(chunk.data())) {
    return Fail(v1::ErrorFrame::CHUNK_DIGEST,
                "chunk " + std::to_string(seq) + " does not match its digest; nothing stored");
  }
  const std::uint64_t size = chunk.data().size();
  if (seq == push_->next_seq) {  // a new chunk (an earlier one again is checked by the store)
    const std::uint64_t after = push_->bytes + size;
    const std::uint64_t limit = context_.options.max_submission_bytes;
    if (after > limit) {
      return Fail(v1::ErrorFrame::INVALID,
                  "push_chunk " + std::to_string(seq) + ": the submission would reach " +
                      std::to_string(after) + " bytes, over this server's limit of " +
                      std::to_string(limit) + " bytes (" + Mib(limit) +
                      ") a submission (fleetmapd --max-submission-mib); nothing stored");
    }
    if (after > push_->total_bytes) {
      return Fail(v1::ErrorFrame::INVALID,
                  "push_chunk " + std::to_string(seq) + ": the submission would reach " +
                      std::to_string(after) + " bytes, more than the " +
                      std::to_string(push_->total_bytes) +
                      " announced at push_begin (total_bytes); nothing stored");
    }
  }
  auto data = std::make_shared<const std::string>(std::move(*chunk.mutable_data()));
  OnStore(
      [id = push_->submission, seq, data, robot = robot_, name = robot_name_,
       delay = context_.options.debug_chunk_delay](Repository& repository) {
        if (delay.count() > 0) std::this_thread::sleep_for(delay);
        RequireOwnContent(*data, seq, robot, name);
        repository.PutPushChunk(id, seq, *data);
        return seq;
      },
      [self = this->shared_from_this(), size](std::uint32_t stored) {
        if (stored == self->push_->next_seq) {
          ++self->push_->next_seq;
          self->push_->bytes += size;
        }
        v1::SyncFrame frame;
        frame.mutable_push_chunk_ack()->set_seq(stored);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnPushEnd() {
  if (!push_->complete && push_->next_seq < push_->chunk_count) {
    return Fail(v1::ErrorFrame::OUT_OF_ORDER, "push_end after " + std::to_string(push_->next_seq) +
                                                  " of the " + std::to_string(push_->chunk_count) +
                                                  " chunks announced");
  }
  struct Result {
    Submission submission;
    std::uint32_t position = 0;
  };
  OnStore(
      [id = push_->submission, digest = push_->digest, robot = robot_,
       &merges = context_.merges](Repository& repository) {
        Result result{repository.CompleteChunkedPush(id, digest), 0};
        if (result.submission.state == SubmissionState::kQueued) {
          result.position = merges.Enqueue(id, robot);
        }
        return result;
      },
      [self = this->shared_from_this()](Result result) {
        const Submission& s = result.submission;
        self->phase_ = Phase::kReady;
        self->push_.reset();
        self->context_.activity.PushAccepted(self->robot_);
        spdlog::info("push {} from {}: {} chunks, {} bytes, {} (queue position {})",
                     s.id.ToString(), self->Who(), s.chunk_count, s.bytes,
                     SubmissionStateName(s.state), result.position);
        v1::SyncFrame frame;
        v1::PushAccepted& accepted = *frame.mutable_push_accepted();
        accepted.set_submission_id(s.id.ToBytesString());
        accepted.set_state(std::string(SubmissionStateName(s.state)));
        accepted.set_revision(s.revision);
        accepted.set_queue_position(result.position);
        accepted.set_error(s.error);  // why, when it failed
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnMergeStatusRequest(const v1::MergeStatusRequest& request) {
  if (request.submission_id().size() != Uuid::kSize) {
    return Fail(v1::ErrorFrame::INVALID, "merge_status_request: a submission id of " +
                                             std::to_string(request.submission_id().size()) +
                                             " bytes (ids are 16 bytes)");
  }
  QueryMergeStatus(Uuid::FromBytes(request.submission_id()), request.wait_ms() > 0,
                   request.wait_ms());
}

template <typename Stream>
void SyncSession<Stream>::QueryMergeStatus(const Uuid& id, bool may_wait, std::uint32_t wait_ms) {
  OnStore(
      [id, robot = robot_, &merges = context_.merges](Repository& repository) {
        const std::optional<Submission> s = repository.versions().FindSubmission(id);
        // Another robot's submission is answered as one never pushed (issue 35 item 11): the
        // answer tells no robot what the others pushed.
        if (!s || s->robot != robot) {
          throw Error(ErrorCode::kNotFound, "no submission " + id.ToString() + " is stored");
        }
        v1::MergeStatus status;
        status.set_submission_id(id.ToBytesString());
        status.set_state(std::string(SubmissionStateName(s->state)));
        status.set_revision(s->revision);
        status.set_error(s->error);
        if (s->state == SubmissionState::kMerged) {
          if (const std::optional<Revision> r = repository.versions().FindRevision(s->revision)) {
            status.set_nodes_added(r->nodes_added);
          }
        }
        if (s->state == SubmissionState::kQueued) {
          // Queued in the store but not in this server's queue (pushed with `fleetmap push`, or
          // left by a failure): queue it, so it merges and a wait below has a merge to watch.
          if (!merges.Position(id)) merges.Enqueue(id, s->robot);
          if (merges.IsMerging(id)) status.set_state("merging");
          status.set_queue_position(merges.Position(id).value_or(0));
          const MergeQueue::Retries retries = merges.RetriesOf(id);
          status.set_merge_attempts(retries.attempts);
          if (status.error().empty()) status.set_error(retries.last_error);
        }
        return status;
      },
      [self = this->shared_from_this(), id, may_wait, wait_ms](v1::MergeStatus status) {
        const bool pending = status.state() == "queued" || status.state() == "merging";
        if (may_wait && pending && !self->shutting_down_) {
          const auto wait =
              std::min(std::chrono::milliseconds(wait_ms), self->context_.options.merge_wait_cap);
          self->merge_wait_.expires_after(wait);
          self->merge_wait_.async_wait([self, id](boost::system::error_code) {
            self->QueryMergeStatus(id, false, 0);  // expired, or the merge finished
          });
          const bool watching = self->context_.merges.Watch(
              id, [weak = self->weak_from_this(), executor = self->executor_] {
                asio::post(executor, [weak] {
                  if (auto session = weak.lock()) session->merge_wait_.cancel();
                });
              });
          if (!watching) self->merge_wait_.cancel();  // it finished in between: ask again now
          return;
        }
        v1::SyncFrame frame;
        *frame.mutable_merge_status() = std::move(status);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnOwnSubmissionsRequest(const v1::OwnSubmissionsRequest& request) {
  OnStore(
      [robot = robot_, after = request.after_revision()](Repository& repository) {
        v1::OwnSubmissions listed;
        for (const Submission& s : repository.versions().ListSubmissions()) {
          if (s.robot != robot || s.state == SubmissionState::kReceiving) continue;
          if (s.state == SubmissionState::kMerged && s.revision <= after) continue;
          if (listed.submissions_size() == kMaxOwnSubmissionsListed) {
            listed.set_truncated(true);
            break;
          }
          v1::OwnSubmission& entry = *listed.add_submissions();
          entry.set_submission_id(s.id.ToBytesString());
          entry.set_state(std::string(SubmissionStateName(s.state)));
          entry.set_revision(s.revision);
          entry.set_error(s.error);
          entry.set_chunk_count(static_cast<std::uint32_t>(s.chunk_count));
          entry.set_digest(s.digest);
        }
        return listed;
      },
      [self = this->shared_from_this()](v1::OwnSubmissions listed) {
        v1::SyncFrame frame;
        *frame.mutable_own_submissions() = std::move(listed);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnSubmissionChunkRequest(const v1::SubmissionChunkRequest& request) {
  if (request.submission_id().size() != Uuid::kSize) {
    return Fail(v1::ErrorFrame::INVALID, "submission_chunk_request: a submission id of " +
                                             std::to_string(request.submission_id().size()) +
                                             " bytes (ids are 16 bytes)");
  }
  const Uuid id = Uuid::FromBytes(request.submission_id());
  OnStore(
      [id, robot = robot_, seq = request.seq()](Repository& repository) {
        const std::optional<Submission> s = repository.versions().FindSubmission(id);
        // Another robot's submission is answered as one never pushed: no robot reads what the
        // others pushed.
        if (!s || s->robot != robot) {
          throw Error(ErrorCode::kNotFound, "no submission " + id.ToString() + " is stored");
        }
        if (s->state == SubmissionState::kReceiving) {
          throw Error(ErrorCode::kInvalidArgument,
                      "submission " + id.ToString() + " is not complete: push it again");
        }
        if (seq >= s->chunk_count) {
          throw Error(ErrorCode::kInvalidArgument, "submission " + id.ToString() + " has " +
                                                       std::to_string(s->chunk_count) +
                                                       " chunks, no chunk " + std::to_string(seq));
        }
        v1::SubmissionChunk chunk;
        chunk.set_submission_id(id.ToBytesString());
        chunk.set_seq(seq);
        chunk.set_data(repository.versions().SubmissionChunk(id, seq));
        return chunk;
      },
      [self = this->shared_from_this()](v1::SubmissionChunk chunk) {
        v1::SyncFrame frame;
        *frame.mutable_submission_chunk() = std::move(chunk);
        self->Reply(frame);
      });
}

template <typename Stream>
void SyncSession<Stream>::OnDownloadRequest(const v1::DownloadRequest& request) {
  bool route = false;
  try {
    // Refuse a bad request before it costs the store anything.
    route = PolicyOfRequest(request).route.has_value();
  } catch (const Error& error) {
    return Fail(v1::ErrorFrame::INVALID, "download_request: " + error.message());
  }
  // A route is planned within the robot's allowance (robot_allowance.h): the slot is held until
  // the store job is done with it (the job, and the slot with it, is destroyed once it ran).
  std::shared_ptr<RoutePlanSlot> route_slot;
  if (route) {
    if (!context_.robots.ReserveRoutePlan(robot_)) {
      return Fail(v1::ErrorFrame::BUSY,
                  "download_request: robot " + robot_name_ + " has its maximum of " +
                      std::to_string(context_.robots.limits().route_plans) +
                      " route downloads being planned (fleetmapd --max-route-plans-per-robot); "
                      "retry when one ends");
    }
    route_slot = std::make_shared<RoutePlanSlot>(context_.robots, robot_);
  }
  // Either a whole download (from the cache, or encoded whole for a version 2 robot) or the
  // plan of one to stream.
  struct Result {
    std::shared_ptr<const EncodedDownload> download;
    std::shared_ptr<const DownloadPlan> plan;
    std::string key;
    bool cached = false;
  };
  download_start_ = std::chrono::steady_clock::now();
  download_channel_ = ChannelOfRequest(request);
  OnStore(
      [request, version = protocol_version_, &cache = context_.downloads,
       route_slot = std::move(route_slot)](Repository& repository) {
        // The channel's revision (channel_registry.h); the head for "head".
        const RevisionNumber head = ChannelRegistry(repository).Resolve(request.channel());
        Result result;
        result.key = DownloadCache::Key(head, request, version);
        DownloadCache::Entry kept = cache.Find(result.key);
        result.cached = kept.encoded || kept.plan;
        result.download = std::move(kept.encoded);
        result.plan = std::move(kept.plan);
        if (result.cached) return result;
        if (version < 3) {
          // Version 2 announces the totals in the header: it can only be sent encoded whole.
          result.download = EncodeDownload(repository, request, head, version);
          cache.Put(result.key, result.download);
        } else {
          result.plan = cache.PlanOnce(
              result.key, [&] { return PlanDownload(repository, request, head, version); });
        }
        return result;
      },
      [self = this->shared_from_this()](Result result) {
        if (result.download) {
          self->download_ = std::move(result.download);
          self->download_cached_ = result.cached;
          return self->do_write_download(0);
        }
        self->StartStreaming(std::move(result.plan), std::move(result.key), result.cached);
      });
}

template <typename Stream>
void SyncSession<Stream>::LogDownload(const DownloadReport& report,
                                      const v1::DownloadHeader& header, std::uint32_t chunks,
                                      std::uint64_t frame_bytes, std::uint64_t sent_digest,
                                      std::uint64_t removed_digest, const char* how) {
  const double seconds = SecondsSince(download_start_);
  spdlog::info(
      "download to {}: policy {}, revision {} (base {}), {} nodes, {} chunks, {} bytes in "
      "{:.3f} s ({:.1f} MB/s){}",
      Who(), report.policy, header.revision(), header.base_revision(), header.nodes(), chunks,
      frame_bytes, seconds, seconds > 0 ? static_cast<double>(frame_bytes) / 1e6 / seconds : 0.0,
      how);
  context_.activity.DownloadSent(robot_);
  RecordSent(header, sent_digest, removed_digest);
}

template <typename Stream>
void SyncSession<Stream>::RecordSent(const v1::DownloadHeader& header, std::uint64_t sent_digest,
                                     std::uint64_t removed_digest) {
  RobotMapRecord sent;
  sent.channel = download_channel_;
  sent.revision = header.revision();
  sent.at_ns = WallClockNs();
  // Best effort, without waiting (the robot is not kept for it): what the robot was sent, as a
  // SelectionDigest of the selection it now makes. Incremental: the last sent selection's,
  // when the robot's base is that one, plus what came minus what went; else unknown (0) until
  // a full download.
  context_.store.Post([robot = robot_, sent, sent_digest, removed_digest,
                       base = header.base_revision()](Repository& repository) mutable {
    try {
      RobotRegistry registry(repository.versions());
      if (base == 0) {
        sent.digest = sent_digest;
      } else if (const std::optional<RegisteredRobot> known = registry.Find(robot);
                 known && known->sent && known->sent->revision == base &&
                 known->sent->digest != 0) {
        sent.digest = known->sent->digest + sent_digest - removed_digest;  // modulo 2^64
      }
      registry.RecordSent(robot, sent);
    } catch (const std::exception& error) {
      spdlog::warn("the download sent to robot {} was not recorded: {}", robot.ToString(),
                   error.what());
    }
  });
}

template <typename Stream>
void SyncSession<Stream>::do_write_download(std::size_t index) {
  if (index == download_->frames.size()) {
    LogDownload(download_->report, download_->header, download_->end.chunk_count(),
                download_->frame_bytes, download_->sent_digest, download_->removed_digest,
                download_cached_                  ? ", from memory"
                : download_->protocol_version < 3 ? ", encoded whole (protocol version 2)"
                                                  : "");
    download_.reset();
    return do_read_prefix();
  }
  Arm(context_.options.io_deadline);
  // Straight from the encoded download: no copy per write.
  asio::async_write(
      stream_, asio::buffer(download_->frames[index]),
      [self = this->shared_from_this(), index](boost::system::error_code ec, std::size_t bytes) {
        self->Disarm();
        self->context_.activity.BytesSent(bytes);
        if (ec) {
          self->close_reason_ = self->timed_out_
                                    ? "the robot did not take a download frame within " +
                                          Seconds(self->context_.options.io_deadline)
                                    : "download write failed: " + ec.message();
          spdlog::warn("session {}: {}", self->Who(), self->close_reason_);
          return self->CloseSocket();
        }
        self->do_write_download(index + 1);
      });
}

// ---- Streamed downloads (protocol version 3) ----
//
// Two batches at most are alive: the one being written and the next, being read and encoded on
// a store worker meanwhile. The read after that starts only when the write ends (back-pressure:
// a slow robot slows the reads, it does not pile batches up in memory).

template <typename Stream>
void SyncSession<Stream>::StartStreaming(std::shared_ptr<const DownloadPlan> plan, std::string key,
                                         bool plan_cached) {
  streaming_.emplace();
  Streaming& s = *streaming_;
  s.encoder =
      std::make_shared<DownloadEncoder>(std::move(plan), context_.options.download_batch_bytes);
  s.cache_key = std::move(key);
  // Frames are kept for the cache only when the download looks small enough for it (node count
  // times the map's mean node), so a big map never piles up frames it will drop; a guess too
  // low is caught in on_stream_write.
  const DownloadPlan& p = s.encoder->plan();
  const std::uint64_t estimate =
      p.nodes.size() * static_cast<std::uint64_t>(std::max<std::int64_t>(p.mean_node_bytes, 0)) +
      (p.edges.size() + p.paths.size()) * 128;
  s.keep_all = estimate <= context_.options.download_cache_entry_bytes;
  s.plan_cached = plan_cached;
  // The plan itself is already kept (DownloadCache::PlanOnce): a big download, never kept
  // encoded, streams at once when asked again, without a second selection.
  s.ready.emplace();
  s.ready->push_back(HeaderFrame(s.encoder->plan().header));
  PumpStream();
}

template <typename Stream>
void SyncSession<Stream>::PumpStream() {
  Streaming& s = *streaming_;
  if (s.writing) return;  // on_stream_write pumps again
  if (s.failed) {
    // Only now, with no write in flight: the ErrorFrame must not land inside a chunk.
    const auto [code, text] = *s.failed;
    streaming_.reset();
    return FailStore(code, text);
  }
  if (s.ready) {
    std::vector<std::string> frames = std::move(*s.ready);
    s.ready.reset();
    if (!s.reading && !s.read_all && !s.end_sent) ReadStreamBatch();
    return WriteStreamBatch(std::move(frames));
  }
  if (s.reading) return;  // the next batch is on its way
  if (!s.read_all) return ReadStreamBatch();
  if (!s.end_sent) {
    s.end_sent = true;
    std::vector<std::string> end;
    end.push_back(EndFrame(s.encoder->End()));
    return WriteStreamBatch(std::move(end));
  }
  FinishStreaming();
}

template <typename Stream>
void SyncSession<Stream>::ReadStreamBatch() {
  Streaming& s = *streaming_;
  s.reading = true;
  context_.store.Post(
      [self = this->shared_from_this(), encoder = s.encoder](Repository& repository) {
        std::vector<std::string> batch;
        std::optional<std::pair<ErrorCode, std::string>> error;
        try {
          batch = encoder->NextBatch(repository);
        } catch (const Error& e) {
          error.emplace(e.code(), e.message());
        } catch (const std::exception& e) {
          error.emplace(ErrorCode::kBackend, e.what());
        }
        asio::post(self->executor_,
                   [self, batch = std::move(batch), error = std::move(error)]() mutable {
                     if (!self->streaming_) return;
                     Streaming& stream = *self->streaming_;
                     stream.reading = false;
                     if (error) {
                       stream.failed = std::move(error);
                     } else if (batch.empty()) {
                       stream.read_all = true;
                     } else {
                       stream.ready = std::move(batch);
                     }
                     self->PumpStream();
                   });
      });
}

template <typename Stream>
void SyncSession<Stream>::WriteStreamBatch(std::vector<std::string> frames) {
  Streaming& s = *streaming_;
  s.writing = true;
  s.frames = std::move(frames);
  std::vector<asio::const_buffer> buffers;
  buffers.reserve(s.frames.size());
  for (const std::string& frame : s.frames) buffers.push_back(asio::buffer(frame));
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
  s.writing = false;
  if (ec) {
    close_reason_ = timed_out_ ? "the robot did not take a download frame within " +
                                     Seconds(context_.options.io_deadline)
                               : "download write failed: " + ec.message();
    spdlog::warn("session {}: {}", Who(), close_reason_);
    streaming_.reset();  // a read in flight finds no stream and drops its batch
    return CloseSocket();
  }
  s.frame_bytes += bytes;
  // Kept for the cache while the download stays small; a big one is sent and forgotten.
  if (s.keep_all && s.frame_bytes <= context_.options.download_cache_entry_bytes) {
    for (std::string& frame : s.frames) s.kept.push_back(std::move(frame));
  } else {
    s.keep_all = false;
    s.kept.clear();
    s.kept.shrink_to_fit();
  }
  s.frames.clear();
  PumpStream();
}

template <typename Stream>
void SyncSession<Stream>::FinishStreaming() {
  Streaming& s = *streaming_;
  DownloadReport report = s.encoder->plan().report;
  report.bytes += s.encoder->landmark_bytes();
  const v1::DownloadEnd end = s.encoder->End();
  LogDownload(report, s.encoder->plan().header, end.chunk_count(), s.frame_bytes,
              s.encoder->sent_digest(), s.encoder->plan().removed_digest,
              s.plan_cached ? ", selection from memory" : "");
  if (s.keep_all) {
    auto encoded = std::make_shared<EncodedDownload>();
    encoded->protocol_version = protocol_version_;
    encoded->header = s.encoder->plan().header;
    encoded->end = end;
    encoded->report = std::move(report);
    encoded->frames = std::move(s.kept);
    encoded->frame_bytes = s.frame_bytes;
    encoded->sent_digest = s.encoder->sent_digest();
    encoded->removed_digest = s.encoder->plan().removed_digest;
    context_.downloads.Put(s.cache_key, std::move(encoded));
  }
  const bool big = !s.keep_all;
  streaming_.reset();
#ifdef __GLIBC__
  // A big download's batches were allocated on the store workers and freed here, in whichever
  // malloc arenas those threads had at the time: each arena keeps the pages of its own peak,
  // and over many downloads a few arenas each hold a batch's worth. Handing the free pages
  // back keeps the server's footprint at one download's, not at the sum of the arenas' peaks.
  if (big) malloc_trim(0);
#endif
  do_read_prefix();
}

template class SyncSession<tcp::socket>;
template class SyncSession<asio::ssl::stream<tcp::socket>>;

}  // namespace fleetmap::daemon
