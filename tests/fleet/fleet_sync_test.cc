// Fleet sync across real processes on 127.0.0.1 (fleetmapd and fleetmap-agent): push →
// merge → download on both central stores, 20 agents at once, and the server SIGKILLed in the
// middle of a push and of a merge; landmarks with a stereo camera intact end to end. Exact
// counts throughout: the robots' maps have random landmarks, so MERGE adds every node pushed and
// nothing may be lost or doubled.
#include <gtest/gtest.h>
#include <signal.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <set>
#include <thread>

#include "fleet_processes.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/map_management/subset_contraction.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/version_store.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

std::set<Uuid> HeadNodeIds(const std::string& store_uri) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(store_uri);
  std::set<Uuid> ids;
  for (const Node& node : store->versions().NodesAt(store->versions().HeadRevision(), false)) {
    EXPECT_TRUE(ids.insert(node.id).second) << "node twice at the head: " << node.id.ToString();
  }
  return ids;
}

std::set<Uuid> LocalNodeIds(const TestRobot& robot) {
  return NodeIds(GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->ReadMap());
}

// Polls the central store until `done` holds for the robot's only submission (bounded).
template <typename Predicate>
bool WaitForSubmission(const std::string& store_uri, Predicate done,
                       milliseconds timeout = milliseconds(30'000)) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (std::chrono::steady_clock::now() < deadline) {
    {
      std::unique_ptr<GraphStore> store = GraphStore::Open(store_uri);
      for (const Submission& submission : store->versions().ListSubmissions()) {
        if (done(submission)) return true;
      }
    }
    std::this_thread::sleep_for(milliseconds(20));
  }
  return false;
}

template <typename Backend>
class FleetSyncTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-fleet-sync"};
};
TYPED_TEST_SUITE(FleetSyncTest, StoreBackends, BackendNames);

TYPED_TEST(FleetSyncTest, PushMergeDownloadEndToEnd) {
  const std::string uri = this->backend_.Uri();
  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const TestRobot beta = RegisterRobot(uri, "beta", this->dir_ / "beta");
  const GraphBatch pushed = RandomRobotMap(alpha.id, 40, 1);
  WriteLocalMap(alpha, pushed);
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());

  const auto log = this->dir_ / "alpha.log";
  SyncOutcome first =
      FinishSync(*StartSync(alpha, server.address, log, {"--wait-merge", "--policy", "copy"}), log);
  ASSERT_EQ(first.exit, 0);
  EXPECT_EQ(first.result["pushed_nodes"], 40);
  EXPECT_EQ(first.result["merged_revision"], 1);
  EXPECT_EQ(first.result["revision"], 1);
  EXPECT_EQ(first.result["nodes"], 40);
  EXPECT_EQ(HeadNodeIds(uri), NodeIds(pushed));
  EXPECT_EQ(LocalNodeIds(alpha), NodeIds(pushed));

  // Another robot pulls what alpha pushed; alpha, with nothing new, pushes nothing and pulls
  // an incremental download with nothing in it.
  const auto beta_log = this->dir_ / "beta.log";
  SyncOutcome pulled =
      FinishSync(*StartSync(beta, server.address, beta_log, {"--policy", "copy"}), beta_log);
  EXPECT_EQ(pulled.result["pushed_nodes"], 0);
  EXPECT_EQ(LocalNodeIds(beta), NodeIds(pushed));
  SyncOutcome again =
      FinishSync(*StartSync(alpha, server.address, log, {"--wait-merge", "--policy", "copy"}), log);
  EXPECT_EQ(again.result["pushed_nodes"], 0);
  EXPECT_EQ(again.result["incremental"], true);
  EXPECT_EQ(again.result["nodes"], 40);
  EXPECT_EQ(LocalNodeIds(alpha), NodeIds(pushed));
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  EXPECT_EQ(store->versions().HeadRevision(), 1);
  EXPECT_EQ(store->versions().ListSubmissions().size(), 1u);
}

// A map of two chains of one place, A captured around 08:00 and B around 16:00 (UTC, a day
// back), joined at A's end, each with a path of its own, and a third path (a robot that
// localised in both) stepping A1, B1, A2, B2, ...: a morning download leaves B out, and the
// third path survives it only contracted (A1 -> A2 -> ...).
GraphBatch TwoConditionsMap(const Uuid& robot) {
  const std::int64_t day_ns = 86'400'000'000'000;
  const std::int64_t midnight = (WallNs() / day_ns - 1) * day_ns;
  const auto at_hour = [&](int hour, int i) {
    return midnight + hour * 3'600'000'000'000 + i * 30'000'000'000LL;
  };
  GraphBatch a = RandomRobotMap(robot, 8, 11);
  GraphBatch b = RandomRobotMap(robot, 8, 12);
  for (std::size_t i = 0; i < 8; ++i) {
    a.nodes[i].stamp_ns = at_hour(8, static_cast<int>(i));
    b.nodes[i].stamp_ns = at_hour(16, static_cast<int>(i));
  }
  a.paths[0].start_ns = at_hour(8, 0);
  a.paths[0].end_ns = at_hour(8, 8);
  b.paths[0].start_ns = at_hour(16, 0);
  b.paths[0].end_ns = at_hour(16, 8);
  GraphBatch map = a;
  map.nodes.insert(map.nodes.end(), b.nodes.begin(), b.nodes.end());
  map.edges.insert(map.edges.end(), b.edges.begin(), b.edges.end());
  map.paths.insert(map.paths.end(), b.paths.begin(), b.paths.end());
  Se3 a_T_b = Se3::Identity();
  a_T_b.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  map.edges.push_back(Edge{Uuid::Generate(), a.nodes.back().id, b.nodes.front().id,
                           EdgeKind::kMetric, a_T_b, Uuid()});
  const Path both{Uuid::Generate(), robot, Uuid::Generate(), at_hour(12, 0), at_hour(12, 16)};
  map.paths.push_back(both);
  std::vector<Uuid> steps;
  for (std::size_t i = 0; i < 8; ++i) {
    steps.push_back(a.nodes[i].id);
    steps.push_back(b.nodes[i].id);
  }
  for (std::size_t i = 0; i + 1 < steps.size(); ++i) {
    map.edges.push_back(
        Edge{Uuid::Generate(), steps[i], steps[i + 1], EdgeKind::kPath, Se3::Identity(), both.id});
  }
  return map;
}

// The head's edges by id; none twice, none a download derived.
std::map<Uuid, Edge> HeadEdges(const std::string& store_uri) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(store_uri);
  std::map<Uuid, Edge> edges;
  for (const Edge& edge : store->versions().EdgesAt(store->versions().HeadRevision())) {
    EXPECT_TRUE(edges.emplace(edge.id, edge).second)
        << "edge twice at the head: " << edge.id.ToString();
    EXPECT_FALSE(IsDerivedEdge(edge)) << "a derived edge stored: " << edge.id.ToString();
  }
  return edges;
}

// Every edge of `expected` is at the head, and whatever else is there MERGE made itself (links
// to the map, metric) beyond `before` (the head's edges earlier).
void ExpectHeadHoldsExactly(const std::map<Uuid, Edge>& head, const std::set<Uuid>& expected,
                            const std::map<Uuid, Edge>& before = {}) {
  for (const Uuid& id : expected) EXPECT_TRUE(head.contains(id)) << "lost: " << id.ToString();
  for (const auto& [id, edge] : head) {
    if (expected.contains(id) || before.contains(id)) continue;
    EXPECT_EQ(edge.kind, EdgeKind::kMetric) << "an edge nobody pushed: " << id.ToString();
  }
}

std::set<Uuid> EdgeIds(const GraphBatch& map) {
  std::set<Uuid> ids;
  for (const Edge& edge : map.edges) ids.insert(edge.id);
  return ids;
}

// End to end: a robot pulls a morning download (protocol 4: path memory
// contracted over the afternoon chain it leaves out), builds on it, and pushes; then its whole
// map, derived edges included, is pushed again as a submission. The server recognises every
// derived edge: nothing the robots built is lost, nothing is stored twice, and no derived edge
// reaches the map.
TYPED_TEST(FleetSyncTest, AContractedDownloadBuiltOnAndPushedBackLosesAndDoublesNothing) {
  const std::string uri = this->backend_.Uri();
  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const TestRobot beta = RegisterRobot(uri, "beta", this->dir_ / "beta");
  const GraphBatch surveyed = TwoConditionsMap(alpha.id);
  WriteLocalMap(alpha, surveyed);
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  const auto alpha_log = this->dir_ / "alpha.log";
  ASSERT_EQ(
      FinishSync(*StartSync(alpha, server.address, alpha_log, {"--wait-merge", "--policy", "copy"}),
                 alpha_log)
          .exit,
      0);
  const std::map<Uuid, Edge> after_alpha = HeadEdges(uri);
  ExpectHeadHoldsExactly(after_alpha, EdgeIds(surveyed));

  const std::vector<std::string> morning = {
      "--wait-merge", "--policy", "tod", "--mission-start", "08:00", "--window-min", "60"};
  const auto beta_log = this->dir_ / "beta.log";
  SyncOutcome pulled = FinishSync(*StartSync(beta, server.address, beta_log, morning), beta_log);
  ASSERT_EQ(pulled.exit, 0);
  EXPECT_EQ(pulled.result["nodes"], 8) << "the morning chain only";
  const GraphBatch downloaded =
      GraphStore::Open("sqlite:" + (beta.map_dir / "map.db").string())->ReadMap();
  const Uuid both = surveyed.paths.back().id;
  std::set<std::pair<Uuid, Uuid>> contracted;
  for (const Edge& edge : downloaded.edges) {
    if (IsDerivedEdge(edge)) {
      EXPECT_EQ(edge.path, both);
      contracted.emplace(edge.from, edge.to);
    }
  }
  std::set<std::pair<Uuid, Uuid>> expected;
  for (std::size_t i = 0; i + 1 < 8; ++i) {
    expected.emplace(surveyed.nodes[i].id, surveyed.nodes[i + 1].id);
  }
  EXPECT_EQ(contracted, expected) << "the third path, step by step over the afternoon chain";

  // Beta drives on from the morning chain's end, on a path through what it downloaded.
  GraphBatch built = RandomChainFrom(beta.id, surveyed.nodes[7].id, 5, 21);
  built.edges.push_back(Edge{Uuid::Generate(), surveyed.nodes[6].id, surveyed.nodes[7].id,
                             EdgeKind::kPath, Se3::Identity(), built.paths[0].id});
  built.edges.push_back(Edge{Uuid::Generate(), surveyed.nodes[7].id, built.nodes[0].id,
                             EdgeKind::kPath, Se3::Identity(), built.paths[0].id});
  WriteLocalMap(beta, built);
  SyncOutcome pushed = FinishSync(*StartSync(beta, server.address, beta_log, morning), beta_log);
  ASSERT_EQ(pushed.exit, 0);
  EXPECT_EQ(pushed.result["pushed_nodes"], 5);
  std::set<Uuid> expected_nodes = NodeIds(surveyed), expected_edges = EdgeIds(surveyed);
  for (const Node& node : built.nodes) expected_nodes.insert(node.id);
  for (const Edge& edge : built.edges) expected_edges.insert(edge.id);
  EXPECT_EQ(HeadNodeIds(uri), expected_nodes);
  const std::map<Uuid, Edge> after_beta = HeadEdges(uri);
  ExpectHeadHoldsExactly(after_beta, expected_edges, after_alpha);
  server.process->Signal(SIGTERM);
  server.process->Wait(milliseconds(10'000));

  // The robot's whole map pushed again (as `fleetmap push --map` would): its derived edges come
  // back, are recognised and dropped, and the map does not change.
  const GraphBatch whole =
      GraphStore::Open("sqlite:" + (beta.map_dir / "map.db").string())->ReadMap();
  ASSERT_FALSE(contracted.empty());
  std::unique_ptr<Repository> repository = Repository::Open(uri);
  const Uuid again = Uuid::Generate();
  repository->Push(again, beta.id, "beta, whole map", whole);
  const MergeOutcome outcome = repository->Merge(again);
  EXPECT_EQ(outcome.report.nodes_added, 0u);
  EXPECT_GE(outcome.report.derived_edges, contracted.size());
  EXPECT_EQ(outcome.report.path_edges_added, 0u);
  EXPECT_EQ(outcome.report.metric_edges_added, 0u);
  EXPECT_EQ(HeadNodeIds(uri), expected_nodes);
  std::set<Uuid> before, after;
  for (const auto& [id, edge] : after_beta) before.insert(id);
  for (const auto& [id, edge] : HeadEdges(uri)) after.insert(id);
  EXPECT_EQ(after, before) << "the whole map again changed the map";
}

// Landmarks with a stereo camera through the whole fleet: pushed by one robot,
// merged by fleetmapd (which decodes every pushed node and localises it against the map) and
// pulled by another robot, and what lands in the central store and in the other robot's map
// decodes to exactly the landmarks pushed, camera included. Every other node carries no camera,
// so a map mixing old and new landmarks travels too.
TYPED_TEST(FleetSyncTest, StereoLandmarksArePushedMergedAndPulledIntact) {
  const std::string uri = this->backend_.Uri();
  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const TestRobot beta = RegisterRobot(uri, "beta", this->dir_ / "beta");
  GraphBatch pushed = RandomRobotMap(alpha.id, 12, 3);
  std::map<Uuid, Landmarks> landmarks;
  for (std::size_t i = 0; i < pushed.nodes.size(); ++i) {
    Node& node = pushed.nodes[i];
    Landmarks view = DecodeLandmarks(node.landmarks_blob);
    if (i % 2 == 0) {
      const Eigen::Quaternionf q(Eigen::AngleAxisf(0.01f * static_cast<float>(i + 1),
                                                   Eigen::Vector3f(0.1f, 1.f, 0.3f).normalized()));
      view.stereo = StereoCamera{.focal_px = 718.856f + static_cast<float>(i),
                                 .baseline_m = 0.5371657f,
                                 .rect_q_camera = {q.w(), q.x(), q.y(), q.z()}};
      node.landmarks_blob = EncodeLandmarks(view);
    }
    landmarks.emplace(node.id, std::move(view));
  }
  WriteLocalMap(alpha, pushed);
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());

  const auto alpha_log = this->dir_ / "alpha.log";
  SyncOutcome push =
      FinishSync(*StartSync(alpha, server.address, alpha_log, {"--wait-merge", "--policy", "copy"}),
                 alpha_log);
  ASSERT_EQ(push.exit, 0);
  EXPECT_EQ(push.result["pushed_nodes"], 12);
  EXPECT_EQ(push.result["merged_revision"], 1);
  const auto beta_log = this->dir_ / "beta.log";
  SyncOutcome pull =
      FinishSync(*StartSync(beta, server.address, beta_log, {"--policy", "copy"}), beta_log);
  ASSERT_EQ(pull.exit, 0);
  EXPECT_EQ(pull.result["nodes"], 12);

  const auto expect_pushed_landmarks = [&](const std::vector<Node>& nodes, const char* where) {
    std::set<Uuid> seen;
    int with_camera = 0;
    for (const Node& node : nodes) {
      SCOPED_TRACE(::testing::Message() << where << " " << node.id.ToString());
      ASSERT_EQ(landmarks.count(node.id), 1u);
      const Landmarks decoded = DecodeLandmarks(node.landmarks_blob);
      EXPECT_EQ(decoded, landmarks.at(node.id));
      EXPECT_EQ(decoded.stereo, landmarks.at(node.id).stereo);
      if (decoded.stereo) ++with_camera;
      seen.insert(node.id);
    }
    EXPECT_EQ(seen, NodeIds(pushed)) << where;
    EXPECT_EQ(with_camera, 6) << where;
  };
  std::unique_ptr<GraphStore> central = GraphStore::Open(uri);
  expect_pushed_landmarks(central->versions().NodesAt(central->versions().HeadRevision(), true),
                          "central head");
  expect_pushed_landmarks(
      GraphStore::Open("sqlite:" + (beta.map_dir / "map.db").string())->ReadMap().nodes,
      "beta's map");
  expect_pushed_landmarks(
      GraphStore::Open("sqlite:" + (alpha.map_dir / "map.db").string())->ReadMap().nodes,
      "alpha's map after the pull");
}

TYPED_TEST(FleetSyncTest, TwentyAgentsAtOnceLoseAndDuplicateNothing) {
  constexpr int kAgents = 20, kNodes = 25;
  const std::string uri = this->backend_.Uri();
  std::vector<TestRobot> robots;
  std::set<Uuid> all_pushed;
  for (int a = 0; a < kAgents; ++a) {
    robots.push_back(
        RegisterRobot(uri, "robot-" + std::to_string(a), this->dir_ / ("r" + std::to_string(a))));
    const GraphBatch map = RandomRobotMap(robots.back().id, kNodes, 100 + a);
    WriteLocalMap(robots.back(), map);
    for (const Node& node : map.nodes) all_pushed.insert(node.id);
  }
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());

  std::vector<std::unique_ptr<ChildProcess>> agents;
  for (int a = 0; a < kAgents; ++a) {
    agents.push_back(StartSync(robots[a], server.address,
                               this->dir_ / ("agent-" + std::to_string(a) + ".log"),
                               {"--wait-merge", "--merge-timeout", "120", "--policy", "copy"}));
  }
  std::vector<double> latencies;
  std::set<std::int64_t> revisions;
  for (int a = 0; a < kAgents; ++a) {
    SyncOutcome outcome =
        FinishSync(*agents[a], this->dir_ / ("agent-" + std::to_string(a) + ".log"));
    ASSERT_EQ(outcome.exit, 0);
    EXPECT_EQ(outcome.result["pushed_nodes"], kNodes);
    revisions.insert(outcome.result["merged_revision"].template get<std::int64_t>());
    latencies.push_back(outcome.result["seconds"].template get<double>());
    // What it pulled is the map at the revision it pulled: its own nodes among them.
    const std::set<Uuid> local = LocalNodeIds(robots[a]);
    EXPECT_EQ(local.size(), outcome.result["nodes"].template get<std::size_t>());
  }
  // Every submission became exactly one revision, and the head holds every node pushed, once.
  EXPECT_EQ(revisions.size(), static_cast<std::size_t>(kAgents));
  EXPECT_EQ(HeadNodeIds(uri), all_pushed);
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  EXPECT_EQ(store->versions().HeadRevision(), kAgents);
  const std::vector<Submission> submissions = store->versions().ListSubmissions();
  ASSERT_EQ(submissions.size(), static_cast<std::size_t>(kAgents));
  for (const Submission& s : submissions) EXPECT_EQ(s.state, SubmissionState::kMerged);

  std::sort(latencies.begin(), latencies.end());
  const auto at = [&](double q) {
    return latencies[static_cast<std::size_t>(q * static_cast<double>(latencies.size() - 1))];
  };
  std::printf("20 agents at once: sync latency p50 %.3f s, p99 %.3f s (push, wait merge, pull)\n",
              at(0.5), at(0.99));
  ::testing::Test::RecordProperty("sync_p50_ms", static_cast<int>(at(0.5) * 1000));
  ::testing::Test::RecordProperty("sync_p99_ms", static_cast<int>(at(0.99) * 1000));
}

TYPED_TEST(FleetSyncTest, ServerKilledMidPushRestartsAndTheAgentResumes) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "gamma", this->dir_ / "gamma");
  // About 4 MB of landmarks: several 1 MiB chunks.
  const GraphBatch pushed = RandomRobotMap(robot.id, 1500, 7);
  WriteLocalMap(robot, pushed);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--debug-chunk-delay-ms", "300"});
  ASSERT_FALSE(server.address.empty());
  const auto log = this->dir_ / "agent.log";
  std::unique_ptr<ChildProcess> agent =
      StartSync(robot, server.address, log, {"--wait-merge", "--retry-for", "90"});

  // Kill the server once two chunks are stored and before the last arrives.
  ASSERT_TRUE(WaitForSubmission(uri, [](const Submission& s) { return s.chunk_count >= 2; }));
  server.process->Signal(SIGKILL);
  ASSERT_EQ(server.process->Wait(milliseconds(10'000)), 128 + SIGKILL);
  {
    std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
    const std::vector<Submission> cut = store->versions().ListSubmissions();
    ASSERT_EQ(cut.size(), 1u);
    EXPECT_EQ(cut[0].state, SubmissionState::kReceiving);
    EXPECT_EQ(store->versions().HeadRevision(), 0);
  }
  // The same address again: the agent's retries reach it and resume the push.
  Fleetmapd restarted = StartFleetmapd(uri, this->dir_ / "fleetmapd-2.log", {}, server.address);
  ASSERT_FALSE(restarted.address.empty());
  SyncOutcome outcome = FinishSync(*agent, log);
  ASSERT_EQ(outcome.exit, 0);
  EXPECT_GE(outcome.result["retries"].template get<int>(), 1);
  EXPECT_EQ(outcome.result["pushed_nodes"], 1500);
  EXPECT_EQ(outcome.result["merged_revision"], 1);
  EXPECT_EQ(HeadNodeIds(uri), NodeIds(pushed));
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  const std::vector<Submission> submissions = store->versions().ListSubmissions();
  ASSERT_EQ(submissions.size(), 1u);
  EXPECT_EQ(submissions[0].state, SubmissionState::kMerged);
  // The restarted server took the rest of the chunks, not the whole push again.
  EXPECT_NE(ReadLog(this->dir_ / "fleetmapd-2.log").find("resum"), std::string::npos)
      << ReadLog(this->dir_ / "fleetmapd-2.log");
}

TYPED_TEST(FleetSyncTest, ServerKilledMidMergeMergesTheQueuedSubmissionAfterRestart) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "delta", this->dir_ / "delta");
  const GraphBatch pushed = RandomRobotMap(robot.id, 200, 9);
  WriteLocalMap(robot, pushed);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--debug-merge-delay-ms", "60000"});
  ASSERT_FALSE(server.address.empty());
  const auto log = this->dir_ / "agent.log";
  std::unique_ptr<ChildProcess> agent =
      StartSync(robot, server.address, log, {"--wait-merge", "--retry-for", "90"});

  // The push is complete and queued; the merge is under way (held by the delay) when killed.
  ASSERT_TRUE(WaitForSubmission(
      uri, [](const Submission& s) { return s.state == SubmissionState::kQueued; }));
  const auto deadline = std::chrono::steady_clock::now() + milliseconds(30'000);
  while (server.Log().find("merging") == std::string::npos &&
         std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(milliseconds(20));
  }
  ASSERT_NE(server.Log().find("merging"), std::string::npos) << server.Log();
  server.process->Signal(SIGKILL);
  ASSERT_EQ(server.process->Wait(milliseconds(10'000)), 128 + SIGKILL);
  {
    std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
    EXPECT_EQ(store->versions().HeadRevision(), 0);  // nothing half-merged
    EXPECT_EQ(store->versions().ListSubmissions().at(0).state, SubmissionState::kQueued);
  }
  Fleetmapd restarted = StartFleetmapd(uri, this->dir_ / "fleetmapd-2.log", {}, server.address);
  ASSERT_FALSE(restarted.address.empty());
  SyncOutcome outcome = FinishSync(*agent, log);
  ASSERT_EQ(outcome.exit, 0);
  EXPECT_EQ(outcome.result["merged_revision"], 1);
  EXPECT_EQ(HeadNodeIds(uri), NodeIds(pushed));
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  EXPECT_EQ(store->versions().HeadRevision(), 1);  // merged once, not twice
  EXPECT_EQ(store->versions().ListSubmissions().size(), 1u);
}

// `fleetmap-agent status --json` of a robot's map directory.
nlohmann::json AgentStatus(const TestRobot& robot, const std::filesystem::path& log) {
  ChildProcess status(
      {FLEETMAP_AGENT_PATH, "status", "--map-dir", robot.map_dir.string(), "--json"},
      ChildProcessOptions{.stderr_file = log, .environment = {}});
  const std::string out = status.ReadRest(milliseconds(30'000));
  EXPECT_EQ(status.Wait(milliseconds(10'000)), std::optional<int>(0)) << ReadLog(log);
  try {
    return nlohmann::json::parse(out);
  } catch (const nlohmann::json::exception&) {
    ADD_FAILURE() << "status printed no JSON: " << out << "\n" << ReadLog(log);
    return nullptr;
  }
}

// A robot whose new content was over fleetmapd's --max-submission-mib was
// wedged: every sync was refused at push_begin and exited before its download. The agent now
// learns the server's limit from the welcome and pushes its content as several submissions
// that each fit, in one sync; an edge to a node of an earlier part resolves because the server
// merges the parts in order.
TYPED_TEST(FleetSyncTest, AMapOverTheSubmissionLimitGoesInPartsThatFitAndTheRobotDownloads) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "epsilon", this->dir_ / "epsilon");
  const GraphBatch pushed = RandomRobotMap(robot.id, 900, 13);  // about 2.4 MiB
  WriteLocalMap(robot, pushed);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--max-submission-mib", "1"});
  ASSERT_FALSE(server.address.empty());
  const auto log = this->dir_ / "agent.log";
  SyncOutcome outcome = FinishSync(
      *StartSync(robot, server.address, log,
                 {"--wait-merge", "--merge-timeout", "60", "--policy", "copy", "--retry-for", "5"}),
      log);
  ASSERT_EQ(outcome.exit, 0);
  EXPECT_EQ(outcome.result["pushed_nodes"], 900);
  EXPECT_EQ(outcome.result["pushed_edges"], pushed.edges.size());
  EXPECT_GE(outcome.result["submissions"].template get<int>(), 3) << outcome.result.dump();
  EXPECT_EQ(outcome.result["held_nodes"], 0);
  EXPECT_EQ(outcome.result["merge_state"], "merged");
  EXPECT_EQ(HeadNodeIds(uri), NodeIds(pushed));
  EXPECT_EQ(LocalNodeIds(robot), NodeIds(pushed));  // downloaded: the head, every node merged
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  EXPECT_EQ(outcome.result["revision"], store->versions().HeadRevision());
  const std::vector<Submission> submissions = store->versions().ListSubmissions();
  EXPECT_EQ(submissions.size(), outcome.result["submissions"].template get<std::size_t>());
  for (const Submission& s : submissions) {
    EXPECT_EQ(s.state, SubmissionState::kMerged) << s.error;
    EXPECT_LE(s.bytes, std::int64_t{1} << 20);
  }
  // The edges between parts are at the head too: nothing of the chain is cut.
  std::set<Uuid> head_edges;
  for (const Edge& edge : Repository::Open(uri)->Checkout().edges) head_edges.insert(edge.id);
  for (const Edge& edge : pushed.edges) EXPECT_TRUE(head_edges.contains(edge.id));
}

// A node that cannot fit: one node over the server's limit on its own. It
// stays in the robot's map, unpushed, with a clear status; the sync reports it and goes on to
// push the rest and download; once the server's limit grows the next sync pushes it.
TYPED_TEST(FleetSyncTest, ANodeOverTheSubmissionLimitIsKeptReportedAndPushedWhenTheLimitGrows) {
  const std::string uri = this->backend_.Uri();
  const TestRobot robot = RegisterRobot(uri, "zeta", this->dir_ / "zeta");
  GraphBatch map = RandomRobotMap(robot.id, 30, 17);
  // 30 000 landmarks: about 1.3 MB, over a limit of 1 MiB by itself.
  const GraphBatch big = RandomChainFrom(robot.id, map.nodes.back().id, 1, 18, 30'000);
  const Uuid big_node = big.nodes.at(0).id;
  map.nodes.insert(map.nodes.end(), big.nodes.begin(), big.nodes.end());
  map.edges.insert(map.edges.end(), big.edges.begin(), big.edges.end());
  map.paths.insert(map.paths.end(), big.paths.begin(), big.paths.end());
  WriteLocalMap(robot, map);
  std::set<Uuid> small_nodes = NodeIds(map);
  small_nodes.erase(big_node);
  Fleetmapd server =
      StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--max-submission-mib", "1"});
  ASSERT_FALSE(server.address.empty());
  const auto log = this->dir_ / "agent.log";
  SyncOutcome outcome =
      FinishSync(*StartSync(robot, server.address, log,
                            {"--wait-merge", "--policy", "copy", "--retry-for", "5"}),
                 log);
  ASSERT_EQ(outcome.exit, 0);
  EXPECT_EQ(outcome.result["pushed_nodes"], 30);
  EXPECT_EQ(outcome.result["held_nodes"], 1) << outcome.result.dump();
  EXPECT_EQ(outcome.result["merge_state"], "merged");
  const std::string agent_log = ReadLog(log);
  EXPECT_NE(agent_log.find(big_node.ToString()), std::string::npos) << agent_log;
  EXPECT_NE(agent_log.find("over this server's limit"), std::string::npos) << agent_log;
  EXPECT_EQ(HeadNodeIds(uri), small_nodes);
  EXPECT_GE(outcome.result["revision"].template get<std::int64_t>(), 1);  // downloaded
  EXPECT_EQ(LocalNodeIds(robot), NodeIds(map));  // the big node stays in the robot's map

  const nlohmann::json status = AgentStatus(robot, this->dir_ / "status.log");
  EXPECT_EQ(status["unsynced_nodes"], 1) << status.dump();
  ASSERT_EQ(status["held_nodes"].size(), 1u) << status.dump();
  EXPECT_EQ(status["held_nodes"][0]["id"], big_node.ToString());

  // The limit grows: the next sync pushes the node that did not fit, and nothing is held.
  server.process->Signal(SIGTERM);
  server.process->Wait(milliseconds(10'000));
  Fleetmapd larger = StartFleetmapd(uri, this->dir_ / "fleetmapd-2.log",
                                    {"--max-submission-mib", "4"}, server.address);
  ASSERT_FALSE(larger.address.empty());
  SyncOutcome again =
      FinishSync(*StartSync(robot, larger.address, log,
                            {"--wait-merge", "--policy", "copy", "--retry-for", "5"}),
                 log);
  ASSERT_EQ(again.exit, 0);
  EXPECT_EQ(again.result["pushed_nodes"], 1);
  EXPECT_EQ(again.result["held_nodes"], 0);
  EXPECT_EQ(again.result["merge_state"], "merged");
  EXPECT_EQ(HeadNodeIds(uri), NodeIds(map));
  EXPECT_EQ(LocalNodeIds(robot), NodeIds(map));
  EXPECT_TRUE(AgentStatus(robot, this->dir_ / "status.log")["held_nodes"].empty());
}

}  // namespace
}  // namespace fleetmap::testing
