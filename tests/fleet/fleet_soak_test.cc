// The soak test of the issue "Nothing a robot builds is ever lost": 20 robots build on their
// maps and sync through real fleetmap-agent processes in loops, with and without waiting for
// their merges, while a chaos thread holds the store's write lock and SIGKILLs fleetmapd at
// random (restarting it on the same address). Bounded: about 25 s of chaos, then every robot
// syncs once more with the server left alone. At the end the head plus the stand-ins accounts
// for every node any robot built, exactly once; no submission failed; the revisions run 1..N
// with no gap; and no robot's map lost a node it built.
#include <gtest/gtest.h>
#include <signal.h>

#include <atomic>
#include <mutex>
#include <random>
#include <set>
#include <thread>

#include "fleet_processes.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "scratch_dir.h"
#include "store_backends.h"
#include "store_write_lock.h"

namespace fleetmap::testing {
namespace {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

constexpr int kRobots = 20;
constexpr int kNodesPerForay = 4;
constexpr milliseconds kChaos{25'000};
constexpr milliseconds kBusyTimeout{500};

// One robot's loop: a foray (new nodes chained on from the last one it built), then a sync.
struct SoakRobot {
  TestRobot robot;
  std::set<Uuid> built;
  std::optional<Uuid> last;
  int syncs = 0, failed_syncs = 0;
  std::string first_problem;  // a local write that could not find its own last node
};

void Foray(SoakRobot& r, std::uint32_t seed) {
  const GraphBatch nodes = r.last ? RandomChainFrom(r.robot.id, *r.last, kNodesPerForay, seed, 30)
                                  : RandomRobotMap(r.robot.id, kNodesPerForay, seed, 30);
  try {
    WriteLocalMap(r.robot, nodes);  // refused (integrity) if the map lost r.last
  } catch (const std::exception& error) {
    if (r.first_problem.empty()) r.first_problem = error.what();
    return;
  }
  for (const Node& node : nodes.nodes) r.built.insert(node.id);
  r.last = nodes.nodes.back().id;
}

template <typename Backend>
class FleetSoakTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_FAIL() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-soak"};
};
TYPED_TEST_SUITE(FleetSoakTest, StoreBackends, BackendNames);

TYPED_TEST(FleetSoakTest, LockHoldsAndKillsLoseNoRobotsNode) {
  const std::string uri = this->backend_.Uri();
  std::vector<SoakRobot> robots(kRobots);
  for (int i = 0; i < kRobots; ++i) {
    robots[i].robot =
        RegisterRobot(uri, "soak-" + std::to_string(i), this->dir_ / ("r" + std::to_string(i)));
  }
  const std::vector<std::string> server_flags = {
      "--busy-timeout-ms", std::to_string(kBusyTimeout.count()), "--merge-max-retry-ms", "1000"};
  std::mutex server_mutex;
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd-0.log", server_flags);
  ASSERT_FALSE(server.address.empty());
  const std::string address = server.address;

  const auto chaos_until = Clock::now() + kChaos;
  std::atomic<int> kills{0}, lock_holds{0};
  std::thread chaos([&] {
    std::mt19937 random(7);
    int restarts = 0;
    while (Clock::now() < chaos_until) {
      std::this_thread::sleep_for(milliseconds(1200 + random() % 1500));
      if (random() % 2 == 0) {
        StoreWriteLock lock(uri);
        ++lock_holds;
        std::this_thread::sleep_for(milliseconds(300 + random() % 1200));
      } else {
        std::lock_guard guard(server_mutex);
        server.process->Signal(SIGKILL);
        server.process->Wait(milliseconds(10'000));
        ++kills;
        std::this_thread::sleep_for(milliseconds(200 + random() % 500));
        server =
            StartFleetmapd(uri, this->dir_ / ("fleetmapd-" + std::to_string(++restarts) + ".log"),
                           server_flags, address);
      }
    }
  });

  std::vector<std::thread> loops;
  for (int i = 0; i < kRobots; ++i) {
    loops.emplace_back([&, i] {
      SoakRobot& r = robots[i];
      std::mt19937 random(100 + i);
      const auto log = this->dir_ / ("agent-" + std::to_string(i) + ".log");
      while (Clock::now() < chaos_until) {
        Foray(r, static_cast<std::uint32_t>(1000 * i + r.syncs));
        std::vector<std::string> flags = {"--policy",     "copy", "--retry-for", "10",
                                          "--io-timeout", "5",    "--quiet"};
        if (random() % 2 == 0) {
          flags.insert(flags.end(), {"--wait-merge", "--merge-timeout", "5"});
        }
        std::unique_ptr<ChildProcess> agent = StartSync(r.robot, address, log, flags);
        agent->ReadRest(milliseconds(60'000));
        const std::optional<int> exit = agent->Wait(milliseconds(10'000));
        ++r.syncs;
        if (exit != 0) ++r.failed_syncs;  // the link or server was down: retried next loop
      }
    });
  }
  for (std::thread& loop : loops) loop.join();
  chaos.join();

  // The server left alone: every robot pushes what is left and waits for its merge.
  std::vector<std::unique_ptr<ChildProcess>> last;
  for (int i = 0; i < kRobots; ++i) {
    last.push_back(StartSync(robots[i].robot, address,
                             this->dir_ / ("agent-" + std::to_string(i) + ".log"),
                             {"--policy", "copy", "--wait-merge", "--merge-timeout", "60",
                              "--retry-for", "30", "--quiet"}));
  }
  for (int i = 0; i < kRobots; ++i) {
    SyncOutcome outcome =
        FinishSync(*last[i], this->dir_ / ("agent-" + std::to_string(i) + ".log"));
    EXPECT_EQ(outcome.exit, 0);
  }

  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  VersionStore& versions = store->versions();
  std::set<Uuid> head;
  std::size_t head_count = 0;
  for (const Node& node : versions.NodesAt(versions.HeadRevision(), false)) {
    head.insert(node.id);
    ++head_count;
  }
  EXPECT_EQ(head.size(), head_count) << "a node twice at the head";
  std::size_t built = 0, syncs = 0, failed_syncs = 0;
  for (const SoakRobot& r : robots) {
    EXPECT_TRUE(r.first_problem.empty()) << r.robot.name << ": " << r.first_problem;
    const std::set<Uuid> local =
        NodeIds(GraphStore::Open("sqlite:" + (r.robot.map_dir / "map.db").string())->ReadMap());
    for (const Uuid& node : r.built) {
      const std::optional<NodeStandIn> stand_in = versions.FindStandIn(node);
      EXPECT_TRUE(head.contains(node) || (stand_in && head.contains(stand_in->stand_in)))
          << r.robot.name << " built " << node.ToString() << ": not in the fleet map";
      EXPECT_TRUE(local.contains(node) || (stand_in && local.contains(stand_in->stand_in)))
          << r.robot.name << " lost " << node.ToString() << " from its own map";
    }
    built += r.built.size();
    syncs += static_cast<std::size_t>(r.syncs);
    failed_syncs += static_cast<std::size_t>(r.failed_syncs);
  }
  std::size_t merged = 0;
  for (const Submission& s : versions.ListSubmissions()) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.id.ToString() << ": " << s.error;
    merged += s.state == SubmissionState::kMerged ? 1 : 0;
  }
  const std::vector<Revision> history = versions.ListRevisions();
  for (std::size_t i = 0; i < history.size(); ++i) {
    EXPECT_EQ(history[i].number, static_cast<RevisionNumber>(i + 1)) << "a gap in the history";
  }
  EXPECT_EQ(history.size(), merged);
  EXPECT_GE(kills.load() + lock_holds.load(), 4) << "the chaos did not happen";
  std::printf(
      "soak: %zu nodes built by %d robots in %zu syncs (%zu failed and retried later), %d kills, "
      "%d lock holds; %zu submissions merged into %zu revisions; head %zu nodes\n",
      built, kRobots, syncs, failed_syncs, kills.load(), lock_holds.load(), merged, history.size(),
      head.size());
}

}  // namespace
}  // namespace fleetmap::testing
