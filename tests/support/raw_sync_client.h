// A small blocking sync client for tests of fleetmapd: raw frames over a POSIX socket on
// 127.0.0.1 (optionally TLS through OpenSSL, without checking the server's certificate), so
// a test can send exactly the bytes it wants (bad prefixes, truncated frames, frames out of
// order) and read exactly what comes back. Every read waits at most `timeout` (SO_RCVTIMEO).
#pragma once

#include <arpa/inet.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <openssl/err.h>
#include <openssl/ssl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <chrono>
#include <csignal>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

#include "fleetmap/core/uuid.h"
#include "fleetmap/wire/sync_frame.h"

namespace fleetmap::testing {

// A frame's 4-byte big-endian length prefix alone (sync_frame.h), for hand-made frames.
inline std::string LengthPrefix(std::uint32_t n) {
  const char prefix[4] = {static_cast<char>(n >> 24), static_cast<char>(n >> 16),
                          static_cast<char>(n >> 8), static_cast<char>(n)};
  return std::string(prefix, 4);
}

class RawSyncClient {
 public:
  // Connects to "127.0.0.1:PORT" (and does the TLS handshake when `tls`). Throws
  // std::runtime_error when it cannot.
  explicit RawSyncClient(const std::string& address, bool tls = false,
                         std::chrono::milliseconds timeout = std::chrono::milliseconds(10'000)) {
    const std::size_t colon = address.rfind(':');
    const std::string host = address.substr(0, colon);
    const int port = std::stoi(address.substr(colon + 1));
    fd_ = ::socket(AF_INET, SOCK_STREAM, 0);
    if (fd_ < 0) throw std::runtime_error("socket failed");
    timeval tv{};
    tv.tv_sec = static_cast<time_t>(timeout.count() / 1000);
    tv.tv_usec = static_cast<suseconds_t>((timeout.count() % 1000) * 1000);
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
    ::setsockopt(fd_, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
    const int one = 1;
    ::setsockopt(fd_, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    sockaddr_in addr{};
    addr.sin_family = AF_INET;
    addr.sin_port = htons(static_cast<std::uint16_t>(port));
    ::inet_pton(AF_INET, host.c_str(), &addr.sin_addr);
    if (::connect(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
      ::close(fd_);
      throw std::runtime_error("connect to " + address + " failed");
    }
    if (tls) {
      // OpenSSL writes with write(2), not send(MSG_NOSIGNAL): a server that closes on the
      // ClientHello (a plain listener) would kill the test with SIGPIPE instead of failing the
      // handshake. A client should see EPIPE, as this one's send() does.
      std::signal(SIGPIPE, SIG_IGN);
      ctx_ = SSL_CTX_new(TLS_client_method());
      SSL_CTX_set_min_proto_version(ctx_, TLS1_2_VERSION);
      ssl_ = SSL_new(ctx_);
      SSL_set_fd(ssl_, fd_);
      if (SSL_connect(ssl_) != 1) {
        SSL_free(ssl_);
        SSL_CTX_free(ctx_);
        ::close(fd_);
        throw std::runtime_error("TLS handshake with " + address + " failed");
      }
    }
  }

  ~RawSyncClient() {
    if (ssl_) {
      SSL_free(ssl_);
      SSL_CTX_free(ctx_);
    }
    if (fd_ >= 0) ::close(fd_);
  }
  RawSyncClient(const RawSyncClient&) = delete;
  RawSyncClient& operator=(const RawSyncClient&) = delete;

  // Sends raw bytes; false when the connection refused them.
  bool SendBytes(std::string_view bytes) {
    while (!bytes.empty()) {
      const long n = ssl_ ? SSL_write(ssl_, bytes.data(), static_cast<int>(bytes.size()))
                          : ::send(fd_, bytes.data(), bytes.size(), MSG_NOSIGNAL);
      if (n <= 0) return false;
      bytes.remove_prefix(static_cast<std::size_t>(n));
    }
    return true;
  }

  bool Send(const v1::SyncFrame& frame) { return SendBytes(EncodeSyncFrame(frame)); }

  // The next frame; nullopt at the end of the stream, on a timeout or on bytes that are not a
  // frame.
  std::optional<v1::SyncFrame> Receive() {
    const std::optional<std::string> raw = ReceiveRaw();
    if (!raw) return std::nullopt;
    try {
      return DecodeSyncFrameBody(raw->substr(kSyncFrameLengthBytes));
    } catch (const std::exception&) {
      return std::nullopt;
    }
  }

  // The next frame exactly as it came, its 4-byte prefix and its body, not parsed; nullopt at
  // the end of the stream, on a timeout or on a prefix over the cap. For tests that compare the
  // server's bytes themselves.
  std::optional<std::string> ReceiveRaw() {
    std::string prefix;
    if (!ReadExactly(kSyncFrameLengthBytes, prefix)) return std::nullopt;
    std::uint32_t length = 0;
    try {
      length = DecodeSyncFrameLength(prefix);
    } catch (const std::exception&) {
      return std::nullopt;
    }
    std::string body;
    if (!ReadExactly(length, body)) return std::nullopt;
    return prefix + body;
  }

  // True when the server closed the connection (end of stream, or reset) within the timeout.
  bool ClosedByServer() {
    char byte = 0;
    const long n = ssl_ ? SSL_read(ssl_, &byte, 1) : ::recv(fd_, &byte, 1, 0);
    if (n == 0) return true;
    if (n < 0) return !(errno == EAGAIN || errno == EWOULDBLOCK) || ssl_ != nullptr;
    return false;
  }

  // Hello for `robot` with `token`; the reply.
  std::optional<v1::SyncFrame> Hello(const Uuid& robot, const std::string& token,
                                     std::uint32_t version = kSyncProtocolVersion) {
    v1::SyncFrame frame;
    frame.mutable_hello()->set_protocol_version(version);
    frame.mutable_hello()->set_robot_id(robot.ToBytesString());
    frame.mutable_hello()->set_token(token);
    frame.mutable_hello()->set_agent("fleetmapd_test");
    if (!Send(frame)) return std::nullopt;
    return Receive();
  }

  // Half-closes our side (the server sees the end of the stream).
  void ShutdownWrite() { ::shutdown(fd_, SHUT_WR); }

 private:
  bool ReadExactly(std::size_t n, std::string& out) {
    out.resize(n);
    std::size_t got = 0;
    while (got < n) {
      const long r = ssl_ ? SSL_read(ssl_, out.data() + got, static_cast<int>(n - got))
                          : ::recv(fd_, out.data() + got, n - got, 0);
      if (r <= 0) return false;
      got += static_cast<std::size_t>(r);
    }
    return true;
  }

  int fd_ = -1;
  SSL_CTX* ctx_ = nullptr;
  SSL* ssl_ = nullptr;
};

}  // namespace fleetmap::testing
