// fleetmapd under floods of connections, on real processes on 127.0.0.1: the real daemon (SQLite
// store), a real fleetmap-agent sync, and a test that opens the flood's sockets itself. Memory
// follows the bytes a connection sends, not the length it announces; connections that never say
// hello cannot keep a robot out, whether they sit idle or reconnect as fast as they are closed;
// idle HTTP connections cannot keep /metrics from a scraper. Every wait is bounded, every flood
// counted.
//
// The figures (RSS before and at the peak, the agent's sync time) are printed; run
//   build/tests/fleetmapd_flood_test
// to see them.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <memory>
#include <optional>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include "fleet_processes.h"
#include "fleetmap/wire/sync_frame.h"
#include "raw_sync_client.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

using Clock = std::chrono::steady_clock;

constexpr std::int64_t kMaxRssGrowthKb = 50 * 1024;
constexpr auto kAgentBudget = milliseconds(5000);

// The resident set of process `pid` (VmRSS in /proc/PID/status), in KiB; -1 when unreadable.
std::int64_t RssKb(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(status, line);) {
    if (line.rfind("VmRSS:", 0) == 0) return std::stoll(line.substr(6));
  }
  return -1;
}

// Samples a process's RSS every 20 ms until destroyed; the peak seen.
class RssPeak {
 public:
  explicit RssPeak(int pid) : pid_(pid), peak_(RssKb(pid)) {
    thread_ = std::thread([this] {
      while (!stop_.load()) {
        const std::int64_t now = RssKb(pid_);
        if (now > peak_.load()) peak_ = now;
        std::this_thread::sleep_for(milliseconds(20));
      }
    });
  }
  ~RssPeak() {
    stop_ = true;
    thread_.join();
  }
  std::int64_t peak() const { return peak_.load(); }

 private:
  int pid_;
  std::atomic<std::int64_t> peak_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

// A blocking TCP connection to "127.0.0.1:PORT"; -1 when it fails.
int ConnectTo(const std::string& address) {
  const std::size_t colon = address.rfind(':');
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  sockaddr_in addr{};
  addr.sin_family = AF_INET;
  addr.sin_port = htons(static_cast<std::uint16_t>(std::stoi(address.substr(colon + 1))));
  ::inet_pton(AF_INET, address.substr(0, colon).c_str(), &addr.sin_addr);
  if (::connect(fd, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

// The flood's sockets, closed when it goes.
struct Sockets {
  std::vector<int> fds;
  ~Sockets() {
    for (const int fd : fds) {
      if (fd >= 0) ::close(fd);
    }
  }
  // Opens `n` connections, each sending `bytes` (maybe none) and then nothing more.
  void Open(const std::string& address, int n, const std::string& bytes = "") {
    for (int i = 0; i < n; ++i) {
      const int fd = ConnectTo(address);
      ASSERT_GE(fd, 0) << "connection " << i;
      if (!bytes.empty()) {
        ASSERT_EQ(::send(fd, bytes.data(), bytes.size(), MSG_NOSIGNAL),
                  static_cast<long>(bytes.size()));
      }
      fds.push_back(fd);
    }
  }
};

double Seconds(Clock::duration d) {
  return std::chrono::duration<double>(d).count();
}

class FleetmapdFloodTest : public ::testing::Test {
 protected:
  void SetUp() override {
    uri_ = backend_.Uri();
    robot_ = RegisterRobot(uri_, "scout", dir_ / "scout");
    WriteLocalMap(robot_, RandomRobotMap(robot_.id, 30, 5));
  }

  // One whole agent sync (push, download) against `server`; its wall time. Bounded: 60 s.
  Clock::duration AgentSync(const Fleetmapd& server, const std::string& name) {
    const auto log = dir_ / (name + ".log");
    const Clock::time_point start = Clock::now();
    std::unique_ptr<ChildProcess> agent =
        StartSync(robot_, server.address, log, {"--policy", "copy", "--retry-for", "30"});
    const SyncOutcome outcome = FinishSync(*agent, log, milliseconds(60'000));
    const Clock::duration took = Clock::now() - start;
    EXPECT_EQ(outcome.exit, 0) << ReadLog(log);
    if (outcome.exit == 0) {
      std::printf("  agent sync: %.3f s wall (%d retries)\n", Seconds(took),
                  outcome.result.value("retries", 0));
    }
    return took;
  }

  SqliteBackend backend_;
  ScratchDir dir_{"fleetmapd-flood-test"};
  std::string uri_;
  TestRobot robot_;
};

// The acceptance test: 100 connections that announce a 64 MiB frame and send
// nothing more took fleetmapd from 22 MB to 4.8 GB. Before a hello a frame is at most 4 KiB,
// so each is refused at once; and the body is never allocated up front in any case.
TEST_F(FleetmapdFloodTest, AnnouncedLengthsBeforeAHelloCostNoMemory) {
  Fleetmapd server = StartFleetmapd(uri_, dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  const int pid = server.process->pid();
  const std::int64_t before = RssKb(pid);
  ASSERT_GT(before, 0);
  Clock::duration took{};
  std::int64_t peak = 0;
  {
    RssPeak sampler(pid);
    Sockets flood;
    flood.Open(server.address, 100, LengthPrefix(0x04000000));
    took = AgentSync(server, "agent");
    std::this_thread::sleep_for(milliseconds(300));  // let the refusals finish
    peak = sampler.peak();
  }
  const std::int64_t after = RssKb(pid);
  std::printf(
      "fleetmapd RSS: %.1f MB before, %.1f MB peak, %.1f MB after 100 connections "
      "announcing 64 MiB\n",
      before / 1024.0, peak / 1024.0, after / 1024.0);
  EXPECT_LE(peak - before, kMaxRssGrowthKb);
  EXPECT_LE(took, kAgentBudget);
  EXPECT_TRUE(server.LogContains("FRAME_TOO_LARGE")) << server.Log();
}

// The same after a hello: robots may send 64 MiB frames, yet 100 sessions that announce one
// and send 1 KiB of it hold what they sent (and a 64 KiB piece), not 64 MiB each.
TEST_F(FleetmapdFloodTest, AnnouncedLengthsAfterAHelloCostWhatArrivesNotWhatIsAnnounced) {
  Fleetmapd server = StartFleetmapd(uri_, dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  const TestRobot other = RegisterRobot(uri_, "flooder", dir_ / "flooder");
  const int pid = server.process->pid();
  const std::int64_t before = RssKb(pid);
  Clock::duration took{};
  std::int64_t peak = 0;
  {
    RssPeak sampler(pid);
    std::vector<std::unique_ptr<RawSyncClient>> sessions;
    for (int i = 0; i < 100; ++i) {
      sessions.push_back(std::make_unique<RawSyncClient>(server.address));
      const std::optional<v1::SyncFrame> welcome = sessions.back()->Hello(other.id, other.token);
      ASSERT_TRUE(welcome && welcome->has_welcome()) << i;
      ASSERT_TRUE(sessions.back()->SendBytes(LengthPrefix(kMaxSyncFrameBytes - 16) +
                                             std::string(1024, 'x')));
    }
    took = AgentSync(server, "agent");
    peak = sampler.peak();
  }
  std::printf(
      "fleetmapd RSS: %.1f MB before, %.1f MB peak with 100 sessions announcing 64 MiB "
      "after their hello\n",
      before / 1024.0, peak / 1024.0);
  EXPECT_LE(peak - before, kMaxRssGrowthKb);
  EXPECT_LE(took, kAgentBudget);
}

TEST_F(FleetmapdFloodTest, ThreeHundredIdleConnectionsDoNotLockAnAgentOut) {
  Fleetmapd server = StartFleetmapd(uri_, dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  Sockets flood;
  flood.Open(server.address, 300);
  const Clock::duration took = AgentSync(server, "agent");
  std::printf("agent sync beside 300 idle connections: %.3f s\n", Seconds(took));
  EXPECT_LE(took, kAgentBudget);
}

// 300 connections that never say hello, each reopened as soon as the server closes it (pushed
// out, or timed out): the flood keeps the server's pending-hello slots full all the while, and
// the agent still gets through. Bounded: 30 s and 200 000 connections.
TEST_F(FleetmapdFloodTest, AReconnectingFloodDoesNotBeatTheAgentsRetries) {
  Fleetmapd server = StartFleetmapd(uri_, dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  constexpr int kSockets = 300;
  constexpr std::uint64_t kMaxConnections = 200'000;
  std::atomic<bool> stop{false};
  std::atomic<std::uint64_t> connections{0};
  std::thread flood([&] {
    std::vector<pollfd> fds(kSockets);
    for (pollfd& p : fds) {
      p.fd = ConnectTo(server.address);
      p.events = POLLIN;
      connections.fetch_add(1);
    }
    const Clock::time_point end = Clock::now() + std::chrono::seconds(30);
    char sink[256];
    while (!stop.load() && Clock::now() < end && connections.load() < kMaxConnections) {
      if (::poll(fds.data(), fds.size(), 50) <= 0) continue;
      for (pollfd& p : fds) {
        if (p.revents == 0) continue;
        // Readable: the server's BUSY or TIMEOUT, then its close. Reconnect at once.
        if (::recv(p.fd, sink, sizeof sink, MSG_DONTWAIT) > 0) continue;
        ::close(p.fd);
        p.fd = ConnectTo(server.address);
        connections.fetch_add(1);
      }
    }
    for (const pollfd& p : fds) {
      if (p.fd >= 0) ::close(p.fd);
    }
  });
  std::this_thread::sleep_for(milliseconds(500));  // the flood is in full swing
  const std::uint64_t at_start = connections.load();
  const Clock::duration took = AgentSync(server, "agent");
  const std::uint64_t during = connections.load() - at_start;
  stop = true;
  flood.join();
  std::printf(
      "agent sync during a reconnecting flood of %d sockets (%llu connections during "
      "the sync): %.3f s\n",
      kSockets, static_cast<unsigned long long>(during), Seconds(took));
  EXPECT_LE(took, kAgentBudget);
  EXPECT_GT(during, 0u) << "the flood did not run";
}

// The status port: 64 idle connections (its limit) and more cannot keep /metrics from a
// scraper for longer than a moment.
TEST_F(FleetmapdFloodTest, IdleHttpConnectionsDoNotKeepMetricsFromAScraper) {
  Fleetmapd server = StartFleetmapd(uri_, dir_ / "fleetmapd.log", {"--http", "127.0.0.1:0"});
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> line =
      server.process->ReadLineContaining("http on", milliseconds(10'000));
  ASSERT_TRUE(line.has_value()) << server.Log();
  const std::string http = line->substr(line->rfind(' ') + 1);
  for (const int idle_count : {64, 300}) {
    Sockets idle;
    idle.Open(http, idle_count);
    const Clock::time_point start = Clock::now();
    const int fd = ConnectTo(http);
    ASSERT_GE(fd, 0);
    const timeval two_s{2, 0};
    ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &two_s, sizeof two_s);
    const std::string request = "GET /metrics HTTP/1.1\r\nHost: x\r\nConnection: close\r\n\r\n";
    ASSERT_EQ(::send(fd, request.data(), request.size(), MSG_NOSIGNAL),
              static_cast<long>(request.size()));
    std::string response;
    char buffer[4096];
    for (long n; (n = ::recv(fd, buffer, sizeof buffer, 0)) > 0;) response.append(buffer, n);
    ::close(fd);
    const Clock::duration took = Clock::now() - start;
    std::printf("/metrics beside %d idle HTTP connections: %.1f ms\n", idle_count,
                Seconds(took) * 1000);
    EXPECT_EQ(response.rfind("HTTP/1.1 200", 0), 0u) << response.substr(0, 200);
    EXPECT_NE(response.find("fleetmap_sessions_open"), std::string::npos);
    EXPECT_LT(took, milliseconds(1000)) << idle_count << " idle connections";
  }
}

}  // namespace
}  // namespace fleetmap::testing
