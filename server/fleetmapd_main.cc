// fleetmapd: the fleet's central repository daemon (docs/sync-protocol.md). Robots
// registered with `fleetmap robot add` connect, push their maps, follow their merges and
// download the map; `--http` adds the status page and Prometheus metrics.
//
// Prints exactly one line to stdout once it serves, "fleetmapd listening on HOST:PORT" (and
// "http on HOST:PORT" with --http), so scripts and tests learn the bound ports; everything
// else goes to the log on stderr. SIGTERM or SIGINT drains (sync_server.h Stop()) and exits 0.
// Exit 2: bad options (or a bad --config file), a store that cannot be opened, unreadable TLS
// files, a busy address.
#include <signal.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>

#include "fleetmap/core/chunk_memory.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/daemon/status_http.h"
#include "fleetmap/daemon/sync_server.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/repository/retirement.h"
#include "fleetmap/store/sqlite_process_setup.h"

namespace {

// The options given in other units or forms than SyncServerOptions holds them, with
// SyncServerOptions' defaults; ApplyFlags converts them once the command line is parsed.
struct Flags {
  explicit Flags(const fleetmap::SyncServerOptions& defaults)
      : busy_timeout_ms(defaults.store_busy_timeout.count()),
        merge_max_retry_ms(defaults.merge_max_retry.count()),
        max_submission_mib(defaults.max_submission_bytes >> 20),
        max_inflight_mib_per_robot(defaults.max_inflight_bytes_per_robot >> 20),
        download_cache_mib(defaults.download_cache_bytes >> 20),
        download_cache_entry_mib(defaults.download_cache_entry_bytes >> 20),
        merge_lease_ms(defaults.merge_lease.count()),
        merge_poll_ms(defaults.merge_poll.count()),
        frame_timeout_s(std::chrono::duration<double>(defaults.io_deadline).count()),
        download_batch_kib(defaults.download_batch_bytes >> 10) {}

  std::string http;  // empty: no status page
  bool allow_plaintext_http = false;
  std::string http_token_file;  // empty: no token
  int debug_merge_delay_ms = 0;
  int debug_merge_pause_ms = 0;
  std::int64_t busy_timeout_ms;
  std::int64_t merge_max_retry_ms;
  int debug_chunk_delay_ms = 0;
  double hello_timeout_s = 5.0;
  std::uint64_t max_submission_mib;
  std::uint64_t max_inflight_mib_per_robot;
  std::uint64_t download_cache_mib;
  std::uint64_t download_cache_entry_mib;
  std::int64_t merge_lease_ms;
  std::int64_t merge_poll_ms;
  std::size_t dream_max_orders = 0;  // 0: all of them
  double retire_after_days = 0.0;    // 0: no retirement
  std::string retire_at;             // empty: right after the dream
  double frame_timeout_s;
  std::size_t download_batch_kib;
};

// The store, the addresses, TLS and the hello deadline.
void AddServiceOptions(CLI::App& app, fleetmap::SyncServerOptions& options, Flags& flags) {
  // Every option below can also come from a TOML file, one `key = value` per long option name
  // without "--" (packaging/config/fleetmapd.toml); an option on the command line wins over the
  // file. An unknown key is an error naming it: in a service's config a misspelt key silently
  // ignored would run the server with a default nobody chose.
  app.set_config("--config", "",
                 "TOML file of these options (key = value, keys without \"--\"); the command "
                 "line wins over the file");
  app.allow_config_extras(CLI::config_extras_mode::error);
  app.add_option("--store", options.store_uri, "Repository store URI")->capture_default_str();
  app.add_option("--listen", options.listen, "Sync address HOST:PORT (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--http", flags.http,
                 "Status page and /metrics on HOST:PORT (default: none). They name every robot, "
                 "so an address other than loopback is refused without --allow-plaintext-http "
                 "(this server speaks no TLS: put it behind a TLS reverse proxy)");
  app.add_flag("--allow-plaintext-http", flags.allow_plaintext_http,
               "Serve --http on an address other than loopback in plain text (a network you "
               "trust); logs a warning");
  app.add_option("--http-token-file", flags.http_token_file,
                 "File holding the status server's read-only token (one line, 16+ characters "
                 "of A-Z a-z 0-9 - . _ ~; chmod 600): every request must then carry "
                 "\"Authorization: Bearer TOKEN\" (or ?token=TOKEN from a browser, which then "
                 "gets a cookie), else 401")
      ->check(CLI::ExistingFile);
  app.add_option(
         "--picture-relax-nodes", options.picture_relax_max_nodes,
         "The status page's pictures are relaxed (a loop closes where it was driven) up "
         "to this many nodes and composed beyond (0: always composed); relaxing takes a "
         "store thread about 4 s at 10^4 nodes and 80 s and 0.75 GB at 10^5; none are drawn "
         "without --http")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{0}, std::size_t{10'000'000}));
  app.add_option("--threads", options.io_threads, "IO threads for sessions")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--tls-cert", options.tls_cert_path, "TLS certificate chain (PEM)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", options.tls_key_path,
                 "TLS private key (PEM); readable by its owner only (chmod 600), else refused")
      ->check(CLI::ExistingFile);
  app.add_flag("--allow-plaintext", options.allow_plaintext,
               "Serve without TLS on an address other than loopback (refused otherwise: tokens "
               "and maps would cross the network in clear); logs a warning");
  app.add_option("--hello-timeout", flags.hello_timeout_s,
                 "Seconds a new connection has to deliver its hello (the TLS handshake "
                 "included); a real agent sends it at once")
      ->capture_default_str()
      ->check(CLI::Range(0.1, 600.0));
}

// What one address, one robot and one submission may take, and the store's waits.
void AddLimitOptions(CLI::App& app, fleetmap::SyncServerOptions& options, Flags& flags) {
  // Why the oldest goes (connection_admission.h): a real agent says hello within milliseconds
  // of connecting, so the connection that waited longest without one is the least likely to be
  // a robot, and closing it, not the newcomer, means idle connections cannot lock robots out.
  app.add_option("--max-pending-hello-per-address", options.max_pending_hello_per_address,
                 "Connections from one address that have not yet sent a complete hello; past "
                 "this the OLDEST of them is closed (BUSY), not the new one: a real agent says "
                 "hello within milliseconds, so a flood of idle connections cannot lock it out")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-pending-hello", options.max_pending_hello,
                 "The same over all addresses (again the oldest is closed)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-sessions-per-robot", options.max_sessions_per_robot,
                 "Sessions one robot may hold at once, once authenticated; past this its new "
                 "session is refused (BUSY) and its others go on (an agent uses one)")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-inflight-mib-per-robot", flags.max_inflight_mib_per_robot,
                 "MiB of frames one robot may have announced and not yet had handled, across "
                 "its sessions; a frame past this is refused (BUSY), so one robot cannot take "
                 "the memory the others sync with; at least 64, one frame of the largest")
      ->capture_default_str()
      ->check(CLI::Range(std::uint64_t{64}, std::uint64_t{1} << 20));
  app.add_option("--max-route-plans-per-robot", options.max_route_plans_per_robot,
                 "Route downloads one robot may have queued or being planned at once, across "
                 "its sessions; past this its route request is refused (BUSY), so one robot's "
                 "routes cannot hold every store worker")
      ->capture_default_str()
      ->check(CLI::Range(1, 100000));
  app.add_option("--max-submission-mib", flags.max_submission_mib,
                 "Largest submission a robot may push, in MiB, as announced and as received; "
                 "a larger push is refused (INVALID). The welcome tells agents the limit: "
                 "they push more content as several submissions that fit, and keep a node "
                 "over it unpushed until it grows")
      ->capture_default_str()
      ->check(CLI::Range(std::uint64_t{1}, std::uint64_t{1} << 24));
  app.add_option("--busy-timeout-ms", flags.busy_timeout_ms,
                 "How long a store call waits for a lock another writer holds before it fails "
                 "(SQLite busy timeout, PostgreSQL lock_timeout). A merge that fails so, or for "
                 "a full disk or a lost connection, stays queued and is retried")
      ->capture_default_str()
      ->check(CLI::Range(std::int64_t{0}, std::int64_t{3'600'000}));
  app.add_option("--merge-max-retry-ms", flags.merge_max_retry_ms,
                 "Longest wait between retries of a merge that failed transiently (the first "
                 "waits 500 ms, each next one twice as long)")
      ->capture_default_str()
      ->check(CLI::Range(std::int64_t{1}, std::int64_t{3'600'000}));
  app.add_option("--download-cache-mib", flags.download_cache_mib,
                 "Memory for downloads kept once encoded, sent again without the store (0: none)")
      ->capture_default_str()
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1} << 20));
  app.add_option("--download-cache-entry-mib", flags.download_cache_entry_mib,
                 "Largest download kept there; a bigger one is streamed from the store each "
                 "time, so memory stays bounded whatever the map's size")
      ->capture_default_str()
      ->check(CLI::Range(std::uint64_t{0}, std::uint64_t{1} << 20));
}

// Several fleetmapd on one store: names and merge claims.
void AddMergeOptions(CLI::App& app, fleetmap::SyncServerOptions& options, Flags& flags) {
  app.add_option("--instance", options.instance,
                 "This server's name among the fleetmapd sharing one store (merge claims, "
                 "/metrics, logs); unique per store and kept across restarts (default: "
                 "HOSTNAME:PORT as bound)");
  app.add_option("--merge-lease-ms", flags.merge_lease_ms,
                 "How long a claim on a submission lasts unless renewed (every third of it "
                 "while the merge runs): another fleetmapd on the store takes the submission "
                 "over this long after its merger died")
      ->capture_default_str()
      ->check(CLI::Range(std::int64_t{300}, std::int64_t{3'600'000}));
  app.add_option("--merge-poll-ms", flags.merge_poll_ms,
                 "How often an idle fleetmapd looks in the store for submissions queued by "
                 "the others or left by one that died, and for merges the others finished")
      ->capture_default_str()
      ->check(CLI::Range(std::int64_t{10}, std::int64_t{600'000}));
}

void AddDreamOptions(CLI::App& app, fleetmap::SyncServerOptions& options, std::string& dream_at,
                     Flags& flags) {
  app.add_option("--dream-at", dream_at,
                 std::string("Dream every day at this UTC time of day, ") +
                     fleetmap::kDailyTimeGrammar +
                     " (default: never): the submissions "
                     "merged since the last dream are merged again in every order into the map "
                     "before them, judged by the newest one, which is held out; the best map is "
                     "kept as a candidate (`fleetmap candidates`), never the head, until "
                     "`fleetmap promote` makes it the next revision. Runs beside pushes and "
                     "downloads, on a store connection of its own; progress in /metrics. A "
                     "dream missed (fleetmapd down at the time, or killed mid-dream) runs once "
                     "at start");
  app.add_option("--dream-max-groups", options.dream.max_groups,
                 "Submissions a dream merges in every order at most (the newest before the "
                 "held-out one); k groups make k! orders")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{1}, std::size_t{fleetmap::kMaxDreamGroups}));
  app.add_option("--dream-max-orders", flags.dream_max_orders,
                 "Explore at most this many orders, a sample seeded by the head revision "
                 "(default 0: all of them)");
}

void AddRetireOptions(CLI::App& app, Flags& flags) {
  app.add_option("--retire-after", flags.retire_after_days,
                 "Retire experiences unused for this many days (fractions allowed; default 0: "
                 "never), daily: nodes no merge has localised against since the map's clock "
                 "(its newest stamp) minus this are hidden as a revision (`fleetmap retire`), "
                 "where their place holds other experiences; `fleetmap revert N` restores them. "
                 "On a store connection of its own, beside merges")
      ->check(CLI::Range(0.0, 36'500.0));
  app.add_option("--retire-at", flags.retire_at,
                 std::string("Retire every day at this UTC time of day, ") +
                     fleetmap::kDailyTimeGrammar +
                     " (default: right after each nightly dream, so --dream-at is needed "
                     "without it). A retirement not made since that time last came runs at "
                     "start");
}

void AddTestOptions(CLI::App& app, Flags& flags) {
  // A test knob, hidden from --help: each merge holds its transaction this long before the
  // commit, so a test can kill the daemon mid-merge.
  app.add_option("--debug-merge-delay-ms", flags.debug_merge_delay_ms)->group("");
  // Likewise, after the claim and before MERGE: a test freezes the daemon there past its lease.
  app.add_option("--debug-merge-pause-ms", flags.debug_merge_pause_ms)->group("");
  app.add_option("--debug-chunk-delay-ms", flags.debug_chunk_delay_ms)->group("");
  // And the deadline of each frame after the hello (SyncServerOptions::io_deadline), so a test
  // of a robot's large backlog need not build 30 s of work to pass it.
  app.add_option("--frame-timeout-s", flags.frame_timeout_s)
      ->group("")
      ->check(CLI::Range(0.05, 3600.0));
  // And the size of a streamed download's batches, for tests and benchmarks of its memory.
  app.add_option("--debug-download-batch-kib", flags.download_batch_kib)
      ->group("")
      ->check(CLI::Range(std::size_t{1}, std::size_t{1} << 20));
}

// The options read from text (times of day); throws Error(kInvalidArgument) naming the one
// that does not read.
void ApplyTimeFlags(const std::string& dream_at, const Flags& flags,
                    fleetmap::SyncServerOptions& options) {
  if (!dream_at.empty()) {
    options.dream_at_second = fleetmap::ParseDailyTime(dream_at, "--dream-at");
  }
  if (!flags.retire_at.empty()) {
    options.retire_at_second = fleetmap::ParseDailyTime(flags.retire_at, "--retire-at");
  }
  if (flags.retire_after_days > 0.0) {
    fleetmap::RetireOptions retire;
    retire.retire_after_ns =
        std::llround(flags.retire_after_days * static_cast<double>(fleetmap::kNanosecondsPerDay));
    options.retire = retire;
    if (!options.retire_at_second && !options.dream_at_second) {
      throw fleetmap::Error(fleetmap::ErrorCode::kInvalidArgument,
                            "--retire-after needs --retire-at HH:MM, or --dream-at to retire "
                            "right after the dream");
    }
  } else if (options.retire_at_second) {
    throw fleetmap::Error(fleetmap::ErrorCode::kInvalidArgument,
                          "--retire-at without --retire-after: retirement is off");
  }
}

void ApplyFlags(const Flags& flags, fleetmap::SyncServerOptions& options) {
  if (flags.dream_max_orders > 0) options.dream.max_orders = flags.dream_max_orders;
  options.merge_lease = std::chrono::milliseconds(flags.merge_lease_ms);
  options.merge_poll = std::chrono::milliseconds(flags.merge_poll_ms);
  options.debug_merge_delay = std::chrono::milliseconds(flags.debug_merge_delay_ms);
  options.debug_merge_pause = std::chrono::milliseconds(flags.debug_merge_pause_ms);
  options.store_busy_timeout = std::chrono::milliseconds(flags.busy_timeout_ms);
  options.merge_max_retry = std::chrono::milliseconds(flags.merge_max_retry_ms);
  options.merge_first_retry = std::min(options.merge_first_retry, options.merge_max_retry);
  options.debug_chunk_delay = std::chrono::milliseconds(flags.debug_chunk_delay_ms);
  options.io_deadline =
      std::chrono::milliseconds(static_cast<std::int64_t>(flags.frame_timeout_s * 1000.0));
  options.hello_deadline =
      std::chrono::milliseconds(static_cast<std::int64_t>(flags.hello_timeout_s * 1000.0));
  options.max_submission_bytes = flags.max_submission_mib << 20;
  options.max_inflight_bytes_per_robot = flags.max_inflight_mib_per_robot << 20;
  options.download_cache_bytes = flags.download_cache_mib << 20;
  options.download_cache_entry_bytes = flags.download_cache_entry_mib << 20;
  options.download_batch_bytes = flags.download_batch_kib << 10;
  options.draw_status_pictures = !flags.http.empty();
}

void StartLogging() {
  auto logger = spdlog::stderr_logger_mt("fleetmapd");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  spdlog::flush_on(spdlog::level::info);
}

// SIGTERM and SIGINT are taken by Serve's sigwait: block them before any thread starts, so
// every thread inherits the mask and none is interrupted.
sigset_t BlockStopSignals() {
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a robot that hangs up is an error code, not a signal
  return stop_signals;
}

// Serves until SIGTERM or SIGINT; 0 once drained, 2 when the server cannot start.
int Serve(const fleetmap::SyncServerOptions& options, const Flags& flags,
          const sigset_t& stop_signals) {
  std::unique_ptr<fleetmap::SyncServer> server;
  std::unique_ptr<fleetmap::StatusHttpServer> status_http;
  try {
    fleetmap::StatusHttpOptions http_options;
    http_options.allow_plaintext = flags.allow_plaintext_http;
    if (!flags.http_token_file.empty()) {
      if (flags.http.empty()) {
        throw fleetmap::Error(fleetmap::ErrorCode::kInvalidArgument,
                              "--http-token-file without --http: there is no status page");
      }
      http_options.token = fleetmap::ReadStatusHttpToken(flags.http_token_file);
    }
    server = std::make_unique<fleetmap::SyncServer>(options);
    server->Start();
    if (!flags.http.empty()) {
      status_http = fleetmap::StartStatusHttp(
          flags.http, [s = server.get()] { return s->Status(); }, std::move(http_options));
    }
  } catch (const fleetmap::Error& e) {
    std::cerr << "fleetmapd: " << e.what() << "\n";
    if (server) server->Stop();
    return 2;
  }
  std::printf("fleetmapd listening on %s\n", server->bound_address().c_str());
  if (status_http) std::printf("http on %s\n", status_http->address().c_str());
  std::fflush(stdout);
  spdlog::info("fleetmapd serving {} on {}{}", options.store_uri, server->bound_address(),
               server->tls() ? " (TLS)" : "");

  int signal_number = 0;
  sigwait(&stop_signals, &signal_number);
  spdlog::info("signal {}: stopping", signal_number == SIGTERM ? "SIGTERM" : "SIGINT");
  if (status_http) status_http->Stop();
  server->Stop();
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  fleetmap::KeepChunkMemory(4 << 20, 16 << 20);
  fleetmap::TuneSqliteForThisProcess();
  CLI::App app{"fleetmapd: the fleet's central map repository (sync server for fleetmap-agent)"};
  fleetmap::SyncServerOptions options;
  Flags flags(options);
  std::string dream_at;
  AddServiceOptions(app, options, flags);
  AddLimitOptions(app, options, flags);
  AddMergeOptions(app, options, flags);
  AddDreamOptions(app, options, dream_at, flags);
  AddRetireOptions(app, flags);
  AddTestOptions(app, flags);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ConfigError& e) {
    std::cerr << "fleetmapd: --config " << app["--config"]->as<std::string>() << ": " << e.what()
              << " (keys are the long options of fleetmapd --help without \"--\")\n";
    return 2;
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  try {
    ApplyTimeFlags(dream_at, flags, options);
  } catch (const fleetmap::Error& e) {
    std::cerr << "fleetmapd: " << e.what() << "\n";
    return 2;
  }
  ApplyFlags(flags, options);
  StartLogging();
  const sigset_t stop_signals = BlockStopSignals();
  return Serve(options, flags, stop_signals);
}
