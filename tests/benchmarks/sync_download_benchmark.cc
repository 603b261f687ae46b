// Downloading a large map from a real fleetmapd over loopback (issue: ≥ 500 MB at ≥ 200 MB/s),
// beside the ceiling of the same machine: the same bytes over a plain TCP socket on loopback.
//
// Setup, once: a SQLite central store holding a map of about 520 MB of landmarks (random, so
// nothing compresses), a registered robot, and fleetmapd serving it. Then:
//   SyncDownload/warm   a copy download streamed to a bare protocol client that reads every
//                       frame and keeps none (what the link sustains once the server holds the
//                       encoded selection; the first, cold download is reported as a counter);
//   AgentPull           the same download by fleetmap-agent, installed into a fresh local map;
//   RawLoopback         the same number of bytes written in 1 MiB pieces over one socket.
// Run by hand: build/tests/benchmarks/sync_download_benchmark (about a minute of setup).
#include <arpa/inet.h>
#include <benchmark/benchmark.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <memory>
#include <stdexcept>
#include <thread>

#include "fleet_processes.h"
#include "fleetmap/wire/sync_frame.h"
#include "raw_sync_client.h"
#include "scratch_dir.h"

namespace fleetmap::testing {
namespace {

constexpr int kNodes = 60'000;
constexpr int kLandmarksPerNode = 200;  // about 9.3 KB of landmarks per node

struct Fixture {
  ScratchDir dir{"fleetmap-sync-bench"};
  std::string uri;
  TestRobot robot;
  Fleetmapd server;
  std::int64_t landmark_bytes = 0;
  double cold_seconds = 0.0;
  std::uint64_t wire_bytes = 0;
};

// Made on first use, destroyed by main after the run: fleetmapd stops and the store goes.
std::unique_ptr<Fixture> shared_fixture;

Fixture& Shared() {
  if (!shared_fixture) {
    shared_fixture = std::make_unique<Fixture>();
    Fixture* f = shared_fixture.get();
    f->uri = "sqlite:" + (f->dir / "central.db").string();
    f->robot = RegisterRobot(f->uri, "bench", f->dir / "robot");
    {
      // The map as revision 0 (outside version control), written in batches.
      std::unique_ptr<GraphStore> store = GraphStore::Open(f->uri);
      for (int batch = 0; batch < kNodes / 2000; ++batch) {
        GraphBatch part = RandomRobotMap(f->robot.id, 2000, 1000 + batch, kLandmarksPerNode);
        store->Put(part);
      }
      f->landmark_bytes = store->Stats().landmark_bytes;
    }
    f->server = StartFleetmapd(f->uri, f->dir / "fleetmapd.log");
  }
  return *shared_fixture;
}

// One copy download, every frame read and decoded, none kept; the bytes on the wire.
std::uint64_t DownloadOnce(const Fixture& f) {
  RawSyncClient client(f.server.address, false, std::chrono::milliseconds(60'000));
  const std::optional<v1::SyncFrame> welcome = client.Hello(f.robot.id, f.robot.token);
  if (!welcome || !welcome->has_welcome()) throw std::runtime_error("no welcome");
  v1::SyncFrame request;
  request.mutable_download_request()->set_policy("copy");
  client.Send(request);
  std::uint64_t received = 0;
  while (true) {
    const std::optional<v1::SyncFrame> frame = client.Receive();
    if (!frame) throw std::runtime_error("the download stopped short");
    received += kSyncFrameLengthBytes + frame->ByteSizeLong();
    if (frame->has_download_end()) break;
    if (frame->has_error()) throw std::runtime_error("server: " + frame->error().text());
  }
  return received;
}

void SyncDownload(benchmark::State& state) {
  Fixture& f = Shared();
  if (f.server.address.empty()) {
    state.SkipWithError("fleetmapd did not start");
    return;
  }
  if (f.wire_bytes == 0) {
    const auto start = std::chrono::steady_clock::now();
    f.wire_bytes = DownloadOnce(f);  // cold: selection, encoding, cache
    f.cold_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  for (auto _ : state) benchmark::DoNotOptimize(DownloadOnce(f));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.wire_bytes));
  state.counters["map_MB"] = static_cast<double>(f.landmark_bytes) / 1e6;
  state.counters["wire_MB"] = static_cast<double>(f.wire_bytes) / 1e6;
  state.counters["cold_s"] = f.cold_seconds;
  state.counters["cold_MBps"] = static_cast<double>(f.wire_bytes) / 1e6 / f.cold_seconds;
}
BENCHMARK(SyncDownload)
    ->Name("SyncDownload/warm")
    ->Unit(benchmark::kMillisecond)
    ->Iterations(5)
    ->UseRealTime();

// The whole pull as a robot does it: fleetmap-agent (a process) downloads the copy, checks it
// and installs it into a fresh local SQLite map (written, fsynced, renamed into place).
void AgentPull(benchmark::State& state) {
  Fixture& f = Shared();
  int run = 0;
  for (auto _ : state) {
    TestRobot robot = f.robot;
    robot.map_dir = f.dir / ("pull-" + std::to_string(run++));
    std::filesystem::create_directories(robot.map_dir);
    const std::filesystem::path log = robot.map_dir / "agent.log";
    std::unique_ptr<ChildProcess> agent = StartSync(robot, f.server.address, log, {"--quiet"});
    const SyncOutcome outcome = FinishSync(*agent, log, std::chrono::milliseconds(600'000));
    if (outcome.exit != 0) state.SkipWithError("the agent failed");
    state.counters["download_s"] = outcome.result.value("download_seconds", 0.0);
    state.counters["install_s"] = outcome.result.value("install_seconds", 0.0);
    state.PauseTiming();
    std::filesystem::remove_all(robot.map_dir);
    state.ResumeTiming();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.wire_bytes));
}
BENCHMARK(AgentPull)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The ceiling: the same bytes through one loopback TCP connection, 1 MiB per write.
void RawLoopback(benchmark::State& state) {
  const std::uint64_t total = Shared().wire_bytes ? Shared().wire_bytes : 520'000'000;
  const int listener = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  bind(listener, reinterpret_cast<sockaddr*>(&address), sizeof address);
  socklen_t length = sizeof address;
  getsockname(listener, reinterpret_cast<sockaddr*>(&address), &length);
  listen(listener, 4);
  const std::string piece(1 << 20, 'x');
  for (auto _ : state) {
    std::thread sender([&] {
      const int fd = accept(listener, nullptr, nullptr);
      for (std::uint64_t sent = 0; sent < total;) {
        const ssize_t n =
            write(fd, piece.data(), std::min<std::uint64_t>(piece.size(), total - sent));
        if (n <= 0) break;
        sent += static_cast<std::uint64_t>(n);
      }
      close(fd);
    });
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    connect(fd, reinterpret_cast<sockaddr*>(&address), sizeof address);
    std::string buffer(1 << 20, '\0');
    std::uint64_t got = 0;
    while (true) {
      const ssize_t n = read(fd, buffer.data(), buffer.size());
      if (n <= 0) break;
      got += static_cast<std::uint64_t>(n);
    }
    close(fd);
    sender.join();
    benchmark::DoNotOptimize(got);
  }
  close(listener);
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * total));
}
BENCHMARK(RawLoopback)->Unit(benchmark::kMillisecond)->Iterations(5)->UseRealTime();

}  // namespace

void DestroySharedFixture() {
  shared_fixture.reset();
}

}  // namespace fleetmap::testing

int main(int argc, char** argv) {
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  fleetmap::testing::DestroySharedFixture();
  return 0;
}
