// The status HTTP server: a listener and one session per connection, as in Boost.Beast's
// advanced server example (every pending handler holds shared_from_this(); a strand per
// connection; a deadline on every read and write), plus a registry of live sessions so Stop()
// can drain them with a deadline instead of dropping work in flight.
#include "fleetmap/daemon/status_http.h"

#include <spdlog/spdlog.h>

#include <array>
#include <boost/asio/bind_executor.hpp>
#include <boost/asio/dispatch.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/strand.hpp>
#include <boost/beast/core/bind_handler.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/core/tcp_stream.hpp>
#include <boost/beast/http/error.hpp>
#include <boost/beast/http/parser.hpp>
#include <boost/beast/http/read.hpp>
#include <boost/beast/http/write.hpp>
#include <chrono>
#include <cstddef>
#include <optional>
#include <thread>
#include <unordered_map>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/core/mutex.h"
#include "status_access.h"
#include "status_routes.h"

namespace fleetmap {
namespace {

namespace net = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
using tcp = net::ip::tcp;
using beast::error_code;

constexpr std::size_t kHeaderLimit = 8 * 1024;
constexpr std::uint64_t kBodyLimit = 8 * 1024;
// Connections at once. At the limit the connection that has waited longest for a request is
// closed to make room (SessionRegistry::Add), so idle connections cannot keep a scraper out.
constexpr std::size_t kMaxSessions = 64;
// Reading one request, from the moment the server waits for it (on a keep-alive connection,
// the wait for the next request counts too) to its last byte. Short: a client that has
// connected sends its request at once, and a connection that sends nothing, or trickles,
// holds a slot only this long.
constexpr std::chrono::seconds kRequestTimeout{3};
constexpr std::chrono::seconds kWriteTimeout{10};
constexpr std::chrono::seconds kDrainTimeout{3};
// How long a connection we close after an answer (413, 400, "Connection: close") may still
// send before we drop it: see HttpSession::CloseAfterResponse.
constexpr std::chrono::seconds kLingerTimeout{2};
// After a failed accept (EMFILE, ...) wait a little before the next, instead of spinning.
constexpr std::chrono::milliseconds kAcceptBackoff{100};

class HttpSession;

// The sessions alive now; shared by the server and every session (a session unregisters in
// its destructor, which may run after the server object is gone, during io_context teardown).
class SessionRegistry {
 public:
  // Registers a new session. When kMaxSessions are live, the one that has waited longest for a
  // request is pushed out (closed, and no longer counted) to make room; false (the caller drops
  // the connection) when stopping, or when every live session is busy with a request.
  bool Add(const std::shared_ptr<HttpSession>& session);
  // The session waits for a request (true) or handles one (false).
  void SetWaiting(const HttpSession* session, bool waiting) {
    MutexLock lock(mutex_);
    if (const auto it = live_.find(session); it != live_.end()) {
      it->second.waiting_since =
          waiting ? std::optional(std::chrono::steady_clock::now()) : std::nullopt;
    }
  }
  void Remove(const HttpSession* session) {
    MutexLock lock(mutex_);
    live_.erase(session);
    if (live_.empty()) drained_.NotifyAll();
  }
  // Refuses new sessions from now on; returns the live ones.
  std::vector<std::shared_ptr<HttpSession>> BeginStop() {
    MutexLock lock(mutex_);
    stopping_ = true;
    std::vector<std::shared_ptr<HttpSession>> sessions;
    for (const auto& [key, entry] : live_) {
      if (auto session = entry.session.lock()) sessions.push_back(std::move(session));
    }
    return sessions;
  }
  bool WaitDrained(std::chrono::steady_clock::duration timeout) {
    MutexLock lock(mutex_);
    return drained_.WaitFor(mutex_, timeout, [this]() REQUIRES(mutex_) { return live_.empty(); });
  }

 private:
  struct Entry {
    std::weak_ptr<HttpSession> session;
    // Set while it waits for a request; a new session counts as waiting from the accept.
    std::optional<std::chrono::steady_clock::time_point> waiting_since;
  };

  Mutex mutex_;
  CondVar drained_;
  std::unordered_map<const HttpSession*, Entry> live_ GUARDED_BY(mutex_);
  bool stopping_ GUARDED_BY(mutex_) = false;
};

// One connection: read a request, write its response, again while keep-alive, on its strand.
class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket&& socket, const StatusHttpServer::StatusSource& status_source,
              const std::string& token, std::shared_ptr<SessionRegistry> registry)
      : stream_(std::move(socket)),
        status_source_(status_source),
        token_(token),
        registry_(std::move(registry)) {}
  ~HttpSession() { registry_->Remove(this); }

  void Start() {
    // The socket came from the acceptor with this session's strand as its executor.
    net::dispatch(stream_.get_executor(),
                  beast::bind_front_handler(&HttpSession::DoRead, shared_from_this()));
  }

  // Closes the connection now when it waits for a request, or once the response being
  // written is out.
  void Close() {
    net::post(stream_.get_executor(), [self = shared_from_this()] {
      self->closing_ = true;
      if (!self->writing_) self->CloseNow();
    });
  }

 private:
  void DoRead() {
    registry_->SetWaiting(this, true);
    parser_.emplace();
    parser_->header_limit(kHeaderLimit);
    parser_->body_limit(kBodyLimit);
    // For the whole request, however it trickles in: not renewed by each read.
    stream_.expires_after(kRequestTimeout);
    http::async_read(stream_, buffer_, *parser_,
                     beast::bind_front_handler(&HttpSession::OnRead, shared_from_this()));
  }

  void OnRead(error_code ec, std::size_t /*bytes*/) {
    registry_->SetWaiting(this, false);
    if (ec == http::error::end_of_stream) return CloseNow();
    if (ec == http::error::body_limit) {
      return Reply(PlainTextResponse(http::status::payload_too_large, 11, false,
                                     "request body over " + std::to_string(kBodyLimit) + " bytes"));
    }
    if (ec == http::error::header_limit) {
      return Reply(
          PlainTextResponse(http::status::request_header_fields_too_large, 11, false,
                            "request header over " + std::to_string(kHeaderLimit) + " bytes"));
    }
    if (ec && &ec.category() == &http::make_error_code(http::error::bad_target).category()) {
      return Reply(PlainTextResponse(http::status::bad_request, 11, false,
                                     "malformed request: " + ec.message()));
    }
    // Timeout, reset or cancelled by Close(): nothing to answer; the stream closes with us.
    if (ec) return;
    if (closing_) return CloseNow();
    const HttpRequest& request = parser_->get();
    const StatusAccess access =
        token_.empty() ? StatusAccess::kByHeaderOrCookie : CheckStatusAccess(request, token_);
    if (access == StatusAccess::kDenied) return Reply(StatusUnauthorized(request));
    HttpResponse response = RouteStatusRequest(request, status_source_);
    if (access == StatusAccess::kByQuery) {
      response.set(http::field::set_cookie, StatusTokenCookie(token_));
    }
    Reply(std::move(response));
  }

  void Reply(HttpResponse response) {
    response_ = std::move(response);
    writing_ = true;
    stream_.expires_after(kWriteTimeout);
    http::async_write(stream_, response_,
                      beast::bind_front_handler(&HttpSession::OnWrite, shared_from_this()));
  }

  void OnWrite(error_code ec, std::size_t /*bytes*/) {
    writing_ = false;
    if (ec) return;
    if (closing_) return CloseNow();
    if (response_.need_eof()) return CloseAfterResponse();
    DoRead();
  }

  // After an answer that ends the connection. Closing a socket with unread input resets the
  // connection, and a reset can destroy the answer before the client has read it (think of the
  // rest of a refused 64 KiB body). So: send FIN, read and discard what still comes until the
  // client closes too or kLingerTimeout passes (Apache's "lingering close"), then close.
  void CloseAfterResponse() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
    stream_.expires_after(kLingerTimeout);  // for the whole drain, not per read
    DoDrain();
  }

  void DoDrain() {
    stream_.async_read_some(net::buffer(drain_),
                            beast::bind_front_handler(&HttpSession::OnDrain, shared_from_this()));
  }

  void OnDrain(error_code ec, std::size_t /*bytes*/) {
    if (ec) return CloseNow();
    DoDrain();
  }

  // Closes at once; a pending read is cancelled, and its handler releases this session.
  void CloseNow() {
    error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_both, ignored);
    stream_.close();
  }

  beast::tcp_stream stream_;
  const StatusHttpServer::StatusSource& status_source_;  // owned by the server, outlives us
  const std::string& token_;                             // likewise; empty: none
  std::shared_ptr<SessionRegistry> registry_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
  HttpResponse response_;
  std::array<char, 4096> drain_{};
  bool writing_ = false;
  bool closing_ = false;
};

bool SessionRegistry::Add(const std::shared_ptr<HttpSession>& session) {
  std::shared_ptr<HttpSession> pushed_out;
  {
    MutexLock lock(mutex_);
    if (stopping_) return false;
    if (live_.size() >= kMaxSessions) {
      auto oldest = live_.end();
      for (auto it = live_.begin(); it != live_.end(); ++it) {
        if (!it->second.waiting_since) continue;
        if (oldest == live_.end() || *it->second.waiting_since < *oldest->second.waiting_since) {
          oldest = it;
        }
      }
      if (oldest == live_.end()) return false;  // every one is answering a request
      pushed_out = oldest->second.session.lock();
      live_.erase(oldest);
    }
    live_.emplace(session.get(), Entry{session, std::chrono::steady_clock::now()});
  }
  // Outside the lock: Close() only posts to the session's strand, but the last reference to
  // it may go with `pushed_out`, and its destructor takes the lock.
  if (pushed_out) pushed_out->Close();
  return true;
}

// Accepts connections and starts a session for each, until Close().
class HttpListener : public std::enable_shared_from_this<HttpListener> {
 public:
  HttpListener(net::io_context& io, tcp::acceptor&& acceptor,
               const StatusHttpServer::StatusSource& status_source, const std::string& token,
               std::shared_ptr<SessionRegistry> registry)
      : io_(io),
        acceptor_(std::move(acceptor)),
        backoff_(acceptor_.get_executor()),
        status_source_(status_source),
        token_(token),
        registry_(std::move(registry)) {}

  void Start() {
    net::dispatch(acceptor_.get_executor(),
                  beast::bind_front_handler(&HttpListener::DoAccept, shared_from_this()));
  }

  void Close() {
    net::post(acceptor_.get_executor(), [self = shared_from_this()] {
      error_code ignored;
      self->acceptor_.close(ignored);
      self->backoff_.cancel();
    });
  }

 private:
  void DoAccept() {
    acceptor_.async_accept(net::make_strand(io_),
                           beast::bind_front_handler(&HttpListener::OnAccept, shared_from_this()));
  }

  void OnAccept(error_code ec, tcp::socket socket) {
    if (!acceptor_.is_open()) return;
    if (ec) {
      backoff_.expires_after(kAcceptBackoff);
      backoff_.async_wait([self = shared_from_this()](error_code wait_ec) {
        if (!wait_ec && self->acceptor_.is_open()) self->DoAccept();
      });
      return;
    }
    auto session =
        std::make_shared<HttpSession>(std::move(socket), status_source_, token_, registry_);
    // Refused (stopping or full): the session and its socket go away right here.
    if (registry_->Add(session)) session->Start();
    DoAccept();
  }

  net::io_context& io_;
  tcp::acceptor acceptor_;
  net::steady_timer backoff_;
  const StatusHttpServer::StatusSource& status_source_;
  const std::string& token_;
  std::shared_ptr<SessionRegistry> registry_;
};

// "HOST:PORT" or "[V6]:PORT" → host and port text.
std::pair<std::string, std::string> SplitAddress(const std::string& address) {
  const std::size_t colon = address.rfind(':');
  if (colon == std::string::npos || colon == 0 || colon + 1 == address.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "status HTTP address \"" + address + "\": expected HOST:PORT");
  }
  std::string host = address.substr(0, colon);
  std::string port = address.substr(colon + 1);
  if (host.size() >= 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  const bool digits = !port.empty() && port.size() <= 5 &&
                      port.find_first_not_of("0123456789") == std::string::npos;
  if (!digits || std::stoul(port) > 65535) {
    throw Error(ErrorCode::kInvalidArgument,
                "status HTTP address \"" + address + "\": port must be 0..65535");
  }
  return {host, port};
}

tcp::endpoint Resolve(net::io_context& io, const std::string& address) {
  const auto [host, port] = SplitAddress(address);
  tcp::resolver resolver(io);
  error_code ec;
  const auto results = resolver.resolve(host, port, tcp::resolver::numeric_service, ec);
  if (ec || results.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "status HTTP address \"" + address + "\": cannot resolve host: " + ec.message());
  }
  return results.begin()->endpoint();
}

tcp::acceptor Bind(net::io_context& io, const tcp::endpoint& endpoint, const std::string& address) {
  tcp::acceptor acceptor(net::make_strand(io));
  error_code ec;
  const auto fail = [&](const char* step) {
    throw Error(ErrorCode::kBackend,
                "status HTTP address \"" + address + "\": " + step + ": " + ec.message());
  };
  if (acceptor.open(endpoint.protocol(), ec); ec) fail("open");
  if (acceptor.set_option(net::socket_base::reuse_address(true), ec); ec) fail("set_option");
  if (acceptor.bind(endpoint, ec); ec) fail("bind");
  if (acceptor.listen(net::socket_base::max_listen_connections, ec); ec) fail("listen");
  return acceptor;
}

}  // namespace

struct StatusHttpServer::Impl {
  Impl(StatusSource source, std::string token_in)
      : status_source(std::move(source)), token(std::move(token_in)) {}

  // Declared first, destroyed last: the io_context's teardown destroys pending handlers,
  // which hold sessions that refer to them.
  StatusSource status_source;
  std::string token;
  std::shared_ptr<SessionRegistry> registry = std::make_shared<SessionRegistry>();
  net::io_context io{1};
  std::shared_ptr<HttpListener> listener;
  tcp::endpoint bound;
  std::thread thread;
  Mutex stop_mutex;
  bool stopped GUARDED_BY(stop_mutex) = false;
};

StatusHttpServer::StatusHttpServer(const std::string& address, StatusSource status_source,
                                   StatusHttpOptions options)
    : impl_(std::make_unique<Impl>(std::move(status_source), std::move(options.token))) {
  Impl& impl = *impl_;
  const tcp::endpoint endpoint = Resolve(impl.io, address);
  if (!endpoint.address().is_loopback()) {
    // The same rule as the sync server's plain text (sync_server.h allow_plaintext): what the
    // page shows is for the fleet's operators, not for whoever reaches the address.
    if (!options.allow_plaintext) {
      throw Error(ErrorCode::kInvalidArgument,
                  "refusing to serve the status page and /metrics on " + address +
                      " in plain text: they name every robot, its UUID, channel and last error "
                      "to whoever reaches the address (and this server speaks no TLS). Serve "
                      "them on loopback (--http 127.0.0.1:PORT) behind a TLS reverse proxy or "
                      "an SSH tunnel, or, on a network you trust, say so with "
                      "--allow-plaintext-http (and require a token with --http-token-file)");
    }
    spdlog::warn("PLAIN TEXT status page and /metrics on {} (--allow-plaintext-http){}", address,
                 impl.token.empty()
                     ? ", with no token: anyone who reaches it sees every robot (--http-token-file)"
                     : ", token required");
  }
  tcp::acceptor acceptor = Bind(impl.io, endpoint, address);
  impl.bound = acceptor.local_endpoint();
  impl.listener = std::make_shared<HttpListener>(impl.io, std::move(acceptor), impl.status_source,
                                                 impl.token, impl.registry);
  impl.listener->Start();
  impl.thread = std::thread([&io = impl.io] { io.run(); });
}

StatusHttpServer::~StatusHttpServer() {
  Stop();
}

std::uint16_t StatusHttpServer::port() const {
  return impl_->bound.port();
}

std::string StatusHttpServer::address() const {
  const auto host = impl_->bound.address();
  const std::string host_text = host.is_v6() ? "[" + host.to_string() + "]" : host.to_string();
  return host_text + ":" + std::to_string(impl_->bound.port());
}

void StatusHttpServer::Stop() {
  MutexLock lock(impl_->stop_mutex);
  if (impl_->stopped) return;
  impl_->stopped = true;
  impl_->listener->Close();
  for (const auto& session : impl_->registry->BeginStop()) session->Close();
  // Sessions leave the registry as their last handler completes; the read and write deadlines
  // bound that too, but a stop should not wait the full 10 s for a client that does not read.
  impl_->registry->WaitDrained(kDrainTimeout);
  impl_->io.stop();
  impl_->thread.join();
}

std::unique_ptr<StatusHttpServer> StartStatusHttp(const std::string& address,
                                                  StatusHttpServer::StatusSource status_source,
                                                  StatusHttpOptions options) {
  return std::make_unique<StatusHttpServer>(address, std::move(status_source), std::move(options));
}

}  // namespace fleetmap
