// The fleet soak: nothing a robot builds is ever lost, not even after a promote or a revert.
// 20 robots build on their maps and sync through real
// fleetmap-agent processes in loops, with and without waiting for their merges, while a chaos
// thread holds the store's write lock, SIGKILLs a fleetmapd (two instances on PostgreSQL, one on
// SQLite; restarted on the same address), reverts a merge, dreams and promotes the candidate,
// and (when FLEETMAP_SOAK_PG_RESTART names a command, as scripts/soak does) restarts
// PostgreSQL. Bounded: one round of every kind of trouble in turn (about 15 s), or
// FLEETMAP_SOAK_SECONDS of chaos and at least that round (scripts/soak runs 300), then every
// robot syncs once more with the servers left alone. At the end every node any
// robot built is at the head, stood in for, or hidden by a named revision (a revert or a
// promotion), exactly once at the head; no submission failed; the revisions run 1..N with no
// gap; and no robot's map lost a node it built unless a revision hid it, also robots that lost
// their map.db, their sync.json or both between syncs at random.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <mutex>
#include <random>
#include <set>
#include <thread>
#include <type_traits>

#include "fleet_processes.h"
#include "fleetmap/core/error.h"
#include "fleetmap/repository/nightly_dream.h"
#include "fleetmap/repository/repository.h"
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
// How long the chaos lasts at least: FLEETMAP_SOAK_SECONDS, else no longer than its first round.
milliseconds ChaosDuration() {
  const char* seconds = std::getenv("FLEETMAP_SOAK_SECONDS");
  return milliseconds(seconds != nullptr ? 1000 * std::max(1, std::atoi(seconds)) : 0);
}
constexpr milliseconds kBusyTimeout{500};

// One robot's loop: a foray (new nodes chained on from the last one it built), then a sync.
struct SoakRobot {
  TestRobot robot;
  std::set<Uuid> built;
  std::optional<Uuid> last;
  int syncs = 0, failed_syncs = 0;
  int chains_restarted = 0;   // its last node hidden by a revision
  int losses = 0;             // map.db, sync.json or both deleted between its syncs
  bool map_lost = false;      // since the last loss, no sync has succeeded
  std::string first_problem;  // a local write that could not find its own last node
};

// A foray chains on from the robot's last node. When a revert or a promotion hid that node, the
// robot's next download took it out of its map (the operator's call); the robot then starts a
// new chain, as it would after relocalising elsewhere. Any other loss is a problem.
void Foray(SoakRobot& r, std::uint32_t seed, const std::string& uri) {
  const GraphBatch nodes = r.last ? RandomChainFrom(r.robot.id, *r.last, kNodesPerForay, seed, 30)
                                  : RandomRobotMap(r.robot.id, kNodesPerForay, seed, 30);
  try {
    WriteLocalMap(r.robot, nodes);  // refused (integrity) if the map lost r.last
  } catch (const std::exception& error) {
    const std::optional<ElementVersion> version =
        GraphStore::Open(uri)->versions().VersionOf(*r.last);
    if (version && version->hidden) {
      ++r.chains_restarted;
      r.last.reset();
      return;
    }
    if (r.first_problem.empty()) r.first_problem = error.what();
    return;
  }
  for (const Node& node : nodes.nodes) r.built.insert(node.id);
  r.last = nodes.nodes.back().id;
}

// Reverts one of the last few merges that added nodes (as an operator undoing a bad one);
// false when there was none to revert or the store was busy.
bool RevertARecentMerge(const std::string& uri, std::mt19937& random) {
  try {
    std::unique_ptr<Repository> repository = Repository::Open(uri, {});
    std::vector<Revision> merges;
    for (const Revision& revision : repository->History()) {
      if (revision.kind == RevisionKind::kMerge && revision.nodes_added > 0) {
        merges.push_back(revision);
      }
    }
    std::set<RevisionNumber> reverted;
    for (const Revision& revision : repository->History()) {
      if (revision.kind == RevisionKind::kRevert) reverted.insert(revision.reverted);
    }
    std::erase_if(merges, [&](const Revision& r) { return reverted.contains(r.number); });
    if (merges.empty()) return false;
    const std::size_t last = std::min<std::size_t>(merges.size(), 4);
    repository->Revert(merges[merges.size() - 1 - random() % last].number, "soak-operator");
    return true;
  } catch (const Error&) {
    return false;  // busy (a lock held, a merge committing): the operator tries again later
  }
}

// The nightly dream over the last two merged submissions, and its candidate promoted (with
// --force: a tie is promoted too, which moves the most nodes).
bool DreamAndPromote(const std::string& uri) {
  try {
    std::unique_ptr<Repository> repository = Repository::Open(uri, {});
    NightlyDreamOptions options;
    options.max_groups = 2;
    const NightlyDreamOutcome dream = RunNightlyDream(*repository, options);
    if (!dream.candidate) {
      std::fprintf(stderr, "soak: no dream candidate: %s\n", dream.skipped.c_str());
      return false;
    }
    repository->Promote(dream.candidate->id, "soak-operator", /*force=*/true);
    return true;
  } catch (const Error& error) {
    std::fprintf(stderr, "soak: dream or promotion refused: %s\n", error.what());
    return false;
  }
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
      "--busy-timeout-ms",    std::to_string(kBusyTimeout.count()),
      "--merge-max-retry-ms", "1000",
      "--merge-lease-ms",     "3000"};
  // Two instances on PostgreSQL (several fleetmapd on one database), one on SQLite.
  const int instances = std::is_same_v<TypeParam, PostgresBackend> ? 2 : 1;
  std::vector<std::unique_ptr<std::mutex>> server_mutex;
  std::vector<Fleetmapd> servers;
  std::vector<std::string> addresses;
  for (int k = 0; k < instances; ++k) {
    std::vector<std::string> flags = server_flags;
    flags.insert(flags.end(), {"--instance", "soak-" + std::to_string(k)});
    servers.push_back(
        StartFleetmapd(uri, this->dir_ / ("fleetmapd-" + std::to_string(k) + "-0.log"), flags));
    ASSERT_FALSE(servers.back().address.empty());
    addresses.push_back(servers.back().address);
    server_mutex.push_back(std::make_unique<std::mutex>());
  }

  const auto chaos_from = Clock::now();
  const auto chaos_until = chaos_from + ChaosDuration();
  const char* pg_restart = std::getenv("FLEETMAP_SOAK_PG_RESTART");
  std::atomic<int> kills{0}, lock_holds{0}, reverts{0}, promotes{0}, pg_restarts{0};
  std::atomic<bool> chaos_done{false};
  std::thread chaos([&] {
    std::mt19937 random(7);
    int restarts = 0;
    std::size_t step = 0;
    // Each kind of trouble in turn, at random moments: lock, kill, revert, lock, promote,
    // kill, and a PostgreSQL restart when there is a command for it; the round at least once.
    constexpr int kCycle[] = {0, 2, 3, 1, 4, 2, 5};
    const std::size_t round = pg_restart != nullptr ? 7 : 6;
    while (step < round || Clock::now() < chaos_until) {
      std::this_thread::sleep_for(milliseconds(1200 + random() % 1500));
      const int action = kCycle[step++ % round];
      if (action == 0 || action == 1) {
        StoreWriteLock lock(uri);
        ++lock_holds;
        std::this_thread::sleep_for(milliseconds(300 + random() % 1200));
      } else if (action == 2) {
        const int k = static_cast<int>(random() % instances);
        std::lock_guard guard(*server_mutex[k]);
        servers[k].process->Signal(SIGKILL);
        servers[k].process->Wait(milliseconds(10'000));
        ++kills;
        std::this_thread::sleep_for(milliseconds(200 + random() % 500));
        std::vector<std::string> flags = server_flags;
        flags.insert(flags.end(), {"--instance", "soak-" + std::to_string(k)});
        servers[k] = StartFleetmapd(uri,
                                    this->dir_ / ("fleetmapd-" + std::to_string(k) + "-" +
                                                  std::to_string(++restarts) + ".log"),
                                    flags, addresses[k]);
      } else if (action == 3) {
        reverts += RevertARecentMerge(uri, random) ? 1 : 0;
      } else if (action == 4) {
        promotes += DreamAndPromote(uri) ? 1 : 0;
      } else {
        ++pg_restarts;
        EXPECT_EQ(std::system(pg_restart), 0) << pg_restart;
      }
    }
    chaos_done = true;
  });

  std::vector<std::thread> loops;
  for (int i = 0; i < kRobots; ++i) {
    loops.emplace_back([&, i] {
      SoakRobot& r = robots[i];
      std::mt19937 random(100 + i);
      const auto log = this->dir_ / ("agent-" + std::to_string(i) + ".log");
      while (!chaos_done.load()) {
        // A map lost after its last sync is synced back before the robot builds on it again.
        if (!r.map_lost) Foray(r, static_cast<std::uint32_t>(1000 * i + r.syncs), uri);
        std::vector<std::string> flags = {"--policy",     "copy", "--retry-for", "10",
                                          "--io-timeout", "5",    "--quiet"};
        if (random() % 2 == 0) {
          flags.insert(flags.end(), {"--wait-merge", "--merge-timeout", "5"});
        }
        // Told every instance, a random one first (as a fleet's robots are).
        const std::size_t first = random() % addresses.size();
        std::string servers_list = addresses[first];
        for (std::size_t k = 0; k < addresses.size(); ++k) {
          if (k != first) servers_list += "," + addresses[k];
        }
        std::unique_ptr<ChildProcess> agent = StartSync(r.robot, servers_list, log, flags);
        agent->ReadRest(milliseconds(60'000));
        const std::optional<int> exit = agent->Wait(milliseconds(10'000));
        ++r.syncs;
        if (exit != 0) {
          ++r.failed_syncs;  // the link or server was down: retried next loop
          continue;
        }
        r.map_lost = false;
        // Now and then the robot loses its map.db, its sync.json or both between syncs (all it
        // built is pushed by now): its next sync must bring back all of it.
        if (random() % 5 == 0) {
          const int loss = static_cast<int>(random() % 3);
          if (loss != 1) {
            for (const char* suffix : {"", "-wal", "-shm"}) {
              std::filesystem::remove((r.robot.map_dir / "map.db").string() + suffix);
            }
          }
          if (loss != 0) std::filesystem::remove(r.robot.map_dir / "sync.json");
          ++r.losses;
          r.map_lost = true;
        }
      }
    });
  }
  for (std::thread& loop : loops) loop.join();
  chaos.join();
  const Clock::duration chaos_took = Clock::now() - chaos_from;

  // The server left alone: every robot pushes what is left and waits for its merge.
  std::vector<std::unique_ptr<ChildProcess>> last;
  for (int i = 0; i < kRobots; ++i) {
    last.push_back(StartSync(robots[i].robot, addresses[i % addresses.size()],
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
  // Hidden by a named revision (a revert or a promotion), or stood in for by such a node.
  const auto hidden = [&](const Uuid& node) {
    const std::optional<ElementVersion> version = versions.VersionOf(node);
    return version && version->hidden.has_value();
  };
  std::size_t built = 0, syncs = 0, failed_syncs = 0, built_hidden = 0, restarted = 0, losses = 0;
  for (const SoakRobot& r : robots) {
    EXPECT_TRUE(r.first_problem.empty()) << r.robot.name << ": " << r.first_problem;
    const std::set<Uuid> local =
        NodeIds(GraphStore::Open("sqlite:" + (r.robot.map_dir / "map.db").string())->ReadMap());
    for (const Uuid& node : r.built) {
      const std::optional<NodeStandIn> stand_in = versions.FindStandIn(node);
      const bool hid = hidden(node) || (stand_in && hidden(stand_in->stand_in));
      built_hidden += hid ? 1 : 0;
      EXPECT_TRUE(head.contains(node) || (stand_in && head.contains(stand_in->stand_in)) || hid)
          << r.robot.name << " built " << node.ToString() << ": not in the fleet map";
      EXPECT_TRUE(local.contains(node) || (stand_in && local.contains(stand_in->stand_in)) || hid)
          << r.robot.name << " lost " << node.ToString() << " from its own map";
    }
    built += r.built.size();
    syncs += static_cast<std::size_t>(r.syncs);
    failed_syncs += static_cast<std::size_t>(r.failed_syncs);
    restarted += static_cast<std::size_t>(r.chains_restarted);
    losses += static_cast<std::size_t>(r.losses);
  }
  EXPECT_GT(losses, 0u) << "no robot lost its map";
  std::size_t merged = 0;
  for (const Submission& s : versions.ListSubmissions()) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.id.ToString() << ": " << s.error;
    merged += s.state == SubmissionState::kMerged ? 1 : 0;
  }
  const std::vector<Revision> history = versions.ListRevisions();
  std::size_t merges = 0;
  for (std::size_t i = 0; i < history.size(); ++i) {
    EXPECT_EQ(history[i].number, static_cast<RevisionNumber>(i + 1)) << "a gap in the history";
    merges += history[i].kind == RevisionKind::kMerge ? 1 : 0;
  }
  EXPECT_EQ(merges, merged);
  // A round holds the lock twice and kills twice; a revert and a promotion happen when there
  // is a merge to revert and a candidate to promote.
  EXPECT_GE(kills.load(), 2) << "the chaos did not happen";
  EXPECT_GE(lock_holds.load(), 2) << "the chaos did not happen";
  std::printf(
      "soak (%lld s, %d instance(s)): %zu nodes built by %d robots in %zu syncs (%zu failed and "
      "retried later), %d kills, %d lock holds, %d reverts, %d promotions, %d PostgreSQL "
      "restarts; %zu submissions merged; %zu revisions; head %zu nodes; %zu built nodes hidden "
      "by a revision (%zu chains restarted on one); %zu maps or states lost and synced back\n",
      static_cast<long long>(std::chrono::duration_cast<std::chrono::seconds>(chaos_took).count()),
      instances, built, kRobots, syncs, failed_syncs, kills.load(), lock_holds.load(),
      reverts.load(), promotes.load(), pg_restarts.load(), merged, history.size(), head.size(),
      built_hidden, restarted, losses);
}

}  // namespace
}  // namespace fleetmap::testing
