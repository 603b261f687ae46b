// Several fleetmapd on one PostgreSQL database:
// three real fleetmapd processes on one throwaway PostgreSQL, 40 real fleetmap-agent processes
// spread over them (each told all three, its own first), and one instance SIGKILLed in the
// middle of a merge. Every pushed node must be in the head exactly once, the revisions 1..N
// without a gap, every submission merged exactly once, the dead instance's submission taken
// over by another after its lease, and each instance's /metrics must say which merges it ran.
// Then, on both stores: an instance frozen past its lease mid-commit rolls back (the fence).
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/beast/core/flat_buffer.hpp>
#include <boost/beast/http.hpp>
#include <cstdlib>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <thread>

#include "fleet_processes.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

namespace http = boost::beast::http;

// GET http://ADDRESS/metrics (127.0.0.1 only), the body.
std::string Metrics(const std::string& address) {
  boost::asio::io_context io;
  boost::asio::ip::tcp::resolver resolver(io);
  boost::asio::ip::tcp::socket socket(io);
  const std::size_t colon = address.rfind(':');
  boost::asio::connect(socket,
                       resolver.resolve(address.substr(0, colon), address.substr(colon + 1)));
  http::request<http::empty_body> request{http::verb::get, "/metrics", 11};
  request.set(http::field::host, address);
  http::write(socket, request);
  boost::beast::flat_buffer buffer;
  http::response<http::string_body> response;
  http::read(socket, buffer, response);
  return response.body();
}

// The value of the sample `name` (no labels), or -1.
double Sample(const std::string& metrics, const std::string& name) {
  const std::regex line("(^|\n)" + name + " ([0-9.e+]+)");
  std::smatch match;
  return std::regex_search(metrics, match, line) ? std::stod(match[2]) : -1.0;
}

// Submission -> revision, from fleetmap_merge_recent_revision samples.
std::map<std::string, std::int64_t> RecentMerges(const std::string& metrics) {
  const std::regex sample(
      "fleetmap_merge_recent_revision\\{instance=\"[^\"]*\",submission=\"([0-9a-f-]+)\"\\} "
      "([0-9]+)");
  std::map<std::string, std::int64_t> merges;
  for (auto it = std::sregex_iterator(metrics.begin(), metrics.end(), sample);
       it != std::sregex_iterator(); ++it) {
    merges[(*it)[1]] = std::stoll((*it)[2]);
  }
  return merges;
}

struct Instance {
  std::string name;
  Fleetmapd server;
  std::string http;  // HOST:PORT of its status page and /metrics
};

Instance StartInstance(const std::string& uri, const std::string& name,
                       const std::filesystem::path& log, std::vector<std::string> extra = {},
                       const std::string& lease_ms = "2000") {
  std::vector<std::string> argv = {"--instance",      name,  "--merge-lease-ms", lease_ms,
                                   "--merge-poll-ms", "200", "--http",           "127.0.0.1:0"};
  argv.insert(argv.end(), extra.begin(), extra.end());
  Instance instance{name, StartFleetmapd(uri, log, argv), ""};
  if (instance.server.address.empty()) return instance;
  const std::optional<std::string> line =
      instance.server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  if (line) instance.http = line->substr(line->rfind(' ') + 1);
  return instance;
}

// The last "merging UUID" the log names.
std::string LastMerging(const std::string& log) {
  const std::regex merging("merging ([0-9a-f-]{36})");
  std::string last;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), merging);
       it != std::sregex_iterator(); ++it) {
    last = (*it)[1];
  }
  return last;
}

class MultiInstanceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = PostgresBackend::Unavailable()) GTEST_FAIL() << *why;
  }
  PostgresBackend backend_;
  ScratchDir dir_{"fleetmap-multi-instance"};
};

TEST_F(MultiInstanceTest, ThreeServersFortyAgentsOneKilledMidMergeLoseAndDoubleNothing) {
  constexpr int kAgents = 40, kNodes = 20;
  const std::string uri = backend_.Uri();
  std::vector<TestRobot> robots;
  std::set<Uuid> all_pushed;
  for (int a = 0; a < kAgents; ++a) {
    robots.push_back(
        RegisterRobot(uri, "robot-" + std::to_string(a), dir_ / ("r" + std::to_string(a))));
    const GraphBatch map = RandomRobotMap(robots.back().id, kNodes, 700 + a);
    WriteLocalMap(robots.back(), map);
    for (const Node& node : map.nodes) all_pushed.insert(node.id);
  }
  // The victim holds every merge open in its commit transaction, so it is surely mid-merge
  // when killed; the other two merge at full speed.
  std::vector<Instance> instances;
  instances.push_back(
      StartInstance(uri, "victim", dir_ / "victim.log", {"--debug-merge-delay-ms", "60000"}));
  instances.push_back(StartInstance(uri, "second", dir_ / "second.log"));
  instances.push_back(StartInstance(uri, "third", dir_ / "third.log"));
  for (const Instance& instance : instances) {
    ASSERT_FALSE(instance.server.address.empty()) << instance.name;
    ASSERT_FALSE(instance.http.empty()) << instance.name;
  }

  std::vector<std::unique_ptr<ChildProcess>> agents;
  for (int a = 0; a < kAgents; ++a) {
    std::string servers;
    for (int k = 0; k < 3; ++k) {
      servers += (k == 0 ? "" : ",") + instances[(a + k) % 3].server.address;
    }
    agents.push_back(StartSync(
        robots[a], servers, dir_ / ("agent-" + std::to_string(a) + ".log"),
        {"--wait-merge", "--merge-timeout", "150", "--retry-for", "90", "--policy", "copy"}));
  }

  // Kill the victim once it is merging (bounded).
  Instance& victim = instances[0];
  ASSERT_TRUE(victim.server.LogContains("merging", std::chrono::milliseconds(60'000)))
      << victim.server.Log();
  std::this_thread::sleep_for(milliseconds(300));  // into its held commit
  const std::string taken_over = LastMerging(victim.server.Log());
  ASSERT_FALSE(taken_over.empty());
  victim.server.process->Signal(SIGKILL);
  ASSERT_EQ(victim.server.process->Wait(milliseconds(10'000)), 128 + SIGKILL);

  for (int a = 0; a < kAgents; ++a) {
    SyncOutcome outcome = FinishSync(*agents[a], dir_ / ("agent-" + std::to_string(a) + ".log"),
                                     milliseconds(180'000));
    ASSERT_EQ(outcome.exit, 0) << "agent " << a;
    EXPECT_EQ(outcome.result["pushed_nodes"], kNodes) << "agent " << a;
  }

  // Every pushed node in the head, once.
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  std::set<Uuid> head;
  for (const Node& node : store->versions().NodesAt(store->versions().HeadRevision(), false)) {
    EXPECT_TRUE(head.insert(node.id).second) << "node twice at the head: " << node.id.ToString();
  }
  EXPECT_EQ(head, all_pushed);
  // Revisions 1..N without a gap, one per submission, every submission merged once.
  const std::vector<Revision> revisions = store->versions().ListRevisions();
  ASSERT_EQ(revisions.size(), static_cast<std::size_t>(kAgents));
  std::set<Uuid> merged_submissions;
  for (std::size_t i = 0; i < revisions.size(); ++i) {
    EXPECT_EQ(revisions[i].number, static_cast<RevisionNumber>(i + 1));
    EXPECT_EQ(revisions[i].kind, RevisionKind::kMerge);
    EXPECT_TRUE(merged_submissions.insert(revisions[i].submission).second)
        << "submission merged twice: " << revisions[i].submission.ToString();
  }
  const std::vector<Submission> submissions = store->versions().ListSubmissions();
  ASSERT_EQ(submissions.size(), static_cast<std::size_t>(kAgents));
  for (const Submission& s : submissions) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.id.ToString() << ": " << s.error;
    EXPECT_TRUE(merged_submissions.contains(s.id)) << s.id.ToString();
  }

  // The two survivors' /metrics: they ran every merge between them (the victim committed
  // none), and one of them says it merged the submission the victim died holding.
  std::map<std::string, std::int64_t> recent;
  double merges = 0;
  for (std::size_t i = 1; i < instances.size(); ++i) {
    const std::string metrics = Metrics(instances[i].http);
    EXPECT_NE(metrics.find("fleetmap_instance_info{instance=\"" + instances[i].name + "\"} 1"),
              std::string::npos)
        << metrics;
    merges += Sample(metrics, "fleetmap_merges_total");
    for (const auto& [submission, revision] : RecentMerges(metrics)) {
      EXPECT_TRUE(recent.emplace(submission, revision).second) << "merged by both: " << submission;
    }
  }
  EXPECT_EQ(merges, kAgents);
  // Each survivor lists its merges (40 fit in its list of the last 64): together, every
  // submission once, with the revision the store gives it.
  EXPECT_EQ(recent.size(), static_cast<std::size_t>(kAgents));
  for (const Submission& s : submissions) {
    const auto listed = recent.find(s.id.ToString());
    ASSERT_NE(listed, recent.end()) << "no survivor lists " << s.id.ToString();
    EXPECT_EQ(listed->second, s.revision) << s.id.ToString();
  }
  EXPECT_TRUE(recent.contains(taken_over)) << "nobody took over " << taken_over;
  std::printf(
      "3 fleetmapd, %d agents, victim killed mid-merge of %s: revisions 1..%zu, %zu nodes\n",
      kAgents, taken_over.c_str(), revisions.size(), head.size());
}

// The peak resident set of a running process (VmHWM), in MB; -1 when unreadable.
double PeakRssMb(int pid) {
  std::ifstream status("/proc/" + std::to_string(pid) + "/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  }
  return -1.0;
}

// A fleet docking at once: FLEETMAP_DOCK_AGENTS robots (16 by
// default; scripts/soak runs 100) on two fleetmapd sharing one PostgreSQL, three rounds: each
// round every robot drives a foray of 20 nodes, then all start their syncs together, push,
// wait for their merges and pull. None may fail; every node is at the head or stood in for.
// Prints the p50/p99 sync time and each instance's peak RSS.
TEST_F(MultiInstanceTest, AFleetDockingAtOnceForThreeRoundsFailsNone) {
  const char* configured = std::getenv("FLEETMAP_DOCK_AGENTS");
  const int agents = configured != nullptr ? std::max(1, std::atoi(configured)) : 16;
  constexpr int kRounds = 3, kNodes = 20;
  const std::string uri = backend_.Uri();
  std::vector<TestRobot> robots;
  std::vector<std::optional<Uuid>> last(agents);
  std::set<Uuid> built;
  for (int a = 0; a < agents; ++a) {
    robots.push_back(
        RegisterRobot(uri, "dock-" + std::to_string(a), dir_ / ("d" + std::to_string(a))));
  }
  std::vector<Instance> instances;
  for (const char* name : {"north", "south"}) {
    instances.push_back(StartInstance(uri, name, dir_ / (std::string(name) + ".log")));
    ASSERT_FALSE(instances.back().server.address.empty()) << name;
  }
  std::vector<double> seconds;
  for (int round = 0; round < kRounds; ++round) {
    for (int a = 0; a < agents; ++a) {
      const std::uint32_t seed = static_cast<std::uint32_t>(10'000 * round + a);
      const GraphBatch foray = last[a] ? RandomChainFrom(robots[a].id, *last[a], kNodes, seed)
                                       : RandomRobotMap(robots[a].id, kNodes, seed);
      WriteLocalMap(robots[a], foray);
      for (const Node& node : foray.nodes) built.insert(node.id);
      last[a] = foray.nodes.back().id;
    }
    std::vector<std::unique_ptr<ChildProcess>> syncs;
    std::vector<std::chrono::steady_clock::time_point> started;
    for (int a = 0; a < agents; ++a) {
      const std::string servers =
          instances[a % 2].server.address + "," + instances[(a + 1) % 2].server.address;
      started.push_back(std::chrono::steady_clock::now());
      syncs.push_back(StartSync(
          robots[a], servers, dir_ / ("dock-" + std::to_string(a) + ".log"),
          {"--wait-merge", "--merge-timeout", "600", "--retry-for", "120", "--policy", "copy"}));
    }
    for (int a = 0; a < agents; ++a) {
      const SyncOutcome outcome = FinishSync(
          *syncs[a], dir_ / ("dock-" + std::to_string(a) + ".log"), milliseconds(900'000));
      seconds.push_back(
          std::chrono::duration<double>(std::chrono::steady_clock::now() - started[a]).count());
      ASSERT_EQ(outcome.exit, 0) << "round " << round << ", agent " << a;
    }
  }
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  VersionStore& versions = store->versions();
  std::set<Uuid> head;
  for (const Node& node : versions.NodesAt(versions.HeadRevision(), false)) head.insert(node.id);
  for (const Uuid& node : built) {
    const std::optional<NodeStandIn> stand_in = versions.FindStandIn(node);
    EXPECT_TRUE(head.contains(node) || (stand_in && head.contains(stand_in->stand_in)))
        << node.ToString();
  }
  for (const Submission& s : versions.ListSubmissions()) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.id.ToString() << ": " << s.error;
  }
  std::sort(seconds.begin(), seconds.end());
  const auto quantile = [&](double q) {
    return seconds[std::min(seconds.size() - 1, static_cast<std::size_t>(q * seconds.size()))];
  };
  std::printf(
      "dock: %d agents x %d rounds on 2 fleetmapd (PostgreSQL): 0 of %zu failed; sync "
      "p50 %.1f s, p99 %.1f s, max %.1f s; peak RSS north %.0f MB, south %.0f MB\n",
      agents, kRounds, seconds.size(), quantile(0.5), quantile(0.99), seconds.back(),
      PeakRssMb(instances[0].server.process->pid()), PeakRssMb(instances[1].server.process->pid()));
}

// An instance frozen (SIGSTOP) mid-merge past its lease: another instance takes the
// submission over and merges it; the frozen one, when it wakes, finds its lease gone and
// drops its merge instead of committing it. The submission is merged once.
template <typename Backend>
class FrozenInstanceTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_FAIL() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-frozen-instance"};
};
TYPED_TEST_SUITE(FrozenInstanceTest, StoreBackends, BackendNames);

TYPED_TEST(FrozenInstanceTest, AnInstanceFrozenPastItsLeaseRollsBackInsteadOfCommitting) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "frozen", this->dir_ / "robot");
  const GraphBatch pushed = RandomRobotMap(robot.id, 20, 31);
  WriteLocalMap(robot, pushed);
  // The merge pauses 3 s after its claim; the lease is 600 ms, renewed every 200 ms while
  // the process runs. The other instance starts only once the frozen one holds the claim: two
  // instances polling one queue race for it, and under load the other could win it first.
  Instance frozen = StartInstance(uri, "frozen", this->dir_ / "frozen.log",
                                  {"--debug-merge-pause-ms", "3000"}, "600");
  ASSERT_FALSE(frozen.server.address.empty());
  const auto log = this->dir_ / "agent.log";
  std::unique_ptr<ChildProcess> agent =
      StartSync(robot, frozen.server.address, log,
                {"--wait-merge", "--merge-timeout", "60", "--retry-for", "60", "--policy", "copy"});

  ASSERT_TRUE(frozen.server.LogContains("merging", std::chrono::milliseconds(30'000)))
      << frozen.server.Log();
  std::this_thread::sleep_for(milliseconds(200));  // into the pause
  // Frozen between writes: stopped inside one (its lease renewal, every 200 ms), it would
  // hold the store's lock, and no instance could take the submission over until it ran again.
  frozen.server.process->Signal(SIGSTOP);
  for (int attempt = 0; attempt < 50 && this->backend_.SubmissionsHeldByAWriter(); ++attempt) {
    frozen.server.process->Signal(SIGCONT);
    std::this_thread::sleep_for(milliseconds(10));
    frozen.server.process->Signal(SIGSTOP);
  }
  ASSERT_FALSE(this->backend_.SubmissionsHeldByAWriter()) << "frozen inside a write 50 times";
  // Past its lease: the other instance claims the submission and merges it.
  Instance other =
      StartInstance(uri, "other", this->dir_ / "other.log", {"--busy-timeout-ms", "500"}, "600");
  ASSERT_FALSE(other.server.address.empty());
  ASSERT_TRUE(other.server.LogContains("merge ", std::chrono::milliseconds(20'000)))
      << other.server.Log();
  ASSERT_TRUE(other.server.LogContains("nodes added", std::chrono::milliseconds(20'000)))
      << other.server.Log();
  frozen.server.process->Signal(SIGCONT);

  SyncOutcome outcome = FinishSync(*agent, log);
  ASSERT_EQ(outcome.exit, 0);
  EXPECT_TRUE(frozen.server.LogContains("the lease ended mid-merge")) << frozen.server.Log();
  EXPECT_FALSE(frozen.server.LogContains("nodes added", milliseconds(0))) << frozen.server.Log();
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  const std::vector<Revision> revisions = store->versions().ListRevisions();
  ASSERT_EQ(revisions.size(), 1u) << "merged once\n"
                                  << frozen.server.Log() << "\n"
                                  << other.server.Log();
  const std::vector<Submission> submissions = store->versions().ListSubmissions();
  ASSERT_EQ(submissions.size(), 1u);
  EXPECT_EQ(submissions[0].state, SubmissionState::kMerged);
  EXPECT_EQ(revisions[0].submission, submissions[0].id);
  std::set<Uuid> head;
  for (const Node& node : store->versions().NodesAt(1, false)) head.insert(node.id);
  EXPECT_EQ(head, NodeIds(pushed));
}

}  // namespace
}  // namespace fleetmap::testing
