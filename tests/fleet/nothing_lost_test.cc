// Nothing a robot builds is ever lost (two ways a robot's new experiences could vanish, a
// stuck queue), on real fleetmapd and fleetmap-agent processes on 127.0.0.1, both stores:
// 1. a robot pushes without waiting, builds on the nodes it kept, and pushes again while the
//    first push is still queued, or after MERGE omitted the nodes it built on;
// 2. another writer holds the store's write lock for twice the busy timeout when a merge is
//    due (its first write, the claim, meets the lock);
// 3. the same, held for ten busy timeouts, while an agent waits on the merge.
#include <gtest/gtest.h>
#include <signal.h>

#include <algorithm>
#include <regex>
#include <set>
#include <thread>

#include "corridor_robot_map.h"
#include "fleet_processes.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "scratch_dir.h"
#include "store_backends.h"
#include "store_write_lock.h"

namespace fleetmap::testing {
namespace {

using Clock = std::chrono::steady_clock;

std::set<Uuid> HeadNodes(const std::string& uri) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  std::set<Uuid> ids;
  for (const Node& node : store->versions().NodesAt(store->versions().HeadRevision(), false)) {
    ids.insert(node.id);
  }
  return ids;
}

std::set<Uuid> LocalNodes(const TestRobot& robot) {
  return NodeIds(GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->ReadMap());
}

// Each node is in `held`, or MERGE omitted it and its stand-in is in `held`; the ones that are
// neither, for the failure message.
std::vector<Uuid> Unaccounted(const std::string& uri, const std::set<Uuid>& nodes,
                              const std::set<Uuid>& held) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  std::vector<Uuid> missing;
  for (const Uuid& node : nodes) {
    if (held.contains(node)) continue;
    const std::optional<NodeStandIn> stand_in = store->versions().FindStandIn(node);
    if (!stand_in || !held.contains(stand_in->stand_in)) missing.push_back(node);
  }
  return missing;
}

template <typename Predicate>
bool WaitFor(Predicate done, std::chrono::milliseconds timeout) {
  const auto deadline = Clock::now() + timeout;
  while (Clock::now() < deadline) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  return done();
}

std::optional<Submission> OnlySubmissionOf(const std::string& uri, const Uuid& robot,
                                           std::size_t index = 0) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  std::vector<Submission> of_robot;
  for (const Submission& s : store->versions().ListSubmissions()) {
    if (s.robot == robot) of_robot.push_back(s);
  }
  if (index >= of_robot.size()) return std::nullopt;
  return of_robot[index];
}

// The frames of each session the server logged as closed ("...; N frames"), summed.
std::uint64_t FramesLogged(const std::string& log) {
  static const std::regex kClosed("closed: [^\\n]*; ([0-9]+) frames");
  std::uint64_t frames = 0;
  for (auto it = std::sregex_iterator(log.begin(), log.end(), kClosed);
       it != std::sregex_iterator(); ++it) {
    frames += std::stoull((*it)[1].str());
  }
  return frames;
}

template <typename Backend>
class NothingLostTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_FAIL() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-nothing-lost"};
};
TYPED_TEST_SUITE(NothingLostTest, StoreBackends, BackendNames);

// (1) The second push references nodes of the first while the first is still queued (its merge
// held open): accepted, merged after the first, and nothing of either lost anywhere.
TYPED_TEST(NothingLostTest, BuildingOnAPushStillQueuedLosesNothing) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const GraphBatch first = RandomRobotMap(robot.id, 30, 11);
  WriteLocalMap(robot, first);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--debug-merge-delay-ms", "2000"});
  ASSERT_FALSE(server.address.empty());
  const auto log = this->dir_ / "agent.log";

  // Push without waiting: the download does not hold the push, the robot keeps it.
  SyncOutcome pushed =
      FinishSync(*StartSync(robot, server.address, log, {"--policy", "copy"}), log);
  ASSERT_EQ(pushed.exit, 0);
  EXPECT_EQ(pushed.result["pushed_nodes"], 30);
  ASSERT_EQ(LocalNodes(robot), NodeIds(first));

  // The next foray starts at the last node of the first push, whose merge has not committed.
  const GraphBatch second = RandomChainFrom(robot.id, first.nodes.back().id, 20, 12);
  WriteLocalMap(robot, second);
  SyncOutcome again =
      FinishSync(*StartSync(robot, server.address, log, {"--policy", "copy", "--wait-merge"}), log);
  ASSERT_EQ(again.exit, 0) << ReadLog(log);
  EXPECT_EQ(again.result["pushed_nodes"], 20);
  EXPECT_EQ(again.result["merge_state"], "merged") << again.result.dump();

  std::set<Uuid> built = NodeIds(first);
  for (const Uuid& id : NodeIds(second)) built.insert(id);
  const std::set<Uuid> head = HeadNodes(uri);
  EXPECT_TRUE(Unaccounted(uri, built, head).empty());
  EXPECT_EQ(head, built);  // random views: MERGE adds every node
  EXPECT_TRUE(Unaccounted(uri, built, LocalNodes(robot)).empty());
  // The edge into the first push was carried: the head is one connected chain.
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  bool linked = false;
  for (const Edge& edge : store->versions().EdgesAt(store->versions().HeadRevision())) {
    linked |= edge.from == first.nodes.back().id && edge.to == second.nodes.front().id;
  }
  EXPECT_TRUE(linked);
  for (const Submission& s : store->versions().ListSubmissions()) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.error;
  }
}

// A robot's node carries another node's UUID with content of its own (a
// robot that reused an id). Its push is refused with a clear reason naming the node; both
// contents are kept (the server's node at the head, the robot's in its failed submission and in
// its own map, which the download does not overwrite with the other node).
TYPED_TEST(NothingLostTest, ACollidingUuidIsRefusedAndTheRobotKeepsItsOwnNode) {
  const std::string uri = this->backend_.Uri();
  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const TestRobot beta = RegisterRobot(uri, "beta", this->dir_ / "beta");
  const GraphBatch alphas = RandomRobotMap(alpha.id, 10, 41);
  WriteLocalMap(alpha, alphas);
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  const auto alpha_log = this->dir_ / "alpha.log", beta_log = this->dir_ / "beta.log";
  ASSERT_EQ(
      FinishSync(*StartSync(alpha, server.address, alpha_log, {"--policy", "copy", "--wait-merge"}),
                 alpha_log)
          .exit,
      0);

  GraphBatch betas = RandomRobotMap(beta.id, 5, 42);
  const Node& taken = alphas.nodes[3];
  const Uuid own = betas.nodes.front().id;
  betas.nodes.front().id = taken.id;
  for (Edge& edge : betas.edges) {
    if (edge.from == own) edge.from = taken.id;
    if (edge.to == own) edge.to = taken.id;
  }
  const Node beta_node = betas.nodes.front();
  WriteLocalMap(beta, betas);
  std::unique_ptr<ChildProcess> sync =
      StartSync(beta, server.address, beta_log, {"--policy", "copy", "--wait-merge"});
  const std::string out = sync->ReadRest(milliseconds(60'000));
  sync->Wait(milliseconds(10'000));
  const std::string said = out + ReadLog(beta_log);
  EXPECT_NE(said.find(taken.id.ToString()), std::string::npos) << said;
  EXPECT_NE(said.find("other content"), std::string::npos) << said;

  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  EXPECT_EQ(*store->FindNode(taken.id), taken) << "the stored node changed";
  bool refused = false;
  for (const Submission& s : store->versions().ListSubmissions()) {
    refused |= s.robot == beta.id && s.state == SubmissionState::kFailed;
  }
  EXPECT_TRUE(refused);
  const GraphBatch local =
      GraphStore::Open("sqlite:" + (beta.map_dir / "map.db").string())->ReadMap();
  const auto kept = std::find_if(local.nodes.begin(), local.nodes.end(),
                                 [&](const Node& n) { return n.id == taken.id; });
  ASSERT_NE(kept, local.nodes.end());
  EXPECT_EQ(*kept, beta_node) << "the robot was given the other node in place of its own";
}

// (1) The first push drove a place the fleet map knows: MERGE omits (most of) it. The robot kept
// those nodes and built on one MERGE omitted; the push that follows is accepted, its edge goes
// to the omitted node's stand-in, and every node is in the map or stood in for.
TYPED_TEST(NothingLostTest, BuildingOnNodesMergeOmittedLosesNothing) {
  const std::string uri = this->backend_.Uri();
  const TestRobot seed = RegisterRobot(uri, "seed", this->dir_ / "seed");
  const TestRobot robot = RegisterRobot(uri, "beta", this->dir_ / "beta");
  WriteLocalMap(seed, CorridorRobotMap({{0, 0.0}}, seed.id));
  const GraphBatch first = CorridorRobotMap({{0, 0.0}}, robot.id);  // the same corridor
  WriteLocalMap(robot, first);
  // Each merge held open a moment, so the robot's download comes before its merge commits.
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--debug-merge-delay-ms", "1500"});
  ASSERT_FALSE(server.address.empty());
  const auto seed_log = this->dir_ / "seed.log";
  ASSERT_EQ(FinishSync(*StartSync(seed, server.address, seed_log, {"--wait-merge"}), seed_log).exit,
            0);

  const auto log = this->dir_ / "agent.log";
  SyncOutcome pushed =
      FinishSync(*StartSync(robot, server.address, log, {"--policy", "copy"}), log);
  ASSERT_EQ(pushed.exit, 0);
  ASSERT_TRUE(WaitFor(
      [&] {
        const auto s = OnlySubmissionOf(uri, robot.id);
        return s && s->state == SubmissionState::kMerged;
      },
      std::chrono::milliseconds(60'000)));
  // Build on a node MERGE omitted (the robot still holds it: its merge is not downloaded yet).
  std::optional<Uuid> anchor;
  {
    std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
    for (auto it = first.nodes.rbegin(); it != first.nodes.rend() && !anchor; ++it) {
      if (store->versions().FindStandIn(it->id)) anchor = it->id;
    }
  }
  ASSERT_TRUE(anchor) << "MERGE omitted none of the re-driven corridor; the test needs one";
  ASSERT_TRUE(LocalNodes(robot).contains(*anchor));
  const GraphBatch second = RandomChainFrom(robot.id, *anchor, 15, 21);
  WriteLocalMap(robot, second);
  SyncOutcome again =
      FinishSync(*StartSync(robot, server.address, log, {"--policy", "copy", "--wait-merge"}), log);
  ASSERT_EQ(again.exit, 0) << ReadLog(log);
  EXPECT_EQ(again.result["merge_state"], "merged") << again.result.dump();

  std::set<Uuid> built = NodeIds(first);
  for (const Uuid& id : NodeIds(second)) built.insert(id);
  const std::set<Uuid> head = HeadNodes(uri);
  const std::vector<Uuid> lost = Unaccounted(uri, built, head);
  EXPECT_TRUE(lost.empty()) << lost.size() << " nodes neither in the head nor stood in for";
  for (const Uuid& id : NodeIds(second)) EXPECT_TRUE(head.contains(id));
  EXPECT_TRUE(Unaccounted(uri, built, LocalNodes(robot)).empty());
  // The edge to the omitted anchor now joins its stand-in to the new foray.
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  const Uuid stand_in = store->versions().FindStandIn(*anchor)->stand_in;
  bool linked = false;
  for (const Edge& edge : store->versions().EdgesAt(store->versions().HeadRevision())) {
    linked |= edge.from == stand_in && edge.to == second.nodes.front().id;
  }
  EXPECT_TRUE(linked);
}

// A submission queued in the store whose merge will meet another writer's lock: pushed through
// a real agent (which keeps it, unmerged), its merge held open by a fleetmapd that is then
// killed, so the next fleetmapd starts with it queued.
struct QueuedBehindALock {
  TestRobot robot;
  GraphBatch pushed;
  std::filesystem::path agent_log;
};

// The killed fleetmapd and the one started after it are the same server restarted: under its
// own name the new one takes back the claim the dead one held at once, instead of waiting out its
// 30 s lease (which the multi-instance tests cover); what these tests hold up is the store lock.
constexpr const char* kRestartedInstance = "nothing-lost-restarted";

QueuedBehindALock QueueASubmission(const std::filesystem::path& dir, const std::string& uri) {
  QueuedBehindALock queued;
  queued.robot = RegisterRobot(uri, "gamma", dir / "gamma");
  queued.pushed = RandomRobotMap(queued.robot.id, 40, 31);
  WriteLocalMap(queued.robot, queued.pushed);
  queued.agent_log = dir / "agent.log";
  // The held merge keeps the store's write lock (on SQLite, the file's): the agent's report
  // of its install (a hello) waits for it a busy timeout, then goes on without recording it.
  Fleetmapd first = StartFleetmapd(uri, dir / "fleetmapd-1.log",
                                   {"--debug-merge-delay-ms", "60000", "--busy-timeout-ms", "1000",
                                    "--instance", kRestartedInstance});
  EXPECT_FALSE(first.address.empty());
  EXPECT_EQ(
      FinishSync(*StartSync(queued.robot, first.address, queued.agent_log), queued.agent_log).exit,
      0);
  EXPECT_TRUE(first.LogContains("merging", std::chrono::milliseconds(30'000))) << first.Log();
  first.process->Signal(SIGKILL);
  first.process->Wait(std::chrono::milliseconds(10'000));
  const std::optional<Submission> s = OnlySubmissionOf(uri, queued.robot.id);
  EXPECT_TRUE(s && s->state == SubmissionState::kQueued);
  return queued;
}

// (2) The lock is held for twice the busy timeout while the merge runs, then released: the merge
// is retried and goes through; the submission never fails; nothing is lost.
TYPED_TEST(NothingLostTest, LockHeldTwiceTheBusyTimeoutDuringAMergeThenMerges) {
  const std::string uri = this->backend_.Uri();
  const QueuedBehindALock queued = QueueASubmission(this->dir_.path(), uri);
  constexpr std::chrono::milliseconds kBusyTimeout{1000};
  auto lock = std::make_unique<StoreWriteLock>(uri);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd-2.log",
                     {"--busy-timeout-ms", std::to_string(kBusyTimeout.count()),
                      "--merge-max-retry-ms", "1000", "--instance", kRestartedInstance});
  ASSERT_FALSE(server.address.empty());
  // The merge's claim met the lock: it failed transiently and is retried; the submission is
  // still queued, not failed.
  ASSERT_TRUE(server.LogContains("claiming the next submission failed")) << server.Log();
  std::this_thread::sleep_for(2 * kBusyTimeout);
  EXPECT_TRUE(server.LogContains("retrying in")) << server.Log();
  EXPECT_EQ(OnlySubmissionOf(uri, queued.robot.id)->state, SubmissionState::kQueued);
  lock->Release();

  ASSERT_TRUE(WaitFor(
      [&] {
        const auto s = OnlySubmissionOf(uri, queued.robot.id);
        return s && s->state != SubmissionState::kQueued;
      },
      std::chrono::milliseconds(30'000)))
      << server.Log();
  const std::optional<Submission> s = OnlySubmissionOf(uri, queued.robot.id);
  EXPECT_EQ(s->state, SubmissionState::kMerged) << s->error;
  EXPECT_EQ(HeadNodes(uri), NodeIds(queued.pushed));
  // The robot's next sync retires its kept copy against the merged revision: still all there.
  SyncOutcome pulled =
      FinishSync(*StartSync(queued.robot, server.address, queued.agent_log, {"--policy", "copy"}),
                 queued.agent_log);
  EXPECT_EQ(pulled.exit, 0);
  EXPECT_EQ(LocalNodes(queued.robot), NodeIds(queued.pushed));
}

// (3) The lock is held for ten busy timeouts, so that claims fail again and again, while the
// robot's agent waits for the merge: the agent and the server do not spin (frames per second
// stay small), and once the lock goes the submission merges without a restart.
TYPED_TEST(NothingLostTest, LockHeldTenBusyTimeoutsWhileAnAgentWaitsNeitherSpinsNorStrands) {
  const std::string uri = this->backend_.Uri();
  const QueuedBehindALock queued = QueueASubmission(this->dir_.path(), uri);
  constexpr std::chrono::milliseconds kBusyTimeout{500}, kHeld{5000};
  auto lock = std::make_unique<StoreWriteLock>(uri);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd-2.log",
                     {"--busy-timeout-ms", std::to_string(kBusyTimeout.count()),
                      "--merge-max-retry-ms", "1000", "--instance", kRestartedInstance});
  ASSERT_FALSE(server.address.empty());
  const auto waited_from = Clock::now();
  std::unique_ptr<ChildProcess> agent =
      StartSync(queued.robot, server.address, queued.agent_log,
                {"--policy", "copy", "--wait-merge", "--merge-timeout", "60"});
  std::this_thread::sleep_for(kHeld);
  // Every claim met the lock and was retried with a backoff; it stays queued in the store.
  EXPECT_TRUE(server.LogContains("claiming the next submission failed (attempt 3)"))
      << server.Log();
  lock->Release();

  SyncOutcome outcome = FinishSync(*agent, queued.agent_log);
  const double seconds = std::chrono::duration<double>(Clock::now() - waited_from).count();
  ASSERT_EQ(outcome.exit, 0);
  // It waited for the earlier push's merge and pulled the revision that merge made.
  EXPECT_EQ(outcome.result["revision"], 1) << outcome.result.dump();
  EXPECT_GT(outcome.result["merge_wait_seconds"].get<double>(), 1.0);
  const std::optional<Submission> s = OnlySubmissionOf(uri, queued.robot.id);
  EXPECT_EQ(s->state, SubmissionState::kMerged) << s->error;
  EXPECT_EQ(HeadNodes(uri), NodeIds(queued.pushed));
  EXPECT_EQ(LocalNodes(queued.robot), NodeIds(queued.pushed));
  // The agent's session is closed once it has pulled; the server logged its frame count. A
  // robot asking again at once would send thousands a second.
  ASSERT_TRUE(server.LogContains("frames"));
  const std::uint64_t frames = FramesLogged(server.Log());
  std::printf("agent waited %.1f s through the lock: %llu frames (%.1f per second)\n", seconds,
              static_cast<unsigned long long>(frames), static_cast<double>(frames) / seconds);
  EXPECT_LT(static_cast<double>(frames) / seconds, 10.0) << server.Log();
}

}  // namespace
}  // namespace fleetmap::testing
