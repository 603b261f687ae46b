// fleetmapd: the fleet's central repository daemon (DESIGN.md "Sync protocol"). Robots
// registered with `fleetmap robot add` connect, push their maps, follow their merges and
// download the map; `--http` adds the status page and Prometheus metrics.
//
// Prints exactly one line to stdout once it serves, "fleetmapd listening on HOST:PORT" (and
// "http on HOST:PORT" with --http), so scripts and tests learn the bound ports; everything
// else goes to the log on stderr. SIGTERM or SIGINT drains (sync_server.h Stop()) and exits 0.
// Exit 2: bad options, a store that cannot be opened, unreadable TLS files, a busy address.
#include <signal.h>
#include <spdlog/sinks/stdout_sinks.h>
#include <spdlog/spdlog.h>

#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>

#include "fleetmap/common/error.h"
#include "fleetmap/server/status_http.h"
#include "fleetmap/server/sync_server.h"

int main(int argc, char** argv) {
  CLI::App app{"fleetmapd: the fleet's central map repository (sync server for fleetmap-agent)"};
  fleetmap::SyncServerOptions options;
  std::string http;
  int debug_merge_delay_ms = 0;
  int debug_chunk_delay_ms = 0;
  app.add_option("--store", options.store_uri, "Repository store URI")->capture_default_str();
  app.add_option("--listen", options.listen, "Sync address HOST:PORT (port 0: any free port)")
      ->capture_default_str();
  app.add_option("--http", http, "Status page and /metrics on HOST:PORT (default: none)");
  app.add_option("--threads", options.io_threads, "IO threads for sessions")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  app.add_option("--tls-cert", options.tls_cert_path, "TLS certificate chain (PEM)")
      ->check(CLI::ExistingFile);
  app.add_option("--tls-key", options.tls_key_path, "TLS private key (PEM)")
      ->check(CLI::ExistingFile);
  // A test knob, hidden from --help: each merge holds its transaction this long before the
  // commit, so a test can kill the daemon mid-merge.
  app.add_option("--debug-merge-delay-ms", debug_merge_delay_ms)->group("");
  app.add_option("--debug-chunk-delay-ms", debug_chunk_delay_ms)->group("");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : 2;
  }
  options.debug_merge_delay = std::chrono::milliseconds(debug_merge_delay_ms);
  options.debug_chunk_delay = std::chrono::milliseconds(debug_chunk_delay_ms);

  auto logger = spdlog::stderr_logger_mt("fleetmapd");
  spdlog::set_default_logger(logger);
  spdlog::set_pattern("%Y-%m-%dT%H:%M:%S.%e %^%l%$ %v");
  spdlog::flush_on(spdlog::level::info);

  // SIGTERM and SIGINT are taken by sigwait below: block them before any thread starts, so
  // every thread inherits the mask and none is interrupted.
  sigset_t stop_signals;
  sigemptyset(&stop_signals);
  sigaddset(&stop_signals, SIGTERM);
  sigaddset(&stop_signals, SIGINT);
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  signal(SIGPIPE, SIG_IGN);  // a robot that hangs up is an error code, not a signal

  std::unique_ptr<fleetmap::SyncServer> server;
  std::unique_ptr<fleetmap::StatusHttpServer> status_http;
  try {
    server = std::make_unique<fleetmap::SyncServer>(options);
    server->Start();
    if (!http.empty()) {
      status_http = fleetmap::StartStatusHttp(http, [s = server.get()] { return s->Status(); });
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
