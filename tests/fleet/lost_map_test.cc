// A robot that loses its map.db, its sync.json or both between syncs, through real fleetmapd,
// fleetmap-agent and fleetmap processes on 127.0.0.1, on both stores: it follows a channel
// behind the head and has pushed work the channel's revision does not hold. After one sync it
// holds exactly what it held before (its own unmerged nodes included), nothing on the server
// was doubled or left half-received, and the depot's robot list says its map is whole; while
// its map is lost and not yet replaced, the depot says it differs.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <set>

#include "corridor_robot_map.h"
#include "fleet_processes.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap_cli_run.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

// Every element of the robot's map.db, by id.
struct HeldIds {
  std::set<Uuid> nodes, edges, paths;
  friend bool operator==(const HeldIds&, const HeldIds&) = default;
};

HeldIds AgentMapIds(const TestRobot& robot) {
  HeldIds ids;
  const GraphBatch map =
      GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->ReadMap();
  for (const Node& node : map.nodes) ids.nodes.insert(node.id);
  for (const Edge& edge : map.edges) ids.edges.insert(edge.id);
  for (const Path& path : map.paths) ids.paths.insert(path.id);
  return ids;
}

std::string Describe(const HeldIds& held, const HeldIds& expected) {
  return "holds " + std::to_string(held.nodes.size()) + " nodes, " +
         std::to_string(held.edges.size()) + " edges, " + std::to_string(held.paths.size()) +
         " paths; held before " + std::to_string(expected.nodes.size()) + ", " +
         std::to_string(expected.edges.size()) + ", " + std::to_string(expected.paths.size()) +
         "\n";
}

nlohmann::json RobotEntry(const ScratchDir& dir, const std::string& uri, const std::string& name) {
  const CliRun run = RunFleetmapCli(dir.path(), {"robot", "list", "--json", "--store", uri});
  EXPECT_EQ(run.exit_code, 0) << run.err;
  for (const nlohmann::json& robot : nlohmann::json::parse(run.out)) {
    if (robot.at("name") == name) return robot;
  }
  ADD_FAILURE() << "no robot " << name << " in " << run.out;
  return nullptr;
}

template <typename Backend>
class LostMapTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-lost-map"};
};
TYPED_TEST_SUITE(LostMapTest, StoreBackends, BackendNames);

TYPED_TEST(LostMapTest, ARobotThatLosesItsMapOrItsStateGetsBackExactlyWhatItHeld) {
  const std::string uri = this->backend_.Uri();
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    for (const CorridorOuting& outing : std::vector<CorridorOuting>{{0, 0.0}, {1, 0.0}}) {
      const Uuid id = Uuid::Generate();
      repository->Push(id, Uuid::Generate(), "surveyor", CorridorRobotMap({outing}));
      ASSERT_FALSE(repository->Merge(id).already_merged);
    }
  }
  const auto cli = [&](std::vector<std::string> args) {
    args.push_back("--store");
    args.push_back(uri);
    return RunFleetmapCli(this->dir_.path(), args);
  };
  ASSERT_EQ(cli({"channel", "set", "stable", "1", "--why", "release"}).exit_code, 0);

  const TestRobot alpha = RegisterRobot(uri, "alpha", this->dir_ / "alpha");
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  int syncs = 0;
  std::filesystem::path last_log;
  const auto sync = [&](std::vector<std::string> extra) {
    const auto log = this->dir_ / ("alpha-" + std::to_string(++syncs) + ".log");
    last_log = log;
    extra.insert(extra.end(), {"--channel", "stable"});
    return FinishSync(*StartSync(alpha, server.address, log, extra), log);
  };
  // Two outings of alpha's, each pushed: the first merged (beyond the channel's revision), the
  // second still queued when it downloads, so both are its unmerged work on "stable".
  WriteLocalMap(alpha, RandomRobotMap(alpha.id, 15, 31));
  ASSERT_EQ(sync({"--wait-merge"}).exit, 0);
  WriteLocalMap(alpha, RandomRobotMap(alpha.id, 10, 32));
  const SyncOutcome second = sync({});
  ASSERT_EQ(second.exit, 0);
  ASSERT_EQ(second.result["revision"], 1);
  ASSERT_EQ(sync({"--wait-merge"}).exit, 0);
  const HeldIds before = AgentMapIds(alpha);
  ASSERT_GT(before.nodes.size(), 25u);

  struct ServerState {
    std::size_t receiving = 0, failed = 0, head_nodes = 0;
  };
  const auto server_state = [&] {
    const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
    ServerState state;
    for (const Submission& s : store->versions().ListSubmissions()) {
      if (s.state == SubmissionState::kReceiving) ++state.receiving;
      if (s.state == SubmissionState::kFailed) ++state.failed;
    }
    const RevisionNumber head = store->versions().HeadRevision();
    state.head_nodes = store->versions().NodesAt(head, false).size();
    return state;
  };
  const std::size_t head_nodes = server_state().head_nodes;

  const std::filesystem::path map_db = alpha.map_dir / "map.db";
  const std::filesystem::path state = alpha.map_dir / "sync.json";
  struct Loss {
    const char* what;
    bool map;
    bool state;
  };
  for (const Loss loss : {Loss{"map.db", true, false}, Loss{"sync.json", false, true},
                          Loss{"map.db and sync.json", true, true}}) {
    SCOPED_TRACE(loss.what);
    if (loss.map) {
      for (const char* suffix : {"", "-wal", "-shm"}) {
        std::filesystem::remove(map_db.string() + suffix);
      }
    }
    if (loss.state) std::filesystem::remove(state);
    const SyncOutcome after = sync({"--wait-merge"});
    ASSERT_EQ(after.exit, 0);
    EXPECT_EQ(after.result["revision"], 1);
    EXPECT_EQ(after.result["incremental"], false);
    EXPECT_EQ(AgentMapIds(alpha), before)
        << Describe(AgentMapIds(alpha), before) << ReadLog(last_log);
    // The next sync is an ordinary one: incremental, nothing new, nothing lost.
    const SyncOutcome next = sync({"--wait-merge"});
    ASSERT_EQ(next.exit, 0);
    EXPECT_EQ(next.result["incremental"], true);
    EXPECT_EQ(next.result["downloaded_nodes"], 0);
    EXPECT_EQ(AgentMapIds(alpha), before);
    const nlohmann::json listed = RobotEntry(this->dir_, uri, "alpha");
    EXPECT_EQ(listed["installed_revision"], 1);
    EXPECT_EQ(listed["map_differs"], false);
    const ServerState now = server_state();
    EXPECT_EQ(now.receiving, 0u) << "a half-made submission was left on the server";
    EXPECT_EQ(now.failed, 0u);
    // What alpha pushed again was recognised by UUID: the head gained nothing.
    EXPECT_EQ(now.head_nodes, head_nodes);
  }

  // Emptied in place (its tables there, its rows gone), then a sync that fails after the hello
  // (an unknown channel): the depot says the map differs until a sync makes it whole again.
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(map_db.string().c_str(), &db), SQLITE_OK);
    EXPECT_EQ(sqlite3_exec(db, "DELETE FROM edges; DELETE FROM nodes; DELETE FROM paths;", nullptr,
                           nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
    ASSERT_TRUE(AgentMapIds(alpha).nodes.empty());
  }
  const auto log = this->dir_ / "alpha-unknown-channel.log";
  const std::unique_ptr<ChildProcess> failing =
      StartSync(alpha, server.address, log, {"--channel", "no-such-channel"});
  failing->ReadRest(std::chrono::milliseconds(60'000));
  EXPECT_NE(failing->Wait(std::chrono::milliseconds(10'000)).value_or(0), 0);
  EXPECT_EQ(RobotEntry(this->dir_, uri, "alpha")["map_differs"], true);
  ASSERT_EQ(sync({"--wait-merge"}).exit, 0);
  EXPECT_EQ(AgentMapIds(alpha), before);
  EXPECT_EQ(RobotEntry(this->dir_, uri, "alpha")["map_differs"], false);
}

}  // namespace
}  // namespace fleetmap::testing
