// fleetmap-agent against the real fleetmapd, both the built executables run as subprocesses on
// 127.0.0.1 (docs/sync-protocol.md; seed 004 §V): a robot's corridor map pushed, merged and
// downloaded back; a second sync that moves nothing; a refused token; a server that comes up
// late; a pending submission resumed under its id; the daemon's dock file; TLS. Every wait is
// bounded; ChildProcess kills what still runs when a test ends.
#include <arpa/inet.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "corridor_robot_map.h"
#include "fleet_processes.h"
#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/child_process.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/robot_registry.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/wire/sync_frame.h"
#include "program_run.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using testing::Contains;

// A port nothing listens on right now (bound and released; the kernel does not hand it out
// again at once).
std::uint16_t UnusedPort() {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = 0;
  socklen_t size = sizeof address;
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), size), 0);
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size), 0);
  ::close(fd);
  return ntohs(address.sin_port);
}

sockaddr_in Loopback(std::uint16_t port) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  address.sin_port = htons(port);
  return address;
}

// A socket listening on 127.0.0.1 at a port the kernel picks, written to `port`.
int ListenOnLoopback(std::uint16_t& port) {
  const int fd = ::socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in address = Loopback(0);
  socklen_t size = sizeof address;
  EXPECT_EQ(::bind(fd, reinterpret_cast<sockaddr*>(&address), size), 0);
  EXPECT_EQ(::listen(fd, 4), 0);
  EXPECT_EQ(::getsockname(fd, reinterpret_cast<sockaddr*>(&address), &size), 0);
  port = ntohs(address.sin_port);
  return fd;
}

// A TCP relay on 127.0.0.1 to `upstream_port` that cuts its first connection once the client
// has sent `cut_after` bytes through it (a link dropped mid-push); later connections pass
// whole. One connection at a time, as the agent makes them.
class CuttingRelay {
 public:
  CuttingRelay(std::uint16_t upstream_port, std::size_t cut_after)
      : upstream_port_(upstream_port), cut_after_(cut_after) {
    listen_fd_ = ListenOnLoopback(port_);
    thread_ = std::thread([this] { Serve(); });
  }
  ~CuttingRelay() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }
  std::uint16_t port() const { return port_; }
  int connections() const { return connections_; }

 private:
  void Serve() {
    while (!stop_) {
      pollfd listening{listen_fd_, POLLIN, 0};
      if (::poll(&listening, 1, 100) <= 0) continue;
      const int client = ::accept(listen_fd_, nullptr, nullptr);
      if (client < 0) continue;
      const int server = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in address = Loopback(upstream_port_);
      if (::connect(server, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
        Relay(client, server, connections_++ == 0 ? cut_after_ : SIZE_MAX);
      }
      ::close(server);
      ::close(client);
    }
  }

  void Relay(int client, int server, std::size_t cut_after) {
    std::size_t from_client = 0;
    char buffer[64 * 1024];
    while (!stop_) {
      pollfd fds[2] = {{client, POLLIN, 0}, {server, POLLIN, 0}};
      if (::poll(fds, 2, 100) <= 0) continue;
      for (int i = 0; i < 2; ++i) {
        if ((fds[i].revents & (POLLIN | POLLHUP | POLLERR)) == 0) continue;
        std::size_t want = sizeof buffer;
        if (i == 0) want = std::min(want, cut_after - from_client);
        const ssize_t n = want == 0 ? 0 : ::read(fds[i].fd, buffer, want);
        if (n <= 0) return;  // a side closed, or the cut
        if (i == 0) from_client += static_cast<std::size_t>(n);
        if (::write(i == 0 ? server : client, buffer, static_cast<std::size_t>(n)) != n) return;
      }
    }
  }

  std::uint16_t upstream_port_;
  std::size_t cut_after_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> connections_{0};
  std::thread thread_;
};

// A TCP relay on 127.0.0.1 to `upstream_port` that reads the server's frames and spoils the
// download's end on every connection: kWrongDigest flips a bit of DownloadEnd's digest (the
// chunks pass untouched); kCutBeforeEnd passes every chunk, then closes both sides instead of
// forwarding DownloadEnd (a stream truncated after its last chunk, the most a robot could
// mistake for whole). Everything else passes as it is.
class SpoilingRelay {
 public:
  enum class Mode { kWrongDigest, kCutBeforeEnd };

  SpoilingRelay(std::uint16_t upstream_port, Mode mode)
      : upstream_port_(upstream_port), mode_(mode) {
    listen_fd_ = ListenOnLoopback(port_);
    thread_ = std::thread([this] { Serve(); });
  }
  ~SpoilingRelay() {
    stop_ = true;
    thread_.join();
    ::close(listen_fd_);
  }
  std::uint16_t port() const { return port_; }
  int spoiled() const { return spoiled_; }  // downloads spoiled so far
  int chunks() const { return chunks_; }    // download chunks passed so far

 private:
  static bool WriteAll(int fd, const std::string& bytes) {
    std::size_t sent = 0;
    while (sent < bytes.size()) {
      const ssize_t n = ::write(fd, bytes.data() + sent, bytes.size() - sent);
      if (n <= 0) return false;
      sent += static_cast<std::size_t>(n);
    }
    return true;
  }

  void Serve() {
    while (!stop_) {
      pollfd listening{listen_fd_, POLLIN, 0};
      if (::poll(&listening, 1, 100) <= 0) continue;
      const int client = ::accept(listen_fd_, nullptr, nullptr);
      if (client < 0) continue;
      const int server = ::socket(AF_INET, SOCK_STREAM, 0);
      sockaddr_in address = Loopback(upstream_port_);
      if (::connect(server, reinterpret_cast<sockaddr*>(&address), sizeof address) == 0) {
        Relay(client, server);
      }
      ::close(server);
      ::close(client);
    }
  }

  void Relay(int client, int server) {
    SyncFrameDecoder from_server;
    std::vector<char> buffer(256 * 1024);
    while (!stop_) {
      pollfd fds[2] = {{client, POLLIN, 0}, {server, POLLIN, 0}};
      if (::poll(fds, 2, 100) <= 0) continue;
      if (fds[0].revents & (POLLIN | POLLHUP | POLLERR)) {
        const ssize_t n = ::read(client, buffer.data(), buffer.size());
        if (n <= 0) return;
        if (!WriteAll(server, std::string(buffer.data(), static_cast<std::size_t>(n)))) return;
      }
      if (fds[1].revents & (POLLIN | POLLHUP | POLLERR)) {
        const ssize_t n = ::read(server, buffer.data(), buffer.size());
        if (n <= 0) return;
        from_server.Append(std::string_view(buffer.data(), static_cast<std::size_t>(n)));
        while (std::optional<v1::SyncFrame> frame = from_server.Next()) {
          if (frame->has_download_chunk()) ++chunks_;
          if (frame->has_download_end()) {
            ++spoiled_;
            if (mode_ == Mode::kCutBeforeEnd) return;  // closes both sides
            frame->mutable_download_end()->set_digest(frame->download_end().digest() ^ 1);
          }
          if (!WriteAll(client, EncodeSyncFrame(*frame))) return;
        }
      }
    }
  }

  std::uint16_t upstream_port_;
  Mode mode_;
  int listen_fd_ = -1;
  std::uint16_t port_ = 0;
  std::atomic<bool> stop_{false};
  std::atomic<int> spoiled_{0};
  std::atomic<int> chunks_{0};
  std::thread thread_;
};

struct AgentRun {
  int exit = -1;
  nlohmann::json result;  // the --json object; null when none was printed
  std::string out;
  std::string err;
};

std::string Describe(const AgentRun& run) {
  return "exit " + std::to_string(run.exit) + "\nstdout:\n" + run.out + "\nstderr:\n" + run.err;
}

// The robot's corridor map, built once per process (a day outing and a night outing).
const GraphBatch& CorridorMap() {
  static const GraphBatch map = CorridorRobotMap({{0, 0.0}, {1, 0.0}});
  return map;
}

class AgentSyncTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_uri_ = "sqlite:" + (dir_ / "fleet.db").string();
    const std::unique_ptr<GraphStore> store = GraphStore::Open(store_uri_);
    RobotRegistry registry(store->versions());
    const NewRobot added = registry.Add("rover-1", testing::WallNs());
    robot_ = added.robot.id;
    token_ = added.token;
    map_dir_ = dir_ / "robot";
  }

  // Starts fleetmapd on `listen` and waits (30 s at most) for its "listening on" line.
  void StartServer(const std::string& listen = "127.0.0.1:0",
                   const std::vector<std::string>& extra = {}) {
    server_ = testing::StartFleetmapd(store_uri_, server_log(), extra, listen);
    ASSERT_FALSE(server_.address.empty());
    address_ = server_.address;
  }

  fs::path server_log() const { return dir_ / "fleetmapd.log"; }

  // The robot's EBN builder wrote `map` into its map directory, each node and path stamped
  // with this robot's id (the server takes a robot's nodes only in its own
  // name).
  void WriteRobotMap(GraphBatch map) {
    for (Node& node : map.nodes) node.robot = robot_;
    for (Path& path : map.paths) path.robot = robot_;
    fs::create_directories(map_dir_);
    GraphStore::Open("sqlite:" + (map_dir_ / "map.db").string())->Put(map);
  }

  std::vector<std::string> SyncArgs(const std::string& server) const {
    return {"sync",      "--server",        server,  "--robot", robot_.ToString(),
            "--map-dir", map_dir_.string(), "--json"};
  }

  std::unique_ptr<ChildProcess> StartAgent(const std::vector<std::string>& args,
                                           const std::string& token) {
    std::vector<std::string> argv = {FLEETMAP_AGENT_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    std::ofstream(agent_log(), std::ios::trunc).flush();
    return std::make_unique<ChildProcess>(
        argv, ChildProcessOptions{.stderr_file = agent_log(),
                                  .environment = {{"FLEETMAP_TOKEN", token}}});
  }

  AgentRun FinishAgent(ChildProcess& agent, milliseconds timeout = milliseconds(120'000)) {
    AgentRun run;
    run.out = agent.ReadRest(timeout);
    run.exit = agent.Wait(milliseconds(10'000)).value_or(-1);
    run.err = testing::ReadLog(agent_log());
    const std::size_t brace = run.out.find('{');
    if (brace != std::string::npos) {
      try {
        run.result =
            nlohmann::json::parse(run.out.substr(brace, run.out.find('\n', brace) - brace));
      } catch (const nlohmann::json::exception& e) {
        ADD_FAILURE() << "agent printed no JSON object (" << e.what() << "):\n" << Describe(run);
      }
    }
    return run;
  }

  AgentRun RunAgent(const std::vector<std::string>& args, const std::string& token) {
    const std::unique_ptr<ChildProcess> agent = StartAgent(args, token);
    return FinishAgent(*agent);
  }

  fs::path agent_log() const { return dir_ / "agent.log"; }

  ElementIds LocalMapIds() const {
    return IdsOf(GraphStore::Open("sqlite:" + (map_dir_ / "map.db").string())->ReadMap());
  }

  // The server's map at its head, read from its store beside the running server.
  ElementIds ServerHeadIds() const { return IdsOf(Repository::Open(store_uri_)->Checkout()); }

  ScratchDir dir_{"fleetmap-agent-sync"};
  std::string store_uri_;
  Uuid robot_;
  std::string token_;
  fs::path map_dir_;
  testing::Fleetmapd server_;
  std::string address_;
};

TEST_F(AgentSyncTest, PushMergeDownloadThenASecondSyncMovesNothing) {
  StartServer();
  WriteRobotMap(CorridorMap());
  std::vector<std::string> args = SyncArgs(address_);
  args.push_back("--wait-merge");
  const AgentRun first = RunAgent(args, token_);
  ASSERT_EQ(first.exit, 0) << Describe(first);
  const nlohmann::json& r = first.result;
  EXPECT_EQ(r["pushed_nodes"], CorridorMap().nodes.size()) << Describe(first);
  EXPECT_EQ(r["pushed_edges"], CorridorMap().edges.size());
  EXPECT_EQ(r["pushed_paths"], CorridorMap().paths.size());
  EXPECT_TRUE(r["submission"].is_string());
  EXPECT_EQ(r["merge_state"], "merged") << Describe(first);
  EXPECT_GE(r["merged_revision"].get<std::int64_t>(), 1);
  EXPECT_EQ(r["revision"], r["merged_revision"]);
  EXPECT_EQ(r["incremental"], false);
  EXPECT_EQ(r["retries"], 0);
  EXPECT_GT(r["bytes_sent"].get<std::int64_t>(), 0);
  EXPECT_GT(r["bytes_received"].get<std::int64_t>(), 0);
  for (const char* key : {"seconds", "push_seconds", "merge_wait_seconds", "download_seconds"}) {
    EXPECT_TRUE(r[key].is_number()) << key;
  }
  EXPECT_TRUE(Contains(first.err, "pushing chunk 1/")) << first.err;
  EXPECT_TRUE(Contains(first.err, "installed revision")) << first.err;

  // The robot now holds exactly the server's head (a copy download).
  const ElementIds head = ServerHeadIds();
  EXPECT_GT(head.nodes.size(), 0u);
  EXPECT_EQ(LocalMapIds(), head);
  EXPECT_EQ(r["nodes"], head.nodes.size());
  EXPECT_EQ(r["edges"], head.edges.size());
  EXPECT_EQ(r["paths"], head.paths.size());
  {
    LocalMap local = LocalMap::Open(map_dir_, LocalMapAccess::kReadOnly);
    EXPECT_EQ(local.Unsynced().nodes.size(), 0u);
    EXPECT_EQ(local.state().revision, r["revision"].get<std::int64_t>());
  }

  // Nothing new: nothing pushed, an incremental download of nothing.
  const AgentRun second = RunAgent(args, token_);
  ASSERT_EQ(second.exit, 0) << Describe(second);
  EXPECT_EQ(second.result["pushed_nodes"], 0);
  EXPECT_TRUE(second.result["submission"].is_null());
  EXPECT_EQ(second.result["incremental"], true) << Describe(second);
  EXPECT_EQ(second.result["downloaded_nodes"], 0);
  EXPECT_EQ(second.result["downloaded_edges"], 0);
  EXPECT_EQ(second.result["removed_nodes"], 0);
  EXPECT_EQ(second.result["revision"], r["revision"]);
  EXPECT_LT(second.result["bytes_received"].get<std::int64_t>(),
            r["bytes_received"].get<std::int64_t>());
  EXPECT_EQ(LocalMapIds(), head);

  // `status` reports the same.
  const AgentRun status = RunAgent({"status", "--map-dir", map_dir_.string(), "--json"}, "");
  ASSERT_EQ(status.exit, 0) << Describe(status);
  EXPECT_EQ(status.result["revision"], r["revision"]);
  EXPECT_EQ(status.result["unsynced_nodes"], 0);
  EXPECT_EQ(status.result["map_nodes"], head.nodes.size());
}

TEST_F(AgentSyncTest, WithoutWaitingTheRobotKeepsWhatItPushedUntilTheMergeIsDownloaded) {
  StartServer("127.0.0.1:0", {"--debug-merge-delay-ms", "3000"});
  WriteRobotMap(CorridorMap());
  const AgentRun first = RunAgent(SyncArgs(address_), token_);
  ASSERT_EQ(first.exit, 0) << Describe(first);
  EXPECT_EQ(first.result["pushed_nodes"], CorridorMap().nodes.size());
  EXPECT_NE(first.result["merge_state"], "merged") << Describe(first);
  EXPECT_EQ(first.result["revision"], 0);  // the empty head, before the merge
  EXPECT_EQ(first.result["kept_unmerged"], IdsOf(CorridorMap()).size()) << Describe(first);
  EXPECT_EQ(LocalMapIds(), IdsOf(CorridorMap()));  // nothing the robot built is gone

  std::vector<std::string> args = SyncArgs(address_);
  args.push_back("--wait-merge");
  const AgentRun second = RunAgent(args, token_);
  ASSERT_EQ(second.exit, 0) << Describe(second);
  EXPECT_EQ(second.result["pushed_nodes"], 0);
  EXPECT_GE(second.result["revision"].get<std::int64_t>(), 1);
  EXPECT_EQ(second.result["kept_unmerged"], 0);
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
  LocalMap local = LocalMap::Open(map_dir_, LocalMapAccess::kReadOnly);
  EXPECT_TRUE(local.state().unmerged.empty());
}

TEST_F(AgentSyncTest, WrongTokenExitsTwoWithTheServersMessageAndChangesNothing) {
  StartServer();
  WriteRobotMap(CorridorMap());
  const AgentRun run = RunAgent(SyncArgs(address_), std::string(64, '0'));
  EXPECT_EQ(run.exit, 2) << Describe(run);
  EXPECT_TRUE(Contains(run.err, "BAD_TOKEN")) << run.err;
  EXPECT_TRUE(run.result.is_null());
  EXPECT_TRUE(Repository::Open(store_uri_)->Submissions().empty());
  LocalMap local = LocalMap::Open(map_dir_, LocalMapAccess::kReadOnly);
  EXPECT_EQ(local.state().revision, 0);
  EXPECT_FALSE(local.state().submission.has_value());
  EXPECT_EQ(local.Unsynced().nodes.size(), CorridorMap().nodes.size());

  // An unknown robot is refused the same way, with the same words: the server does not say
  // which robot ids it knows.
  std::vector<std::string> args = SyncArgs(address_);
  args[4] = Uuid::Generate().ToString();
  const AgentRun unknown = RunAgent(args, token_);
  EXPECT_EQ(unknown.exit, 2) << Describe(unknown);
  EXPECT_TRUE(Contains(unknown.err, "BAD_TOKEN")) << unknown.err;
  EXPECT_TRUE(Contains(unknown.err, "unknown robot or wrong token")) << unknown.err;
}

TEST_F(AgentSyncTest, BadArgumentsExitTwoBeforeDialling) {
  const AgentRun policy = RunAgent({"sync", "--server", "127.0.0.1:1", "--robot", robot_.ToString(),
                                    "--map-dir", map_dir_.string(), "--policy", "nonsense"},
                                   token_);
  EXPECT_EQ(policy.exit, 2) << Describe(policy);
  EXPECT_TRUE(Contains(policy.err, "nonsense")) << policy.err;
  const AgentRun no_token = RunAgent({"sync", "--server", "127.0.0.1:1", "--robot",
                                      robot_.ToString(), "--map-dir", map_dir_.string()},
                                     "");
  EXPECT_EQ(no_token.exit, 2) << Describe(no_token);
  EXPECT_TRUE(Contains(no_token.err, "token")) << no_token.err;
  const AgentRun empty_server = RunAgent({"sync", "--server", "127.0.0.1:1,,127.0.0.1:2", "--robot",
                                          robot_.ToString(), "--map-dir", map_dir_.string()},
                                         token_);
  EXPECT_EQ(empty_server.exit, 2) << Describe(empty_server);
  EXPECT_TRUE(Contains(empty_server.err, "an empty address")) << empty_server.err;
}

// Several servers on one store: the first listed is down, the retry goes to the next.
TEST_F(AgentSyncTest, ASecondListedServerTakesTheSyncWhenTheFirstIsDown) {
  WriteRobotMap(CorridorMap());
  StartServer();
  const std::string down = "127.0.0.1:" + std::to_string(UnusedPort());
  std::vector<std::string> args = SyncArgs(down + "," + address_);
  args.insert(args.end(), {"--retry-for", "30", "--wait-merge"});
  const AgentRun run = RunAgent(args, token_);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_EQ(run.result["retries"].get<int>(), 1) << Describe(run);
  EXPECT_TRUE(Contains(run.err, "connected to " + address_)) << run.err;
  EXPECT_EQ(run.result["pushed_nodes"], CorridorMap().nodes.size());
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
}

TEST_F(AgentSyncTest, RetriesUntilALateServerComesUp) {
  WriteRobotMap(CorridorMap());
  const std::string listen = "127.0.0.1:" + std::to_string(UnusedPort());
  std::vector<std::string> args = SyncArgs(listen);
  args.insert(args.end(), {"--retry-for", "60", "--wait-merge"});
  const std::unique_ptr<ChildProcess> agent = StartAgent(args, token_);
  std::this_thread::sleep_for(milliseconds(1000));
  StartServer(listen);
  const AgentRun run = FinishAgent(*agent);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_GE(run.result["retries"].get<int>(), 1) << Describe(run);
  EXPECT_TRUE(Contains(run.err, "retry 1 in")) << run.err;
  EXPECT_EQ(run.result["pushed_nodes"], CorridorMap().nodes.size());
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
}

TEST_F(AgentSyncTest, GivesUpAfterRetryForWithExitOne) {
  const std::string listen = "127.0.0.1:" + std::to_string(UnusedPort());
  std::vector<std::string> args = SyncArgs(listen);
  args.insert(args.end(), {"--retry-for", "1"});
  const auto start = std::chrono::steady_clock::now();
  const AgentRun run = RunAgent(args, token_);
  EXPECT_EQ(run.exit, 1) << Describe(run);
  EXPECT_TRUE(Contains(run.err, "failed after")) << run.err;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(20));
}

TEST_F(AgentSyncTest, PushCutMidwayResumesUnderTheSameIdFromTheNextChunk) {
  StartServer();
  const GraphBatch map = testing::RandomRobotMap(Uuid::Generate(), 150, 7, 400);
  const std::size_t chunks = EncodeMapChunks(map).size();
  ASSERT_GE(chunks, 3u);
  WriteRobotMap(map);
  const std::uint16_t server_port =
      static_cast<std::uint16_t>(std::stoi(address_.substr(address_.rfind(':') + 1)));
  // Cut after a chunk and a half: the first chunk is stored, the second is not.
  const CuttingRelay relay(server_port, (std::size_t{3} << 20) / 2);
  std::vector<std::string> args = SyncArgs("127.0.0.1:" + std::to_string(relay.port()));
  args.insert(args.end(), {"--retry-for", "30"});
  const AgentRun run = RunAgent(args, token_);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_GE(run.result["retries"].get<int>(), 1) << Describe(run);
  EXPECT_GE(relay.connections(), 2);
  EXPECT_TRUE(Contains(run.err, "resuming at chunk 2")) << run.err;
  EXPECT_EQ(run.result["pushed_nodes"], map.nodes.size());
  // Sent: the map once, plus the part of chunk 2 that was cut off, not the map twice.
  std::uint64_t map_bytes = 0;
  for (const std::string& chunk : EncodeMapChunks(map)) map_bytes += chunk.size();
  EXPECT_LT(run.result["bytes_sent"].get<std::uint64_t>(), map_bytes + (std::size_t{1} << 20));
  const std::vector<Submission> stored = Repository::Open(store_uri_)->Submissions();
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].id.ToString(), run.result["submission"]);
}

TEST_F(AgentSyncTest, PendingSubmissionIsPushedUnderItsRecordedId) {
  StartServer();
  WriteRobotMap(CorridorMap());
  Uuid pending;
  {  // A run that recorded its submission and died before sending it.
    LocalMap local = LocalMap::Open(map_dir_);
    pending = local.BeginSubmission(local.Unsynced()).id;
  }
  const AgentRun run = RunAgent(SyncArgs(address_), token_);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_EQ(run.result["submission"], pending.ToString());
  EXPECT_EQ(run.result["pushed_nodes"], CorridorMap().nodes.size());
  const std::vector<Submission> stored = Repository::Open(store_uri_)->Submissions();
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_EQ(stored[0].id, pending);
}

TEST_F(AgentSyncTest, DaemonSyncsWhenDockedAndStopsOnSigterm) {
  StartServer();
  WriteRobotMap(CorridorMap());
  const fs::path dock = dir_ / "docked";
  std::vector<std::string> args = SyncArgs(address_);
  args[0] = "daemon";
  args.insert(args.end(), {"--dock-file", dock.string(), "--wait-merge"});
  const std::unique_ptr<ChildProcess> daemon = StartAgent(args, token_);
  std::this_thread::sleep_for(milliseconds(500));
  EXPECT_TRUE(daemon->running());
  std::ofstream(dock).put('\n');
  const std::optional<std::string> line = daemon->ReadLineContaining("{", milliseconds(120'000));
  ASSERT_TRUE(line.has_value()) << testing::ReadLog(agent_log());
  const nlohmann::json result = nlohmann::json::parse(*line);
  EXPECT_EQ(result["pushed_nodes"], CorridorMap().nodes.size());
  EXPECT_EQ(result["merge_state"], "merged");
  for (int i = 0; i < 50 && fs::exists(dock); ++i) std::this_thread::sleep_for(milliseconds(100));
  EXPECT_FALSE(fs::exists(dock));
  daemon->Signal(SIGTERM);
  EXPECT_EQ(daemon->Wait(milliseconds(10'000)), std::optional<int>(0))
      << testing::ReadLog(agent_log());
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
}

TEST_F(AgentSyncTest, SyncsOverTlsVerifyingTheServer) {
  const fs::path cert = dir_ / "cert.pem";
  const fs::path key = dir_ / "key.pem";
  {
    ChildProcess openssl(
        {"/usr/bin/openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt",
         "ec_paramgen_curve:prime256v1", "-nodes", "-days", "1", "-subj", "/CN=127.0.0.1",
         "-addext", "subjectAltName=IP:127.0.0.1", "-keyout", key.string(), "-out", cert.string()},
        ChildProcessOptions{.stderr_file = dir_ / "openssl.log", .environment = {}});
    ASSERT_EQ(openssl.Wait(milliseconds(30'000)), std::optional<int>(0))
        << testing::ReadLog(dir_ / "openssl.log");
  }
  StartServer("127.0.0.1:0", {"--tls-cert", cert.string(), "--tls-key", key.string()});
  WriteRobotMap(CorridorMap());
  std::vector<std::string> args = SyncArgs(address_);
  args.insert(args.end(), {"--tls-ca", cert.string()});
  const AgentRun run = RunAgent(args, token_);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_EQ(run.result["pushed_nodes"], CorridorMap().nodes.size());

  // Plain TCP to a TLS server fails (no retry can fix it within 2 s) ...
  std::vector<std::string> plain = SyncArgs(address_);
  plain.insert(plain.end(), {"--retry-for", "2"});
  EXPECT_NE(RunAgent(plain, token_).exit, 0);
  // ... and a server whose certificate does not chain to the CA is refused at once.
  const fs::path other_ca = dir_ / "other.pem";
  {
    ChildProcess openssl(
        {"/usr/bin/openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt",
         "ec_paramgen_curve:prime256v1", "-nodes", "-days", "1", "-subj", "/CN=other", "-keyout",
         (dir_ / "other-key.pem").string(), "-out", other_ca.string()},
        ChildProcessOptions{.stderr_file = dir_ / "openssl.log", .environment = {}});
    ASSERT_EQ(openssl.Wait(milliseconds(30'000)), std::optional<int>(0));
  }
  std::vector<std::string> wrong = SyncArgs(address_);
  wrong.insert(wrong.end(), {"--tls-ca", other_ca.string(), "--retry-for", "30"});
  const auto start = std::chrono::steady_clock::now();
  const AgentRun refused = RunAgent(wrong, token_);
  EXPECT_EQ(refused.exit, 1) << Describe(refused);
  EXPECT_TRUE(Contains(refused.err, "handshake")) << refused.err;
  EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(10));
  // Without verification (tests only) it connects.
  std::vector<std::string> insecure = SyncArgs(address_);
  insecure.push_back("--tls-insecure");
  EXPECT_EQ(RunAgent(insecure, token_).exit, 0);
}

// An agent without TLS against a TLS server sent its token in clear five times
// and reported only "End of file". It now says the server speaks TLS and how to connect, after
// one attempt: the server saw plain bytes once.
TEST_F(AgentSyncTest, APlainAgentAgainstATlsServerIsToldSoAfterOneAttempt) {
  const fs::path cert = dir_ / "cert.pem";
  const fs::path key = dir_ / "key.pem";
  {
    ChildProcess openssl(
        {"/usr/bin/openssl", "req", "-x509", "-newkey", "ec", "-pkeyopt",
         "ec_paramgen_curve:prime256v1", "-nodes", "-days", "1", "-subj", "/CN=127.0.0.1",
         "-addext", "subjectAltName=IP:127.0.0.1", "-keyout", key.string(), "-out", cert.string()},
        ChildProcessOptions{.stderr_file = dir_ / "openssl.log", .environment = {}});
    ASSERT_EQ(openssl.Wait(milliseconds(30'000)), std::optional<int>(0))
        << testing::ReadLog(dir_ / "openssl.log");
  }
  StartServer("127.0.0.1:0", {"--tls-cert", cert.string(), "--tls-key", key.string()});
  WriteRobotMap(CorridorMap());
  std::vector<std::string> args = SyncArgs(address_);
  args.insert(args.end(), {"--retry-for", "6"});
  const auto start = std::chrono::steady_clock::now();
  const AgentRun run = RunAgent(args, token_);
  const auto took = std::chrono::steady_clock::now() - start;
  EXPECT_NE(run.exit, 0) << Describe(run);
  EXPECT_TRUE(Contains(run.err, "speaks TLS")) << run.err;
  EXPECT_TRUE(Contains(run.err, "--tls-ca")) << run.err;
  EXPECT_LT(took, std::chrono::seconds(4)) << Describe(run);
  const std::string log = testing::ReadLog(server_log());
  std::size_t plain_attempts = 0;
  const std::string refused = "refused: it sent plain bytes, not a TLS handshake";
  for (std::size_t at = log.find(refused); at != std::string::npos;
       at = log.find(refused, at + 1)) {
    ++plain_attempts;
  }
  EXPECT_EQ(plain_attempts, 1u) << log;
}

// Streamed install (protocol version 3): a full download is written into map.db.new as it
// arrives and made current only after DownloadEnd checks. A download whose end does not match
// its chunks, or that stops before its end, leaves the installed map and its state exactly as
// they were (and no map.db.new behind); the next good download installs normally.
TEST_F(AgentSyncTest, ADownloadWithAWrongDigestOrCutBeforeItsEndLeavesTheMapAsItWas) {
  StartServer();
  WriteRobotMap(CorridorMap());
  std::vector<std::string> args = SyncArgs(address_);
  args.push_back("--wait-merge");
  const AgentRun first = RunAgent(args, token_);
  ASSERT_EQ(first.exit, 0) << Describe(first);
  const fs::path map_path = map_dir_ / "map.db";
  const GraphBatch before = GraphStore::Open("sqlite:" + map_path.string())->ReadMap();
  ASSERT_GT(before.nodes.size(), 0u);
  const std::string state_before = testing::ReadLog(map_dir_ / "sync.json");
  ASSERT_FALSE(state_before.empty());

  const std::uint16_t server_port =
      static_cast<std::uint16_t>(std::stoi(address_.substr(address_.rfind(':') + 1)));
  // Another mission start: other parameters than the installed download's, so a full one.
  auto full_download_args = [&](const std::string& server) {
    std::vector<std::string> a = SyncArgs(server);
    for (const char* extra : {"--mission-start", "13:30", "--retry-for", "1"}) a.push_back(extra);
    return a;
  };
  for (const SpoilingRelay::Mode mode :
       {SpoilingRelay::Mode::kWrongDigest, SpoilingRelay::Mode::kCutBeforeEnd}) {
    const bool wrong_digest = mode == SpoilingRelay::Mode::kWrongDigest;
    SCOPED_TRACE(wrong_digest ? "wrong digest" : "cut before the end");
    SpoilingRelay relay(server_port, mode);
    const AgentRun spoiled =
        RunAgent(full_download_args("127.0.0.1:" + std::to_string(relay.port())), token_);
    EXPECT_NE(spoiled.exit, 0) << Describe(spoiled);
    EXPECT_GE(relay.spoiled(), 1);
    EXPECT_GE(relay.chunks(), 1);  // the chunks came, and were written into map.db.new
    if (wrong_digest) {
      EXPECT_TRUE(Contains(spoiled.err, "do not match")) << spoiled.err;
    }
    EXPECT_FALSE(fs::exists(map_dir_ / "map.db.new"));
    EXPECT_FALSE(fs::exists(map_dir_ / "sync.json.next"));
    // The state as it was, but for the failed sync's error, kept for the next hello.
    nlohmann::json state = nlohmann::json::parse(testing::ReadLog(map_dir_ / "sync.json"));
    EXPECT_FALSE(state["last_error"].get<std::string>().empty());
    state["last_error"] = "";
    EXPECT_EQ(state, nlohmann::json::parse(state_before));
    const GraphBatch after = GraphStore::Open("sqlite:" + map_path.string())->ReadMap();
    EXPECT_EQ(after.nodes, before.nodes);  // landmarks included
    EXPECT_EQ(after.paths, before.paths);
    ASSERT_EQ(after.edges.size(), before.edges.size());
    for (std::size_t i = 0; i < after.edges.size(); ++i) {
      EXPECT_TRUE(SameEdgeContent(after.edges[i], before.edges[i])) << i;
    }
  }

  const AgentRun good = RunAgent(full_download_args(address_), token_);
  ASSERT_EQ(good.exit, 0) << Describe(good);
  EXPECT_EQ(good.result["incremental"], false);
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
  EXPECT_NE(testing::ReadLog(map_dir_ / "sync.json"), state_before);  // the new request
}

// A robot already wedged: an agent before the fix recorded its whole backlog as
// one pending submission, which the server refuses at push_begin (over --max-submission-mib,
// before storing a byte) on every sync. The agent abandons that submission and pushes its
// content again in submissions that fit.
TEST_F(AgentSyncTest, APendingSubmissionOverTheServersLimitIsPushedAgainInPartsThatFit) {
  StartServer("127.0.0.1:0", {"--max-submission-mib", "1"});
  const GraphBatch map = testing::RandomRobotMap(robot_, 900, 23);  // about 2.4 MiB
  WriteRobotMap(map);
  Uuid wedged;
  {
    LocalMap local = LocalMap::Open(map_dir_);
    wedged = local.BeginSubmission(local.Unsynced()).id;
  }
  std::vector<std::string> args = SyncArgs(address_);
  args.insert(args.end(), {"--wait-merge", "--retry-for", "5"});
  const AgentRun run = RunAgent(args, token_);
  ASSERT_EQ(run.exit, 0) << Describe(run);
  EXPECT_GE(run.result["submissions"].get<int>(), 3) << Describe(run);
  EXPECT_EQ(run.result["pushed_nodes"], map.nodes.size());
  EXPECT_EQ(run.result["merge_state"], "merged");
  EXPECT_TRUE(Contains(run.err, wedged.ToString() + " is over the server's limits")) << run.err;
  EXPECT_EQ(LocalMapIds(), ServerHeadIds());
  EXPECT_EQ(ServerHeadIds().nodes, IdsOf(map).nodes);
  for (const Submission& s : Repository::Open(store_uri_)->Submissions()) {
    EXPECT_NE(s.id, wedged);  // refused before a byte: the server never stored it
  }
}

// A backlog of FLEETMAP_BACKLOG_NODES nodes (20 000 by default; scripts/soak measures
// 10^6, about 600 MB, in several minutes): `fleetmap-agent status` and a sync
// against a fleetmapd with its default 30 s frame timeout, each under /usr/bin/time -v, which
// prints its time and peak RSS.
TEST_F(AgentSyncTest, ABacklogSyncsAndItsStatusAndSyncAreMeasured) {
  StartServer();
  const char* configured = std::getenv("FLEETMAP_BACKLOG_NODES");
  const int kNodes = configured != nullptr ? std::max(20, std::atoi(configured)) : 20'000;
  {
    const auto start = std::chrono::steady_clock::now();
    fs::create_directories(map_dir_);
    const std::unique_ptr<GraphStore> store =
        GraphStore::Open("sqlite:" + (map_dir_ / "map.db").string());
    for (int part = 0; part < 20; ++part) {  // one path per 50 000 nodes, chained on
      store->Put(testing::RandomRobotMap(robot_, kNodes / 20, 100 + part, /*landmarks=*/13));
    }
    std::printf("wrote %d nodes in %.1f s\n", kNodes,
                std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  const auto timed = [&](const std::vector<std::string>& args, const std::string& what) {
    std::vector<std::string> argv = {"/usr/bin/time", "-v", FLEETMAP_AGENT_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    const fs::path log = dir_ / (what + ".log");
    const auto start = std::chrono::steady_clock::now();
    ChildProcess agent(
        argv, ChildProcessOptions{.stderr_file = log, .environment = {{"FLEETMAP_TOKEN", token_}}});
    const std::string out = agent.ReadRest(milliseconds(3'600'000));
    const std::optional<int> exit = agent.Wait(milliseconds(10'000));
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    const std::string err = testing::ReadLog(log);
    const std::size_t rss = err.find("Maximum resident set size");
    std::printf(
        "%s: exit %d, %.1f s, %s\n%s\n", what.c_str(), exit.value_or(-1), seconds,
        rss == std::string::npos ? "no RSS" : err.substr(rss, err.find('\n', rss) - rss).c_str(),
        out.substr(0, 2000).c_str());
    EXPECT_EQ(exit, std::optional<int>(0)) << err;
  };
  timed({"status", "--map-dir", map_dir_.string(), "--json"}, "status");
  std::vector<std::string> sync = SyncArgs(address_);
  sync.insert(sync.end(), {"--retry-for", "1"});
  timed(sync, "sync");
  timed({"status", "--map-dir", map_dir_.string(), "--json"}, "status-after");
}

// `fleetmap-agent status` of a map whose unmerged submission carries 400 000 ids reads none of
// them: it shows their counts (sync.json's), and its peak RSS is a small process's (the ids
// alone, read as a set, are over 25 MB; as JSON, several times that).
TEST_F(AgentSyncTest, AStatusReadsNoIdsOfALargeUnmergedSubmission) {
  constexpr std::size_t kNodes = 300'000;
  constexpr std::size_t kEdges = 100'000;
  {
    LocalMap map = LocalMap::Open(map_dir_);
    ElementIds content;
    for (std::size_t i = 0; i < kNodes; ++i) content.nodes.insert(Uuid::Generate());
    for (std::size_t i = 0; i < kEdges; ++i) content.edges.insert(Uuid::Generate());
    map.MarkPushed(map.BeginSubmission(content).id);
  }
  const fs::path log = dir_ / "status.log";
  ChildProcess agent({"/usr/bin/time", "-v", FLEETMAP_AGENT_PATH, "status", "--map-dir",
                      map_dir_.string(), "--json"},
                     ChildProcessOptions{.stderr_file = log, .environment = {}});
  const std::string out = agent.ReadRest(milliseconds(60'000));
  ASSERT_EQ(agent.Wait(milliseconds(10'000)), std::optional<int>(0)) << testing::ReadLog(log);
  const nlohmann::json status = nlohmann::json::parse(out);
  ASSERT_EQ(status["unmerged"].size(), 1u) << out;
  EXPECT_EQ(status["unmerged"][0]["nodes"], kNodes);
  EXPECT_EQ(status["unmerged"][0]["edges"], kEdges);
  EXPECT_EQ(status["unsynced_nodes"], 0);
  const std::string err = testing::ReadLog(log);
  const std::string key = "Maximum resident set size (kbytes): ";
  const std::size_t at = err.find(key);
  ASSERT_NE(at, std::string::npos) << err;
  const long kb = std::stol(err.substr(at + key.size()));
  EXPECT_LT(kb, 40 * 1024) << "status peaked at " << kb << " kB";
}

// A robot with a large backlog never synced. The agent read, selected and
// encoded its whole backlog after its hello, and the server, hearing no frame within its frame
// timeout, closed the session; every retry the same. The agent now prepares its submission
// before it says hello and streams it chunk by chunk. A fleetmapd with a short frame timeout
// (0.3 s) and a backlog of 30 000 small nodes (about 0.6 s to prepare the old way) stand in for
// the 30 s timeout and the 10^6 nodes of the report.
TEST_F(AgentSyncTest, ALargeBacklogIsPreparedBeforeTheHelloSoTheFrameTimeoutNeverCutsIt) {
  StartServer("127.0.0.1:0", {"--frame-timeout-s", "0.3"});
  constexpr int kNodes = 30'000;
  const GraphBatch backlog = testing::RandomRobotMap(robot_, kNodes, 21, /*landmarks=*/8);
  WriteRobotMap(backlog);
  std::vector<std::string> args = SyncArgs(address_);
  args.insert(args.end(), {"--retry-for", "3"});
  const AgentRun run = RunAgent(args, token_);
  ASSERT_EQ(run.exit, 0) << Describe(run) << "\nfleetmapd:\n" << testing::ReadLog(server_log());
  EXPECT_EQ(run.result["pushed_nodes"], kNodes);
  EXPECT_EQ(run.result["pushed_edges"], backlog.edges.size());
  EXPECT_EQ(run.result["retries"], 0) << Describe(run);
  EXPECT_EQ(testing::ReadLog(server_log()).find("no frame within"), std::string::npos)
      << testing::ReadLog(server_log());
  const std::vector<Submission> stored = Repository::Open(store_uri_)->Submissions();
  ASSERT_EQ(stored.size(), 1u);
  EXPECT_NE(stored[0].state, SubmissionState::kReceiving);
}

}  // namespace
}  // namespace fleetmap
