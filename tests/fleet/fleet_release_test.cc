// Fleet releases across real processes on 127.0.0.1, on both stores:
// a robot on channel "stable" keeps getting the stable revision while the head advances and
// keeps its own pushed nodes; `fleetmap channel set` refused by --require-score changes
// nothing; a move reaches the robot at its next sync, incrementally; `robot list --json`,
// /metrics and the status page in headless Chromium agree on every robot's installed revision;
// a robot whose map.db was damaged after its install is flagged until its next sync makes it
// whole. And a route download (item 3)
// through the same processes.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <chrono>
#include <regex>
#include <set>
#include <thread>

#include "corridor_robot_map.h"
#include "fleet_processes.h"
#include "fleetmap/repository/channel_registry.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap_cli_run.h"
#include "headless_chromium.h"
#include "http_get.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

std::set<Uuid> AgentMapNodes(const TestRobot& robot) {
  std::set<Uuid> ids;
  for (const Node& node :
       GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->ReadMap().nodes) {
    ids.insert(node.id);
  }
  return ids;
}

std::set<Uuid> RevisionNodes(const std::string& uri, RevisionNumber revision) {
  std::set<Uuid> ids;
  for (const Node& node : GraphStore::Open(uri)->versions().NodesAt(revision, false)) {
    ids.insert(node.id);
  }
  return ids;
}

bool HoldsAll(const std::set<Uuid>& all, const std::set<Uuid>& part) {
  return std::includes(all.begin(), all.end(), part.begin(), part.end());
}

// The installed revision of each robot (by name) as `fleetmap robot list --json` gives it.
std::map<std::string, nlohmann::json> RobotList(const ScratchDir& dir, const std::string& uri) {
  const CliRun run = RunFleetmapCli(dir.path(), {"robot", "list", "--json", "--store", uri});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  std::map<std::string, nlohmann::json> robots;
  for (const nlohmann::json& robot : nlohmann::json::parse(run.out)) {
    robots[robot.at("name").get<std::string>()] = robot;
  }
  return robots;
}

// fleetmap_robot_installed_revision{robot="NAME",...} N in /metrics, by name.
std::map<std::string, std::int64_t> MetricsInstalled(const std::string& metrics) {
  std::map<std::string, std::int64_t> installed;
  const std::regex sample(R"re(fleetmap_robot_installed_revision\{robot="([^"]+)"[^}]*\} (\d+))re");
  for (auto it = std::sregex_iterator(metrics.begin(), metrics.end(), sample);
       it != std::sregex_iterator(); ++it) {
    installed[(*it)[1]] = std::stoll((*it)[2]);
  }
  return installed;
}

// The status page's robots table as Chromium built it: the installed revision per robot UUID.
std::map<std::string, std::int64_t> PageInstalled(const std::string& dom) {
  std::map<std::string, std::int64_t> installed;
  const std::regex row(
      R"re(<tr data-robot="([0-9a-f-]+)">.*?<td class="num installed" data-revision="(\d+)")re");
  for (auto it = std::sregex_iterator(dom.begin(), dom.end(), row); it != std::sregex_iterator();
       ++it) {
    installed[(*it)[1]] = std::stoll((*it)[2]);
  }
  return installed;
}

// Changes the landmark bytes of one installed node in the robot's map.db behind the agent's
// back: a damaged map.
void DamageOneInstalledNode(const TestRobot& robot, const Uuid& node) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open((robot.map_dir / "map.db").string().c_str(), &db), SQLITE_OK);
  sqlite3_stmt* statement = nullptr;
  ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE nodes SET landmarks = landmarks || x'00' WHERE id = ?1",
                               -1, &statement, nullptr),
            SQLITE_OK);
  const std::string id = node.ToBytesString();
  sqlite3_bind_blob(statement, 1, id.data(), static_cast<int>(id.size()), SQLITE_TRANSIENT);
  EXPECT_EQ(sqlite3_step(statement), SQLITE_DONE);
  EXPECT_EQ(sqlite3_changes(db), 1);
  sqlite3_finalize(statement);
  sqlite3_close(db);
}

template <typename Backend>
class FleetReleaseTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-fleet-release"};
};
TYPED_TEST_SUITE(FleetReleaseTest, StoreBackends, BackendNames);

TYPED_TEST(FleetReleaseTest, RobotsFollowTheirChannelAndTheDepotSeesWhatEachRuns) {
  const std::string uri = this->backend_.Uri();
  // Revisions 1-3: a day outing, a night outing, and another night outing: the held-out
  // submission of the score checks (night data the day map alone localises badly).
  Uuid held_out;
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    const std::vector<CorridorOuting> outings = {{0, 0.0}, {1, 0.0}, {1, 10.0}};
    for (const CorridorOuting& outing : outings) {
      held_out = Uuid::Generate();
      repository->Push(held_out, Uuid::Generate(), "surveyor", CorridorRobotMap({outing}));
      ASSERT_FALSE(repository->Merge(held_out).already_merged);
    }
    ASSERT_EQ(repository->Head(), 3);
  }
  const auto cli = [&](std::vector<std::string> args) {
    args.push_back("--store");
    args.push_back(uri);
    return RunFleetmapCli(this->dir_.path(), args);
  };
  const CliRun set = cli({"channel", "set", "stable", "2", "--why", "first release"});
  ASSERT_EQ(set.exit_code, 0) << set.err;

  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  const TestRobot beta = RegisterRobot(uri, "beta", this->dir_ / "beta");
  const GraphBatch alpha_map = RandomRobotMap(alpha.id, 20, 11);
  WriteLocalMap(alpha, alpha_map);
  WriteLocalMap(beta, RandomRobotMap(beta.id, 20, 12));
  std::set<Uuid> alpha_own;
  for (const Node& node : alpha_map.nodes) alpha_own.insert(node.id);

  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--http", "127.0.0.1:0"});
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> http_line =
      server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  ASSERT_TRUE(http_line);
  const std::string http = http_line->substr(http_line->rfind(' ') + 1);
  const auto sync = [&](const TestRobot& robot, std::vector<std::string> extra) {
    const auto log = this->dir_ / (robot.name + ".log");
    return FinishSync(*StartSync(robot, server.address, log, extra), log);
  };
  const std::vector<std::string> on_stable = {"--wait-merge", "--channel", "stable"};

  // alpha on stable: its push merges beyond revision 2, it installs revision 2, and it still
  // holds what it built.
  SyncOutcome first = sync(alpha, on_stable);
  ASSERT_EQ(first.exit, 0);
  EXPECT_EQ(first.result["merge_state"], "merged");
  EXPECT_EQ(first.result["revision"], 2);
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), RevisionNodes(uri, 2)));
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), alpha_own));

  // beta on the head advances it; alpha's next sync still gets revision 2, with nothing new.
  SyncOutcome beta_first = sync(beta, {"--wait-merge"});
  ASSERT_EQ(beta_first.exit, 0);
  const std::int64_t head = beta_first.result["revision"].get<std::int64_t>();
  EXPECT_GE(head, 5);
  SyncOutcome again = sync(alpha, on_stable);
  ASSERT_EQ(again.exit, 0);
  EXPECT_EQ(again.result["revision"], 2);
  EXPECT_EQ(again.result["incremental"], true);
  EXPECT_EQ(again.result["downloaded_nodes"], 0);
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), alpha_own));

  // A move to a revision that localises the held-out night worse (the day map alone) is
  // refused and changes nothing.
  const CliRun refused = cli({"channel", "set", "stable", "1", "--require-score",
                              held_out.ToString(), "--why", "roll back"});
  EXPECT_NE(refused.exit_code, 0);
  EXPECT_NE(refused.err.find("stays at revision 2"), std::string::npos) << refused.err;
  const CliRun log_after_refusal = cli({"channel", "log", "stable", "--json"});
  ASSERT_EQ(log_after_refusal.exit_code, 0);
  EXPECT_EQ(nlohmann::json::parse(log_after_refusal.out).size(), 1u) << log_after_refusal.out;
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    EXPECT_EQ(ChannelRegistry(*repository).Resolve("stable"), 2);
  }

  // A move that scores at least as well goes through, is logged with both scores, and
  // reaches alpha at its next sync as changes since revision 2.
  const CliRun moved = cli({"channel", "set", "stable", std::to_string(head), "--require-score",
                            held_out.ToString(), "--why", "night route checked", "--json"});
  ASSERT_EQ(moved.exit_code, 0) << moved.err;
  const nlohmann::json move = nlohmann::json::parse(moved.out);
  EXPECT_EQ(move["from"], 2);
  EXPECT_EQ(move["to"], head);
  EXPECT_LE(move["proposed_score"]["score"].get<double>(),
            move["current_score"]["score"].get<double>());
  const nlohmann::json log = nlohmann::json::parse(cli({"channel", "log", "stable", "--json"}).out);
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[1]["why"], "night route checked");
  EXPECT_EQ(log[1]["from"], 2);

  SyncOutcome moved_sync = sync(alpha, on_stable);
  ASSERT_EQ(moved_sync.exit, 0);
  EXPECT_EQ(moved_sync.result["revision"], head);
  EXPECT_EQ(moved_sync.result["incremental"], true);
  EXPECT_GT(moved_sync.result["downloaded_nodes"].get<int>(), 0);
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), RevisionNodes(uri, head)));
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), alpha_own));

  // robot list, /metrics and the page agree: both robots installed the head, none differs.
  std::map<std::string, nlohmann::json> listed = RobotList(this->dir_, uri);
  EXPECT_EQ(listed["alpha"]["installed_revision"], head);
  EXPECT_EQ(listed["alpha"]["channel"], "stable");
  EXPECT_EQ(listed["alpha"]["behind"], 0);
  EXPECT_EQ(listed["beta"]["installed_revision"], head);
  EXPECT_EQ(listed["beta"]["channel"], "head");
  EXPECT_EQ(listed["alpha"]["map_differs"], false);
  EXPECT_EQ(listed["beta"]["map_differs"], false);
  EXPECT_NE(listed["alpha"]["sent_digest"], "0");
  EXPECT_EQ(listed["alpha"]["sent_digest"], listed["alpha"]["installed_digest"]);
  // The status refreshes from the store every few seconds: wait (bounded) for it.
  std::map<std::string, std::int64_t> metrics;
  for (int i = 0; i < 100; ++i) {
    metrics = MetricsInstalled(HttpGet(http, "/metrics"));
    if (metrics["alpha"] == head && metrics["beta"] == head) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_EQ(metrics["alpha"], head);
  EXPECT_EQ(metrics["beta"], head);
  const std::map<std::string, std::int64_t> page =
      PageInstalled(RunChromium(this->dir_, "--dump-dom", "http://" + http + "/"));
  EXPECT_EQ(page.size(), 2u);
  EXPECT_EQ(page.at(alpha.id.ToString()), head);
  EXPECT_EQ(page.at(beta.id.ToString()), head);

  // alpha's map damaged after its install: its next hello says so (here a sync that fails
  // after its hello, asking for a channel that is not set), and it is flagged; beta is not.
  DamageOneInstalledNode(alpha, *RevisionNodes(uri, 1).begin());
  {
    const auto failing_log = this->dir_ / "alpha-unknown-channel.log";
    const std::unique_ptr<ChildProcess> failing =
        StartSync(alpha, server.address, failing_log, {"--channel", "no-such-channel"});
    failing->ReadRest(std::chrono::milliseconds(60'000));
    EXPECT_NE(failing->Wait(std::chrono::milliseconds(10'000)).value_or(0), 0);
  }
  listed = RobotList(this->dir_, uri);
  EXPECT_EQ(listed["alpha"]["map_differs"], true);
  EXPECT_EQ(listed["beta"]["map_differs"], false);
  std::string metrics_text;
  for (int i = 0; i < 100; ++i) {
    metrics_text = HttpGet(http, "/metrics");
    if (metrics_text.find("fleetmap_robot_map_differs{robot=\"alpha\",robot_id=\"" +
                          alpha.id.ToString() + "\"} 1") != std::string::npos) {
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_NE(metrics_text.find("fleetmap_robot_map_differs{robot=\"alpha\",robot_id=\"" +
                              alpha.id.ToString() + "\"} 1"),
            std::string::npos)
      << metrics_text;
  const std::string dom = RunChromium(this->dir_, "--dump-dom", "http://" + http + "/");
  EXPECT_NE(dom.find("MAP DIFFERS"), std::string::npos);

  // Its next sync takes the map whole again (a full download, its own nodes kept): no longer
  // flagged.
  SyncOutcome repaired = sync(alpha, on_stable);
  ASSERT_EQ(repaired.exit, 0);
  EXPECT_EQ(repaired.result["incremental"], false);
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), RevisionNodes(uri, head)));
  EXPECT_TRUE(HoldsAll(AgentMapNodes(alpha), alpha_own));
  EXPECT_EQ(RobotList(this->dir_, uri)["alpha"]["map_differs"], false);
}

// A mission's route through real processes: positions in the frame of the
// corridor's first node, its first 40 m. The robot gets the map within 5 m of them, not the
// whole corridor, and the server says how much of the route has a node within 5 m.
TYPED_TEST(FleetReleaseTest, ARouteDownloadHoldsTheMapNearTheRouteOnly) {
  const std::string uri = this->backend_.Uri();
  Uuid first_node;
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    for (const CorridorOuting& outing : std::vector<CorridorOuting>{{0, 0.0}, {1, 0.0}}) {
      const Uuid id = Uuid::Generate();
      const GraphBatch map = CorridorRobotMap({outing});
      if (first_node.IsNil()) {
        first_node =
            std::min_element(map.nodes.begin(), map.nodes.end(), [](const Node& a, const Node& b) {
              return a.stamp_ns < b.stamp_ns;
            })->id;
      }
      repository->Push(id, Uuid::Generate(), "surveyor", map);
      ASSERT_FALSE(repository->Merge(id).already_merged);
    }
  }
  const std::size_t map_nodes = RevisionNodes(uri, 2).size();
  const TestRobot gamma = RegisterRobot(uri, "gamma", this->dir_ / "gamma");
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  const std::vector<std::string> route = {
      "--route", "anchor " + first_node.ToString() + "; 0 0 0; 0 0 40", "--route-radius", "5"};
  const auto log = this->dir_ / "gamma.log";
  SyncOutcome first = FinishSync(*StartSync(gamma, server.address, log, route), log);
  ASSERT_EQ(first.exit, 0);
  const double length = first.result["route_length_m"].get<double>();
  EXPECT_NEAR(length, 40.0, 1e-6);
  EXPECT_GE(first.result["route_covered_m"].get<double>(), 0.99 * length);
  const std::size_t nodes = first.result["nodes"].get<std::size_t>();
  EXPECT_GT(nodes, 0u);
  EXPECT_LT(nodes, map_nodes / 2) << "the corridor is 120 m; the route 40 m of it";
  EXPECT_EQ(AgentMapNodes(gamma).size(), nodes);
  // The same route again: incremental, nothing new.
  SyncOutcome again = FinishSync(*StartSync(gamma, server.address, log, route), log);
  ASSERT_EQ(again.exit, 0);
  EXPECT_EQ(again.result["incremental"], true);
  EXPECT_EQ(again.result["downloaded_nodes"], 0);
  EXPECT_EQ(again.result["nodes"], nodes);
}

}  // namespace
}  // namespace fleetmap::testing
