#include "fleetmap/daemon/sync_server.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <atomic>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/ssl/context.hpp>
#include <boost/asio/strand.hpp>
#include <cstring>
#include <functional>
#include <optional>
#include <thread>
#include <vector>

#include "connection_admission.h"
#include "download_cache.h"
#include "dream_schedule.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/wire/secret_file.h"
#include "merge_queue.h"
#include "retire_schedule.h"
#include "robot_allowance.h"
#include "server_activity.h"
#include "session_tracker.h"
#include "status_pictures.h"
#include "store_workers.h"
#include "sync_session.h"

namespace fleetmap {
namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;

// "HOST:PORT" or "[HOST]:PORT" as an endpoint; Error(kInvalidArgument) naming it otherwise.
tcp::endpoint ParseListen(const std::string& listen) {
  const auto bad = [&](const std::string& why) {
    return Error(ErrorCode::kInvalidArgument,
                 "listen address '" + listen + "': " + why + " (expected HOST:PORT)");
  };
  const std::size_t colon = listen.rfind(':');
  if (colon == std::string::npos || colon == 0) throw bad("no port");
  std::string host = listen.substr(0, colon);
  const std::string port_text = listen.substr(colon + 1);
  if (host.size() > 2 && host.front() == '[' && host.back() == ']') {
    host = host.substr(1, host.size() - 2);
  }
  if (host == "localhost") host = "127.0.0.1";
  unsigned long port = 0;
  try {
    std::size_t used = 0;
    port = std::stoul(port_text, &used);
    if (used != port_text.size() || port > 65535) throw bad("port out of range");
  } catch (const std::logic_error&) {
    throw bad("port '" + port_text + "' is not a number");
  }
  boost::system::error_code ec;
  const asio::ip::address address = asio::ip::make_address(host, ec);
  if (ec) throw bad("host '" + host + "' is not an IP address");
  return tcp::endpoint(address, static_cast<unsigned short>(port));
}

daemon::AdmissionLimits LimitsOf(const SyncServerOptions& options) {
  return daemon::AdmissionLimits{options.max_sessions, options.max_pending_hello,
                                 options.max_pending_hello_per_address};
}

// HOSTNAME:PORT: unique among the servers on one host, and the same when a server restarts on
// its port (so it takes back its own claims at once).
std::string DefaultInstanceName(unsigned short port) {
  char host[256] = {};
  if (gethostname(host, sizeof host - 1) != 0 || host[0] == '\0') std::strcpy(host, "fleetmapd");
  return std::string(host) + ":" + std::to_string(port);
}

std::string EndpointText(const tcp::endpoint& endpoint) {
  const std::string host = endpoint.address().to_string();
  const std::string port = std::to_string(endpoint.port());
  return endpoint.address().is_v6() ? "[" + host + "]:" + port : host + ":" + port;
}

}  // namespace

class SyncServer::Impl {
 public:
  explicit Impl(SyncServerOptions options)
      : options_(std::move(options)),
        picture_(options_.picture_relax_max_nodes),
        cache_(options_.download_cache_bytes, options_.download_cache_entry_bytes),
        admission_(LimitsOf(options_)),
        robots_(daemon::RobotLimits{options_.max_sessions_per_robot,
                                    options_.max_inflight_bytes_per_robot,
                                    options_.max_route_plans_per_robot}),
        acceptor_(asio::make_strand(ioc_)) {
    if (options_.io_threads < 1 || options_.store_threads < 1) {
      throw Error(ErrorCode::kInvalidArgument, "fleetmapd: --threads must be at least 1");
    }
    if (options_.hello_deadline.count() <= 0) {
      throw Error(ErrorCode::kInvalidArgument, "fleetmapd: --hello-timeout must be positive");
    }
    if (options_.retire && !options_.retire_at_second && !options_.dream_at_second) {
      throw Error(ErrorCode::kInvalidArgument,
                  "--retire-after needs --retire-at HH:MM, or --dream-at to retire right after "
                  "the dream");
    }
    const tcp::endpoint endpoint = ParseListen(options_.listen);
    if (options_.tls_cert_path.empty() != options_.tls_key_path.empty()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "TLS needs both a certificate and a key (--tls-cert and --tls-key)");
    }
    if (!options_.tls_cert_path.empty()) LoadTls();
    if (!tls_ && !endpoint.address().is_loopback()) RequirePlaintextAllowed();
    StoreOptions store_options;
    store_options.busy_timeout_ms = options_.store_busy_timeout.count();
    store_ = std::make_unique<daemon::StoreWorkers>(options_.store_uri, options_.store_threads,
                                                    store_options);
    try {
      acceptor_.open(endpoint.protocol());
      acceptor_.set_option(asio::socket_base::reuse_address(true));
      acceptor_.bind(endpoint);
      acceptor_.listen(asio::socket_base::max_listen_connections);
    } catch (const boost::system::system_error& error) {
      throw Error(ErrorCode::kBackend,
                  "cannot listen on " + options_.listen + ": " + error.code().message());
    }
    bound_ = acceptor_.local_endpoint();
    daemon::MergeQueueOptions merge_options;
    merge_options.instance =
        options_.instance.empty() ? DefaultInstanceName(bound_.port()) : options_.instance;
    merge_options.lease = options_.merge_lease;
    merge_options.poll = options_.merge_poll;
    merge_options.debug_delay = options_.debug_merge_delay;
    merge_options.debug_pause = options_.debug_merge_pause;
    merge_options.first_retry = options_.merge_first_retry;
    merge_options.max_retry = options_.merge_max_retry;
    merge_options.store = store_options;
    merges_ = std::make_unique<daemon::MergeQueue>(
        options_.store_uri, merge_options,
        [this](const daemon::MergeDone& done) { OnMergeDone(done); });
    activity_.SetInstance(merge_options.instance);
    if (options_.retire) {
      // The head moved under the status page and the warm download plan: read it again.
      retire_ = std::make_unique<daemon::RetireSchedule>(
          options_.store_uri, store_options, options_.retire_at_second, *options_.retire,
          [this] { RefreshFromStore(); });
    }
    if (options_.dream_at_second) {
      // Without a time of its own, retirement follows each dream.
      std::function<void()> after_dream;
      if (retire_ && !options_.retire_at_second) {
        after_dream = [retire = retire_.get()] { retire->RunSoon(); };
      }
      dream_ = std::make_unique<daemon::DreamSchedule>(options_.store_uri, store_options,
                                                       *options_.dream_at_second, options_.dream,
                                                       std::move(after_dream));
    }
    context_.emplace(daemon::SessionContext{options_, *store_, *merges_, cache_, activity_,
                                            tracker_, admission_, robots_, draining_});
  }

  ~Impl() { Stop(); }

  void Start() {
    started_ns_ = WallClockNs();
    const std::size_t queued = merges_->Start();
    spdlog::info("merge queue: instance {}, {} submissions queued in the store",
                 merges_->instance(), queued);
    RefreshFromStore();
    if (retire_) retire_->Start();
    if (dream_) dream_->Start();
    do_accept();
    for (int i = 0; i < options_.io_threads; ++i) {
      threads_.emplace_back([this] { ioc_.run(); });
    }
  }

  void Stop() {
    if (stopped_.exchange(true)) return;
    draining_ = true;
    if (dream_) dream_->Stop();    // abandons a dream in progress: it leaves no candidate
    if (retire_) retire_->Stop();  // after the dream, which may ask it to run
    if (threads_.empty()) {        // never started
      merges_->Stop();
      store_->Stop();
      return;
    }
    spdlog::info("draining: no new sessions; waiting up to {} ms for {} open",
                 options_.drain_deadline.count(), activity_.sessions_open());
    // On the acceptor's strand, where its handlers run: never concurrently with an accept.
    asio::post(acceptor_.get_executor(), [this] {
      accepting_ = false;
      boost::system::error_code ignored;
      acceptor_.close(ignored);
    });
    tracker_.ShutdownAll();
    merges_->Stop();  // abandons a running merge; it stays queued in the store
    if (!tracker_.WaitAllClosed(options_.drain_deadline)) {
      spdlog::warn("draining: {} sessions still open after {} ms; closing them",
                   activity_.sessions_open(), options_.drain_deadline.count());
    }
    ioc_.stop();
    for (std::thread& thread : threads_) thread.join();
    store_->Stop();
    spdlog::info("stopped");
  }

  // Not const: it may start a refresh of the robots from the store.
  FleetStatus Status() {
    FleetStatus status = activity_.Snapshot();
    status.now_ns = WallClockNs();
    status.started_ns = started_ns_;
    status.listen = EndpointText(bound_);
    status.tls = tls_.has_value();
    status.draining = draining_.load();
    status.queue_length = merges_->Length();
    status.merge_backing_off = merges_->backing_off();
    if (dream_) status.dream = dream_->Status();
    picture_.AddTo(status);
    status.find_picture = [this](PictureKind kind, std::int64_t revision) {
      bool asked = false;
      std::shared_ptr<const ServedPicture> picture = picture_.Find(kind, revision, &asked);
      if (asked) RefreshPicture();
      return picture;
    };
    if (const auto running = merges_->Merging()) {
      status.merging = MergingSubmission{running->submission.ToString(),
                                         activity_.RobotName(running->robot), running->started_ns};
    }
    // Robots registered meanwhile (by `fleetmap robot add`) show up a moment later.
    const std::int64_t last = last_refresh_ns_.load();
    if (status.now_ns - last > 2'000'000'000 && !draining_.load()) {
      RefreshFromStore();
    }
    return status;
  }

  const tcp::endpoint& bound() const { return bound_; }
  bool tls() const { return tls_.has_value(); }

 private:
  // A robot's hello carries its token, so plain text only where nobody else
  // can listen (loopback), or where the operator said so.
  void RequirePlaintextAllowed() const {
    if (!options_.allow_plaintext) {
      throw Error(ErrorCode::kInvalidArgument,
                  "refusing to serve " + options_.listen +
                      " without TLS: robots' tokens and maps would cross the network in clear. "
                      "Give --tls-cert FILE and --tls-key FILE (robots then connect with "
                      "fleetmap-agent --tls-ca FILE), listen on loopback (127.0.0.1), or, on a "
                      "network you trust as a cable, say so with --allow-plaintext");
    }
    spdlog::warn(
        "PLAIN TEXT on {} (--allow-plaintext): every robot's token and map cross the network "
        "unencrypted; anyone on it can read them and sync as any robot",
        options_.listen);
  }

  void LoadTls() {
    // The key, before it is loaded.
    RequirePrivateSecretFile(options_.tls_key_path, "TLS key (--tls-key)");
    tls_.emplace(asio::ssl::context::tls_server);
    // TLS 1.2 or later only.
    tls_->set_options(asio::ssl::context::default_workarounds | asio::ssl::context::no_sslv2 |
                      asio::ssl::context::no_sslv3 | asio::ssl::context::no_tlsv1 |
                      asio::ssl::context::no_tlsv1_1 | asio::ssl::context::single_dh_use);
    try {
      tls_->use_certificate_chain_file(options_.tls_cert_path);
    } catch (const boost::system::system_error& error) {
      throw Error(ErrorCode::kInvalidArgument,
                  "TLS certificate " + options_.tls_cert_path + ": " + error.code().message());
    }
    try {
      tls_->use_private_key_file(options_.tls_key_path, asio::ssl::context::pem);
    } catch (const boost::system::system_error& error) {
      throw Error(ErrorCode::kInvalidArgument,
                  "TLS key " + options_.tls_key_path + ": " + error.code().message());
    }
  }

  // Robots and the head's facts, read on a store thread into activity_.
  void RefreshFromStore() {
    last_refresh_ns_ = WallClockNs();
    store_->Post([this](Repository& repository) {
      try {
        activity_.SetRobots(RobotRegistry(repository).List(), ChannelRegistry(repository).List());
        const RevisionNumber head = repository.Head();
        const StoreStats stats = repository.inspect().StatsAt(head);
        activity_.SetHead(head, stats);
        WarmCopyPlan(repository, head, stats);
      } catch (const std::exception& error) {
        spdlog::error("reading robots and the head for the status: {}", error.what());
      }
    });
    RefreshPicture();
  }

  // The plan of a whole copy of the head (DownloadPlan: the selection without landmarks), made
  // on a store thread when the head moves here or the server starts, so that the first robot
  // to pull the map does not wait for the selection: for a 540 MB map of 60,000 nodes it was a
  // third of the server's CPU in that robot's download (sync_download_benchmark). Only when
  // the plan fits the cache's entry cap, as a download's own plan is kept: a bigger map is
  // planned per download as before, and no merge pays for a plan nobody keeps.
  void WarmCopyPlan(Repository& repository, RevisionNumber head, const StoreStats& stats) {
    const std::uint64_t plan_bytes = static_cast<std::uint64_t>(stats.nodes) * sizeof(Uuid) +
                                     static_cast<std::uint64_t>(stats.edges) * sizeof(Edge) +
                                     static_cast<std::uint64_t>(stats.paths) * sizeof(Path);
    if (plan_bytes > options_.download_cache_entry_bytes) return;
    // The parameters' defaults: a copy of the head.
    const DownloadAsk copy = DownloadAskOf(DownloadParams{}, 0);
    const std::string key = daemon::DownloadCache::Key(head, copy, kSyncProtocolVersion);
    const daemon::DownloadCache::Entry kept = cache_.Find(key);
    if (kept.plan || kept.encoded) return;
    const auto start = std::chrono::steady_clock::now();
    try {
      const std::shared_ptr<const daemon::DownloadToSend> plan = cache_.PlanOnce(key, [&] {
        return daemon::PlanDownloadToSend(repository, PolicyOfRequest(copy.params),
                                          copy.params.channel, head, 0, kSyncProtocolVersion);
      });
      spdlog::info("planned a copy of revision {} ahead of downloads: {} nodes, {} edges, {:.3f} s",
                   head, plan->plan.nodes.size(), plan->plan.edges.size(), SecondsSince(start));
    } catch (const std::exception& error) {
      // Only a head start lost: the download that asks plans (and reports) for itself.
      spdlog::warn("planning a copy of revision {} ahead of downloads: {}", head, error.what());
    }
  }

  // The status page's pictures, drawn on a store thread when the head has moved or the page
  // asked for one (status_pictures.h), in a job of their own so the robots and counts above
  // never wait for them.
  void RefreshPicture() {
    if (!options_.draw_status_pictures) return;
    store_->Post([this](Repository& repository) {
      try {
        picture_.Refresh(repository);
      } catch (const std::exception& error) {
        spdlog::error("drawing a picture for the status page: {}", error.what());
      }
    });
  }

  void OnMergeDone(const daemon::MergeDone& done) {
    if (done.merged) {
      activity_.MergeFinished(true);
      activity_.MergeRan(done.submission, done.revision, done.seconds, WallClockNs());
      activity_.SetHead(done.revision, done.head_stats);
      RefreshPicture();
      store_->Post([this, head = done.revision, stats = done.head_stats](Repository& repository) {
        WarmCopyPlan(repository, head, stats);
      });
      spdlog::info("merge {}: revision {}, {} nodes added, {:.3f} s", done.submission.ToString(),
                   done.revision, done.nodes_added, done.seconds);
    } else if (done.transient) {
      activity_.MergeRetried();
      spdlog::warn(
          "merge {}: attempt {} failed after {:.3f} s, retrying in {} ms (it stays "
          "queued): {}",
          done.submission.ToString(), done.attempts, done.seconds, done.retry_in.count(),
          done.error);
    } else if (done.abandoned) {
      spdlog::warn("merge {}: {} ({:.3f} s)", done.submission.ToString(), done.error, done.seconds);
    } else {
      activity_.MergeFinished(false);
      spdlog::error("merge {} failed after {:.3f} s: {}", done.submission.ToString(), done.seconds,
                    done.error);
    }
  }

  void do_accept() {
    acceptor_.async_accept(asio::make_strand(ioc_),
                           [this](boost::system::error_code ec, tcp::socket socket) {
                             on_accept(ec, std::move(socket));
                           });
  }

  void on_accept(const boost::system::error_code& ec, tcp::socket socket) {
    if (!accepting_) return;  // draining: the socket closes as it goes
    if (ec) {
      if (ec == asio::error::operation_aborted || ec == asio::error::bad_descriptor) return;
      spdlog::warn("accept failed: {}", ec.message());
      return do_accept();
    }
    boost::system::error_code peer_ec;
    const tcp::endpoint remote = socket.remote_endpoint(peer_ec);
    const std::string peer = peer_ec ? "unknown peer" : EndpointText(remote);
    const std::string address = peer_ec ? peer : remote.address().to_string();
    if (tls_) {
      Launch(std::make_shared<daemon::TlsSyncSession>(
                 asio::ssl::stream<tcp::socket>(std::move(socket), *tls_), *context_, peer),
             address);
    } else {
      Launch(std::make_shared<daemon::PlainSyncSession>(std::move(socket), *context_, peer),
             address);
    }
    do_accept();
  }

  // Counts the session in (connection_admission.h), pushes out the connections it displaces
  // and starts it.
  template <typename Session>
  void Launch(std::shared_ptr<Session> session, const std::string& address) {
    tracker_.Opened(session);
    daemon::AdmissionDecision admitted = admission_.Admit(address, session);
    for (const auto& [evicted, why] : admitted.evict) evicted->Evict(why);
    session->Start(admitted.ticket);
  }

  SyncServerOptions options_;
  daemon::ServerActivity activity_;
  daemon::StatusPictures picture_;
  daemon::SessionTracker tracker_;
  daemon::DownloadCache cache_;
  daemon::ConnectionAdmission admission_;
  daemon::RobotAllowance robots_;
  std::unique_ptr<daemon::MergeQueue> merges_;
  std::unique_ptr<daemon::RetireSchedule> retire_;  // null without --retire-after
  std::unique_ptr<daemon::DreamSchedule> dream_;    // null without --dream-at
  std::unique_ptr<daemon::StoreWorkers> store_;
  std::atomic<bool> draining_{false};
  std::atomic<bool> stopped_{false};
  std::atomic<std::int64_t> last_refresh_ns_{0};
  std::int64_t started_ns_ = 0;
  std::optional<asio::ssl::context> tls_;
  asio::io_context ioc_;
  tcp::acceptor acceptor_;  // on a strand of its own, as is accepting_
  bool accepting_ = true;
  tcp::endpoint bound_;
  std::vector<std::thread> threads_;
  std::optional<daemon::SessionContext> context_;  // set once store_ and merges_ are
};

SyncServer::SyncServer(SyncServerOptions options)
    : impl_(std::make_unique<Impl>(std::move(options))) {}

SyncServer::~SyncServer() = default;

void SyncServer::Start() {
  impl_->Start();
}

void SyncServer::Stop() {
  impl_->Stop();
}

std::string SyncServer::bound_address() const {
  return EndpointText(impl_->bound());
}

std::uint16_t SyncServer::bound_port() const {
  return impl_->bound().port();
}

bool SyncServer::tls() const {
  return impl_->tls();
}

FleetStatus SyncServer::Status() const {
  return impl_->Status();
}

}  // namespace fleetmap
