#include "fleetmap/agent/sync_client.h"

#include <openssl/ssl.h>

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/read.hpp>
#include <boost/asio/ssl.hpp>
#include <boost/asio/write.hpp>
#include <optional>

namespace fleetmap {

namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using Clock = std::chrono::steady_clock;

constexpr std::chrono::milliseconds kStopPollInterval{100};
constexpr std::chrono::milliseconds kCloseTimeout{500};
// A TLS server closes a plain connection at its first bytes; a second connection then tells
// whether it is one with a TLS handshake alone (nothing else is sent over it).
constexpr std::chrono::milliseconds kTlsProbeTimeout{3'000};
// The first bytes of a TLS record from a server: an alert (21) or a handshake (22), version 3.
constexpr unsigned char kTlsAlertRecord = 0x15;
constexpr unsigned char kTlsHandshakeRecord = 0x16;
constexpr unsigned char kTlsMajorVersion = 0x03;

struct HostPort {
  std::string host;
  std::string port;
};

HostPort SplitHostPort(std::string_view text) {
  const std::size_t colon = text.rfind(':');
  if (colon == std::string_view::npos || colon == 0 || colon + 1 == text.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "server address '" + std::string(text) + "' is not HOST:PORT");
  }
  HostPort out{std::string(text.substr(0, colon)), std::string(text.substr(colon + 1))};
  if (out.host.size() >= 2 && out.host.front() == '[' && out.host.back() == ']') {
    out.host = out.host.substr(1, out.host.size() - 2);
  }
  if (!std::all_of(out.port.begin(), out.port.end(), [](char c) { return c >= '0' && c <= '9'; }) ||
      out.port.size() > 5 || std::stoi(out.port) == 0 || std::stoi(out.port) > 65535) {
    throw Error(ErrorCode::kInvalidArgument,
                "server address '" + std::string(text) + "' has no valid port");
  }
  return out;
}

ErrorCode ClientCodeOf(v1::ErrorFrame::Code code) {
  switch (code) {
    case v1::ErrorFrame::NOT_FOUND:
      return ErrorCode::kNotFound;
    case v1::ErrorFrame::CONFLICT:
      return ErrorCode::kConflict;
    case v1::ErrorFrame::BAD_FRAME:
    case v1::ErrorFrame::FRAME_TOO_LARGE:
    case v1::ErrorFrame::UNSUPPORTED_VERSION:
    case v1::ErrorFrame::UNKNOWN_ROBOT:
    case v1::ErrorFrame::BAD_TOKEN:
    case v1::ErrorFrame::OUT_OF_ORDER:
    case v1::ErrorFrame::INVALID:
      return ErrorCode::kInvalidArgument;
    default:
      return ErrorCode::kBackend;
  }
}

std::string BodyName(v1::SyncFrame::BodyCase body) {
  const auto* field = v1::SyncFrame::descriptor()->FindFieldByNumber(static_cast<int>(body));
  return field ? field->name() : "empty";
}

}  // namespace

SyncServerError::SyncServerError(const v1::ErrorFrame& frame, const std::string& context)
    : Error(ClientCodeOf(frame.code()), context + ": server said " +
                                            v1::ErrorFrame::Code_Name(frame.code()) + ": " +
                                            frame.text()),
      server_code_(frame.code()),
      server_text_(frame.text()) {}

bool SyncServerError::retryable() const {
  return server_code_ == v1::ErrorFrame::SHUTTING_DOWN ||
         server_code_ == v1::ErrorFrame::INTERNAL || server_code_ == v1::ErrorFrame::TIMEOUT ||
         server_code_ == v1::ErrorFrame::CHUNK_DIGEST || server_code_ == v1::ErrorFrame::BUSY;
}

// The socket, its TLS layer when there is one, and the io_context that drives both.
struct SyncClient::Link {
  asio::io_context io;
  tcp::socket socket{io};
  std::optional<asio::ssl::context> tls_context;
  std::unique_ptr<asio::ssl::stream<tcp::socket&>> tls;
  bool broken = false;
  boost::system::error_code failure;  // what the operation that broke the link completed with

  // Runs the operation `start` begins (it takes a completion handler) until it completes,
  // `timeout` passes or `stop` is raised. Throws SyncLinkError (timed out, or the error the
  // operation completed with) or SyncStopped; either leaves the link closed.
  template <typename Start>
  void Run(Start start, std::chrono::milliseconds timeout, const std::string& what,
           const std::atomic<bool>* stop) {
    if (broken)
      throw SyncLinkError(what + ": the link was already closed by an earlier failure", true);
    bool done = false;
    boost::system::error_code result;
    io.restart();
    start([&done, &result](const boost::system::error_code& ec, auto&&...) {
      done = true;
      result = ec;
    });
    const Clock::time_point deadline = Clock::now() + timeout;
    while (!done) {
      if (stop != nullptr && stop->load()) {
        Abort(done);
        throw SyncStopped(what + ": abandoned (stopping)");
      }
      const Clock::time_point now = Clock::now();
      if (now >= deadline) {
        Abort(done);
        throw SyncLinkError(what + ": timed out after " + std::to_string(timeout.count()) + " ms",
                            true);
      }
      io.run_for(std::min<Clock::duration>(deadline - now, kStopPollInterval));
    }
    if (result) {
      broken = true;
      failure = result;
      boost::system::error_code ignored;
      socket.close(ignored);
      // A TLS failure at the handshake (a certificate that does not verify) will not go
      // away by retrying; a reset or a refused connection may.
      const bool tls_failure = result.category() == asio::error::get_ssl_category() ||
                               result.category() == asio::ssl::error::get_stream_category();
      throw SyncLinkError(what + ": " + result.message(),
                          !(tls_failure && what.find("handshake") != std::string::npos));
    }
  }

  // Closes the socket, which completes the pending operation with operation_aborted, and
  // lets its handler run so nothing refers to the caller's frame afterwards.
  void Abort(const bool& done) {
    broken = true;
    boost::system::error_code ignored;
    socket.close(ignored);
    const Clock::time_point until = Clock::now() + kCloseTimeout;
    while (!done && Clock::now() < until) io.run_for(kStopPollInterval);
  }

  template <typename Fn>
  void WithStream(Fn fn) {
    if (tls) {
      fn(*tls);
    } else {
      fn(socket);
    }
  }
};

SyncClient::SyncClient(std::string_view host_port, const SyncLinkOptions& options)
    : server_(host_port), options_(options), link_(std::make_unique<Link>()) {
  const HostPort address = SplitHostPort(host_port);
  Link& link = *link_;

  tcp::resolver resolver(link.io);
  tcp::resolver::results_type endpoints;
  const Clock::time_point deadline = Clock::now() + options_.connect_timeout;
  auto remaining = [&deadline] {
    return std::max(std::chrono::milliseconds(1),
                    std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
  };
  try {
    link.Run(
        [&](auto handler) {
          resolver.async_resolve(
              address.host, address.port,
              [&endpoints, handler](const boost::system::error_code& ec,
                                    tcp::resolver::results_type results) mutable {
                endpoints = std::move(results);
                handler(ec);
              });
        },
        remaining(), "resolving " + server_, options_.stop);
  } catch (const SyncLinkError& e) {
    throw SyncLinkError(e.message(), false);  // a name that does not resolve stays so
  }
  link.Run([&](auto handler) { asio::async_connect(link.socket, endpoints, handler); }, remaining(),
           "connecting to " + server_, options_.stop);
  boost::system::error_code ignored;
  link.socket.set_option(tcp::no_delay(true), ignored);  // one small ack per chunk

  if (options_.tls != TlsMode::kNone) {
    link.tls_context.emplace(asio::ssl::context::tls_client);
    link.tls_context->set_options(asio::ssl::context::no_sslv2 | asio::ssl::context::no_sslv3 |
                                  asio::ssl::context::no_tlsv1 | asio::ssl::context::no_tlsv1_1);
    if (options_.tls == TlsMode::kVerify) {
      try {
        if (options_.tls_ca_file.empty()) {
          link.tls_context->set_default_verify_paths();
        } else {
          link.tls_context->load_verify_file(options_.tls_ca_file.string());
        }
      } catch (const boost::system::system_error& e) {
        throw Error(ErrorCode::kInvalidArgument,
                    "cannot load TLS CA file '" + options_.tls_ca_file.string() + "': " + e.what());
      }
      link.tls_context->set_verify_mode(asio::ssl::verify_peer);
    } else {
      link.tls_context->set_verify_mode(asio::ssl::verify_none);
    }
    link.tls = std::make_unique<asio::ssl::stream<tcp::socket&>>(link.socket, *link.tls_context);
    if (options_.tls == TlsMode::kVerify) {
      link.tls->set_verify_callback(asio::ssl::host_name_verification(address.host));
    }
    boost::system::error_code not_an_address;
    asio::ip::make_address(address.host, not_an_address);
    if (not_an_address) {  // SNI carries names only
      // SSL_set_tlsext_host_name, without the macro's C cast.
      SSL_ctrl(link.tls->native_handle(), SSL_CTRL_SET_TLSEXT_HOSTNAME, TLSEXT_NAMETYPE_host_name,
               const_cast<char*>(address.host.c_str()));
    }
    link.Run(
        [&](auto handler) { link.tls->async_handshake(asio::ssl::stream_base::client, handler); },
        remaining(), "TLS handshake with " + server_, options_.stop);
  }
}

SyncClient::~SyncClient() {
  Close();
}

void SyncClient::Close() {
  if (!link_) return;
  Link& link = *link_;
  if (!link.broken && link.tls) {
    try {
      link.Run([&](auto handler) { link.tls->async_shutdown(handler); }, kCloseTimeout,
               "TLS shutdown", nullptr);
    } catch (const Error&) {
      // The peer may close first; the link ends either way.
    }
  }
  boost::system::error_code ignored;
  link.socket.close(ignored);
  link.broken = true;
}

void SyncClient::Send(const v1::SyncFrame& frame) {
  const std::string bytes = EncodeSyncFrame(frame, options_.max_frame_bytes);
  Link& link = *link_;
  link.WithStream([&](auto& stream) {
    link.Run([&](auto handler) { asio::async_write(stream, asio::buffer(bytes), handler); },
             options_.io_timeout, "sending " + std::string(SyncFrameName(frame)) + " to " + server_,
             options_.stop);
  });
  bytes_sent_ += bytes.size();
}

std::string_view SyncClient::ReceiveBody(std::string_view during,
                                         std::chrono::milliseconds timeout) {
  if (timeout.count() <= 0) timeout = options_.io_timeout;
  Link& link = *link_;
  const std::string context = std::string(during) + " with " + server_;
  char prefix[kSyncFrameLengthBytes];
  const Clock::time_point deadline = Clock::now() + timeout;
  link.WithStream([&](auto& stream) {
    try {
      link.Run(
          [&](auto handler) {
            asio::async_read(stream, asio::buffer(prefix, sizeof prefix), handler);
          },
          timeout, context + ": reading a frame", options_.stop);
    } catch (const SyncLinkError&) {
      const bool ended =
          link.failure == asio::error::eof || link.failure == asio::error::connection_reset;
      if (ended && FirstReplyWithoutTls() && ServerSpeaksTls()) ThrowTlsMismatch(context);
      throw;
    }
    const auto* first = reinterpret_cast<const unsigned char*>(prefix);
    if (FirstReplyWithoutTls() &&
        (first[0] == kTlsAlertRecord || first[0] == kTlsHandshakeRecord) &&
        first[1] == kTlsMajorVersion) {
      Close();
      ThrowTlsMismatch(context);
    }
    std::uint32_t length = 0;
    try {
      length =
          DecodeSyncFrameLength(std::string_view(prefix, sizeof prefix), options_.max_frame_bytes);
    } catch (const Error& e) {
      Close();
      throw Error(ErrorCode::kCorrupt, context + ": " + e.message());
    }
    // Grown, never shrunk: resizing a string clears what it adds, a pass over every frame.
    if (receive_buffer_.size() < length) receive_buffer_.resize(length);
    receive_size_ = length;
    const auto left =
        std::max(std::chrono::milliseconds(1),
                 std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()));
    link.Run(
        [&](auto handler) {
          asio::async_read(stream, asio::buffer(receive_buffer_.data(), length), handler);
        },
        left, context + ": reading a frame of " + std::to_string(length) + " bytes", options_.stop);
  });
  bytes_received_ += sizeof prefix + receive_size_;
  return std::string_view(receive_buffer_.data(), receive_size_);
}

v1::SyncFrame SyncClient::DecodeBody(std::string_view body, std::string_view during) {
  v1::SyncFrame frame;
  try {
    frame = DecodeSyncFrameBody(body);
  } catch (const Error& e) {
    Close();
    throw Error(ErrorCode::kCorrupt, std::string(during) + " with " + server_ + ": " + e.message());
  }
  if (frame.body_case() == v1::SyncFrame::kError) {
    Close();  // the server closes after an ErrorFrame
    throw SyncServerError(frame.error(), std::string(during) + " with " + server_);
  }
  return frame;
}

v1::SyncFrame SyncClient::Receive(std::string_view during, std::chrono::milliseconds timeout) {
  return DecodeBody(ReceiveBody(during, timeout), during);
}

bool SyncClient::FirstReplyWithoutTls() const {
  return options_.tls == TlsMode::kNone && bytes_received_ == 0;
}

bool SyncClient::ServerSpeaksTls() const {
  SyncLinkOptions probe = options_;
  probe.tls = TlsMode::kInsecure;  // whether it speaks TLS at all: nothing is sent over it
  probe.connect_timeout = std::min(options_.connect_timeout, kTlsProbeTimeout);
  try {
    SyncClient tls(server_, probe);
    return true;
  } catch (const Error&) {
    return false;
  }
}

void SyncClient::ThrowTlsMismatch(const std::string& context) const {
  // Not retryable: every retry would send the token in clear again, to the same refusal.
  throw SyncLinkError(context +
                          ": the server speaks TLS and this agent connected without it (its "
                          "hello, token included, went out unencrypted once; not retried): give "
                          "fleetmap-agent --tls-ca FILE, the CA of the server's certificate",
                      false);
}

v1::SyncFrame SyncClient::Expect(v1::SyncFrame::BodyCase expected, std::string_view during,
                                 std::chrono::milliseconds timeout) {
  v1::SyncFrame frame = Receive(during, timeout);
  if (frame.body_case() != expected) {
    Close();
    throw Error(ErrorCode::kCorrupt, std::string(during) + " with " + server_ + ": expected " +
                                         BodyName(expected) + ", the server sent " +
                                         std::string(SyncFrameName(frame)));
  }
  return frame;
}

}  // namespace fleetmap
