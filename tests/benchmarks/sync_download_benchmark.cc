// Downloading a large map from a real fleetmapd over loopback (the bar: ≥ 500 MB at ≥ 200 MB/s),
// beside the ceiling of the same machine: the same bytes over a plain TCP socket on loopback.
//
// Setup, once: a SQLite central store holding a map of about 540 MB of landmarks (random, so
// nothing compresses) in 30 revisions, a registered robot, and fleetmapd serving it (a child
// process). Then:
//   SyncDownload/warm   a copy download streamed to a bare protocol client that reads every
//                       frame and keeps none. The first, cold download (reads and encoding from
//                       a freshly started server once its start-up work is done, which plans
//                       the copy ahead: WaitUntilSettled) is reported as counters:
//                       cold_MBps, and the server's peak RSS (VmHWM of the fleetmapd process,
//                       /proc/PID/status) at idle before it and its growth over idle after it
//                       (server_growth_MB). A map this big is over the download cache's entry
//                       cap, so warm downloads stream from the store again (its pages in the
//                       OS cache);
//   AgentPull           the same download by fleetmap-agent, installed into a fresh local map
//                       (landmark_MBps: landmark bytes over the whole pull; agent_cpu_s and
//                       server_cpu_s: what each process spent per pull; cpu_ms_per_MB: the
//                       two together per MB of landmarks);
//   AgentSyncNothingNew after one pull, syncs with nothing new (agent_cpu_s: the agent's CPU
//                       per sync); /verify_map with every installed byte read back as well;
//   RawSqliteInstall    the install's ceiling: the same map written by plain sqlite3 into the
//                       agent's tables, one transaction, then fsynced (landmark_MBps;
//                       cpu_ms_per_MB: this process's CPU per MB of landmarks);
//   StoreScratchInstall the same map through a scratch GraphStore in 1 MiB chunks, as the
//                       agent's install thread puts it, without the link (landmark_MBps);
//   RawLoopback         the same number of bytes written in 1 MiB pieces over one socket.
// Run by hand: build/tests/benchmarks/sync_download_benchmark (about a minute of setup).
#include <arpa/inet.h>
#include <benchmark/benchmark.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sqlite3.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iterator>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>

#include "fleet_processes.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "fleetmap/wire/sync_frame.h"
#include "random_robot_map.h"
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
  std::int64_t idle_peak_rss = 0;  // VmHWM of fleetmapd before the first download
  std::int64_t cold_peak_rss = 0;  // after it
  double cold_cpu_seconds = 0.0;   // fleetmapd's CPU time (all threads) during it
};

// VmHWM of process `pid` (its peak resident memory so far), in bytes; 0 when unreadable.
std::int64_t PeakRssBytes(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stoll(line.substr(6)) * 1024;
  }
  return 0;
}

// CPU seconds of the children this process has waited for (user + system, all threads).
double ChildrenCpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_CHILDREN, &usage);
  const auto seconds = [](const timeval& t) {
    return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) / 1e6;
  };
  return seconds(usage.ru_utime) + seconds(usage.ru_stime);
}

// CPU seconds this process has used so far (user + system, all threads).
double OwnCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) / 1e9;
}

// CPU seconds process `pid` used so far (user + system, all threads); 0 when unreadable. On a
// machine busy with other work wall time says little; MB per CPU second says what the server
// itself costs.
double CpuSeconds(int pid) {
  std::ifstream stat("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(stat)), std::istreambuf_iterator<char>());
  const std::size_t close = text.rfind(')');
  if (close == std::string::npos) return 0.0;
  std::istringstream fields(text.substr(close + 2));
  std::string field;
  double ticks = 0.0;
  for (int i = 3; fields >> field; ++i) {  // field 3 is the state; 14 utime, 15 stime
    if (i == 14 || i == 15) ticks += std::stod(field);
    if (i == 15) break;
  }
  return ticks / static_cast<double>(sysconf(_SC_CLK_TCK));
}

// Waits until process `pid` has used under 10 ms of CPU in 250 ms (at most 60 s): fleetmapd's
// start-up work (the head's counts and picture, the copy's plan) done, as a depot's server is
// when the first robot docks. The first download after that is the cold one.
void WaitUntilSettled(int pid) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  double before = CpuSeconds(pid);
  while (std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
    const double now = CpuSeconds(pid);
    if (now - before < 0.010) return;
    before = now;
  }
}

// Made on first use, destroyed by main after the run: fleetmapd stops and the store goes.
std::unique_ptr<Fixture> shared_fixture;

Fixture& Shared() {
  if (!shared_fixture) {
    shared_fixture = std::make_unique<Fixture>();
    Fixture* f = shared_fixture.get();
    f->uri = "sqlite:" + (f->dir / "central.db").string();
    f->robot = RegisterRobot(f->uri, "bench", f->dir / "robot");
    {
      // The map in revisions of 2000 nodes each, committed as MERGE commits them, so that a
      // robot that has installed the head syncs incrementally from it. Built by another robot
      // of the fleet: what the pulling robot downloads is none of its own work.
      std::unique_ptr<GraphStore> store = GraphStore::Open(f->uri);
      const Uuid surveyor = Uuid::Generate();
      for (int batch = 0; batch < kNodes / 2000; ++batch) {
        GraphBatch part = RandomRobotMap(surveyor, 2000, 1000 + batch, kLandmarksPerNode);
        GraphStore::Transaction transaction = store->Begin();
        Revision revision;
        revision.number = store->versions().HeadRevision() + 1;
        revision.created_ns = WallClockNs();
        revision.author = "bench";
        revision.submission = Uuid::Generate();
        store->versions().AppendRevision(revision, part);
        store->Put(part);
        transaction.Commit();
      }
      f->landmark_bytes = store->Stats().landmark_bytes;
    }
    // On disk before anything is measured: otherwise the first pulls share the disk with the
    // writeback of the 540 MB just written (AgentPull's first pulls ran 10-20% slower).
    ::sync();
    f->server = StartFleetmapd(f->uri, f->dir / "fleetmapd.log");
    if (!f->server.address.empty()) WaitUntilSettled(f->server.process->pid());
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
    const int pid = f.server.process->pid();
    f.idle_peak_rss = PeakRssBytes(pid);
    const double cpu_before = CpuSeconds(pid);
    const auto start = std::chrono::steady_clock::now();
    f.wire_bytes = DownloadOnce(f);  // cold: selection, reads, encoding
    f.cold_seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    f.cold_peak_rss = PeakRssBytes(pid);
    f.cold_cpu_seconds = CpuSeconds(pid) - cpu_before;
  }
  for (auto _ : state) benchmark::DoNotOptimize(DownloadOnce(f));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.wire_bytes));
  state.counters["map_MB"] = static_cast<double>(f.landmark_bytes) / 1e6;
  state.counters["wire_MB"] = static_cast<double>(f.wire_bytes) / 1e6;
  state.counters["cold_s"] = f.cold_seconds;
  state.counters["cold_MBps"] = static_cast<double>(f.wire_bytes) / 1e6 / f.cold_seconds;
  state.counters["cold_server_cpu_s"] = f.cold_cpu_seconds;
  state.counters["server_idle_MB"] = static_cast<double>(f.idle_peak_rss) / 1e6;
  state.counters["server_growth_MB"] = static_cast<double>(f.cold_peak_rss - f.idle_peak_rss) / 1e6;
  state.counters["server_growth_after_warm_MB"] =
      static_cast<double>(PeakRssBytes(f.server.process->pid()) - f.idle_peak_rss) / 1e6;
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
  double seconds = 0.0;
  double agent_cpu = 0.0;   // the agents' CPU seconds (all threads)
  double server_cpu = 0.0;  // fleetmapd's during the pulls
  for (auto _ : state) {
    const auto start = std::chrono::steady_clock::now();
    TestRobot robot = f.robot;
    robot.map_dir = f.dir / ("pull-" + std::to_string(run++));
    std::filesystem::create_directories(robot.map_dir);
    const std::filesystem::path log = robot.map_dir / "agent.log";
    const double server_cpu_before = CpuSeconds(f.server.process->pid());
    const double children_cpu_before = ChildrenCpuSeconds();
    std::unique_ptr<ChildProcess> agent = StartSync(robot, f.server.address, log, {"--quiet"});
    const SyncOutcome outcome = FinishSync(*agent, log, std::chrono::milliseconds(600'000));
    agent_cpu += ChildrenCpuSeconds() - children_cpu_before;
    server_cpu += CpuSeconds(f.server.process->pid()) - server_cpu_before;
    if (outcome.exit != 0) state.SkipWithError("the agent failed");
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    state.counters["download_s"] = outcome.result.value("download_seconds", 0.0);
    state.counters["install_s"] = outcome.result.value("install_seconds", 0.0);
    state.PauseTiming();
    std::filesystem::remove_all(robot.map_dir);
    state.ResumeTiming();
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * f.wire_bytes));
  // CPU per pull: on a busy machine wall time says little, and the two processes share the
  // cores, so what each costs says where the time goes.
  const double pulls = static_cast<double>(state.iterations());
  state.counters["agent_cpu_s"] = agent_cpu / pulls;
  state.counters["server_cpu_s"] = server_cpu / pulls;
  // The pull's whole cost per MB, comparable with RawSqliteInstall's when the machine is too
  // busy for MB/s to mean much.
  const double landmark_mb = static_cast<double>(f.landmark_bytes) / 1e6;
  state.counters["cpu_ms_per_MB"] = 1e3 * (agent_cpu + server_cpu) / pulls / landmark_mb;
  state.counters["landmark_MBps"] = seconds > 0 ? static_cast<double>(f.landmark_bytes) *
                                                      static_cast<double>(state.iterations()) /
                                                      1e6 / seconds
                                                : 0.0;
}
BENCHMARK(AgentPull)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// A sync with nothing new, as a docked robot holding the whole map makes each time: after one
// pull (untimed), fleetmap-agent syncs again and again; agent_cpu_s is the agent's CPU per sync
// (all threads; the bound is 1 s for this map of about 540 MB), server_cpu_s fleetmapd's.
// /verify_map adds --verify-map: every installed landmark byte read back before the hello, as
// each sync did before the check by what map.db holds.
void AgentSyncNothingNew(benchmark::State& state, bool verify_map) {
  Fixture& f = Shared();
  TestRobot robot = f.robot;
  robot.map_dir = f.dir / (verify_map ? "steady-verify" : "steady");
  std::filesystem::create_directories(robot.map_dir);
  const std::filesystem::path log = robot.map_dir / "agent.log";
  const std::vector<std::string> flags = verify_map
                                             ? std::vector<std::string>{"--quiet", "--verify-map"}
                                             : std::vector<std::string>{"--quiet"};
  if (FinishSync(*StartSync(robot, f.server.address, log, {"--quiet"}), log,
                 std::chrono::milliseconds(600'000))
          .exit != 0) {
    state.SkipWithError("the first pull failed");
    return;
  }
  double agent_cpu = 0.0;
  double server_cpu = 0.0;
  for (auto _ : state) {
    const double server_cpu_before = CpuSeconds(f.server.process->pid());
    const double children_cpu_before = ChildrenCpuSeconds();
    const SyncOutcome outcome = FinishSync(*StartSync(robot, f.server.address, log, flags), log,
                                           std::chrono::milliseconds(600'000));
    agent_cpu += ChildrenCpuSeconds() - children_cpu_before;
    server_cpu += CpuSeconds(f.server.process->pid()) - server_cpu_before;
    if (outcome.exit != 0) state.SkipWithError("the agent failed");
    if (outcome.result.value("downloaded_nodes", 0) != 0) {
      state.SkipWithError(("not a sync with nothing new: " + outcome.result.dump()).c_str());
    }
  }
  std::filesystem::remove_all(robot.map_dir);
  const double syncs = static_cast<double>(state.iterations());
  state.counters["agent_cpu_s"] = agent_cpu / syncs;
  state.counters["server_cpu_s"] = server_cpu / syncs;
  state.counters["map_MB"] = static_cast<double>(f.landmark_bytes) / 1e6;
}
BENCHMARK_CAPTURE(AgentSyncNothingNew, checked, false)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();
BENCHMARK_CAPTURE(AgentSyncNothingNew, verify_map, true)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(3)
    ->UseRealTime();

// The install's ceiling: the same map (nodes and edges, generated as the fixture's) written
// through plain sqlite3 into a fresh file as the agent's tables hold it (the node table with
// its three indexes, the edge table with its two), in one transaction with the journal in
// memory, then fsynced: no link, no decoding, no digest, no checks. landmark_MBps and
// cpu_ms_per_MB compare with AgentPull's: the map is the fixture's, so the landmark bytes
// summed here are the store's landmark_bytes AgentPull divides by.
void RawSqliteInstall(benchmark::State& state) {
  Fixture& f = Shared();
  std::vector<GraphBatch> parts;
  for (int batch = 0; batch < kNodes / 2000; ++batch) {
    parts.push_back(RandomRobotMap(f.robot.id, 2000, 1000 + batch, kLandmarksPerNode));
  }
  std::int64_t landmark_bytes = 0;
  for (const GraphBatch& part : parts) {
    for (const Node& node : part.nodes) {
      landmark_bytes += static_cast<std::int64_t>(node.landmarks_blob.size());
    }
  }
  const std::filesystem::path file = f.dir / "raw-install.db";
  const auto exec = [](sqlite3* db, const char* sql) {
    char* error = nullptr;
    if (sqlite3_exec(db, sql, nullptr, nullptr, &error) != SQLITE_OK) {
      const std::string text = error ? error : "?";
      sqlite3_free(error);
      throw std::runtime_error(std::string(sql) + ": " + text);
    }
  };
  double seconds = 0.0;
  double cpu = 0.0;
  for (auto _ : state) {
    std::filesystem::remove(file);
    const auto start = std::chrono::steady_clock::now();
    const double cpu_before = OwnCpuSeconds();
    sqlite3* db = nullptr;
    sqlite3_open(file.c_str(), &db);
    exec(db,
         "PRAGMA page_size=8192; PRAGMA journal_mode=MEMORY; PRAGMA synchronous=OFF;"
         "PRAGMA cache_size=-32768;"
         "CREATE TABLE nodes (seq INTEGER PRIMARY KEY, id BLOB NOT NULL UNIQUE,"
         " stamp_ns INTEGER NOT NULL, robot BLOB NOT NULL, outing BLOB NOT NULL,"
         " landmarks BLOB NOT NULL);"
         "CREATE INDEX nodes_by_robot ON nodes (robot, stamp_ns);"
         "CREATE INDEX nodes_by_outing ON nodes (outing, stamp_ns);"
         "CREATE TABLE edges (id BLOB PRIMARY KEY NOT NULL, from_id BLOB NOT NULL,"
         " to_id BLOB NOT NULL, kind INTEGER NOT NULL, tx REAL, ty REAL, tz REAL, qw REAL,"
         " qx REAL, qy REAL, qz REAL, path_id BLOB) WITHOUT ROWID;"
         "CREATE INDEX edges_by_from ON edges (from_id);"
         "CREATE INDEX edges_by_to ON edges (to_id);"
         "BEGIN");
    sqlite3_stmt* node_row = nullptr;
    sqlite3_stmt* edge_row = nullptr;
    sqlite3_prepare_v2(db,
                       "INSERT INTO nodes (id, stamp_ns, robot, outing, landmarks)"
                       " VALUES (?1, ?2, ?3, ?4, ?5)",
                       -1, &node_row, nullptr);
    sqlite3_prepare_v2(
        db, "INSERT INTO edges VALUES (?1, ?2, ?3, ?4, ?5, ?5, ?5, ?5, ?5, ?5, ?5, NULL)", -1,
        &edge_row, nullptr);
    for (const GraphBatch& part : parts) {
      for (const Node& node : part.nodes) {
        sqlite3_bind_blob(node_row, 1, node.id.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_int64(node_row, 2, node.stamp_ns);
        sqlite3_bind_blob(node_row, 3, node.robot.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_blob(node_row, 4, node.outing.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_blob64(node_row, 5, node.landmarks_blob.data(), node.landmarks_blob.size(),
                            SQLITE_STATIC);
        if (sqlite3_step(node_row) != SQLITE_DONE) throw std::runtime_error("node insert");
        sqlite3_reset(node_row);
      }
      for (const Edge& edge : part.edges) {
        sqlite3_bind_blob(edge_row, 1, edge.id.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_blob(edge_row, 2, edge.from.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_blob(edge_row, 3, edge.to.bytes().data(), 16, SQLITE_STATIC);
        sqlite3_bind_int(edge_row, 4, 1);
        sqlite3_bind_double(edge_row, 5, 1.0);
        if (sqlite3_step(edge_row) != SQLITE_DONE) throw std::runtime_error("edge insert");
        sqlite3_reset(edge_row);
      }
    }
    sqlite3_finalize(node_row);
    sqlite3_finalize(edge_row);
    exec(db, "COMMIT");
    sqlite3_close(db);
    const int fd = ::open(file.c_str(), O_RDONLY);
    ::fsync(fd);
    ::close(fd);
    cpu += OwnCpuSeconds() - cpu_before;
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  std::filesystem::remove(file);
  state.counters["landmark_MBps"] = seconds > 0 ? static_cast<double>(landmark_bytes) *
                                                      static_cast<double>(state.iterations()) /
                                                      1e6 / seconds
                                                : 0.0;
  state.counters["cpu_ms_per_MB"] = 1e3 * cpu / static_cast<double>(state.iterations()) /
                                    (static_cast<double>(landmark_bytes) / 1e6);
}
BENCHMARK(RawSqliteInstall)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The agent's writer alone: the same map put through a scratch GraphStore in the chunks a
// download brings (about 1 MiB, 100 nodes), one transaction, then fsynced. Between
// RawSqliteInstall and AgentPull: what the store's checks and bookkeeping cost over plain
// sqlite3, without the link.
void StoreScratchInstall(benchmark::State& state) {
  const Uuid robot = Uuid::Generate();
  std::vector<GraphBatch> parts;
  std::int64_t landmark_bytes = 0;
  for (int batch = 0; batch < kNodes / 2000; ++batch) {
    GraphBatch whole = RandomRobotMap(robot, 2000, 1000 + batch, kLandmarksPerNode);
    for (std::size_t first = 0; first < whole.nodes.size(); first += 100) {
      GraphBatch part;
      for (std::size_t i = first; i < std::min(first + 100, whole.nodes.size()); ++i) {
        landmark_bytes += static_cast<std::int64_t>(whole.nodes[i].landmarks_blob.size());
        part.nodes.push_back(whole.nodes[i]);
      }
      if (first == 0) part.paths = whole.paths;
      if (first + 100 >= whole.nodes.size()) part.edges = whole.edges;
      parts.push_back(std::move(part));
    }
  }
  ScratchDir dir{"fleetmap-store-install"};
  const std::filesystem::path file = dir / "install.db";
  double seconds = 0.0;
  for (auto _ : state) {
    std::filesystem::remove(file);
    const auto start = std::chrono::steady_clock::now();
    {
      StoreOptions options;
      options.durability = Durability::kScratch;
      auto store = GraphStore::Open("sqlite:" + file.string(), options);
      GraphStore::Transaction transaction = store->Begin();
      for (const GraphBatch& part : parts) store->Put(part);
      transaction.Commit();
    }
    const int fd = ::open(file.c_str(), O_RDONLY);
    ::fsync(fd);
    ::close(fd);
    seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  }
  state.counters["landmark_MBps"] = seconds > 0 ? static_cast<double>(landmark_bytes) *
                                                      static_cast<double>(state.iterations()) /
                                                      1e6 / seconds
                                                : 0.0;
}
BENCHMARK(StoreScratchInstall)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

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
