// Retirement (retirement.h) across real processes on 127.0.0.1, on both stores. Three robots
// drive the corridor and sync through fleetmapd: a day survey on day 0, a foray on day 1 that
// turns to night half-way and back to day, and the day survey again on day 20. The night
// experiences sit beside the day ones (MERGE links them), and by day 20 nobody has localised
// against them for 19 days while the day ones were used that morning:
// (a) `fleetmap retire --dry-run --json` lists exactly what `fleetmap retire` then hides, and
//     `fleetmap revert` restores each node whole (same ids and landmark bytes, same edges);
// (b) a robot on a channel pinned before the retirement keeps every node it held, while a robot
//     on the head loses the retired ones at its next sync;
// (c) a queued submission that builds on a night node keeps it, and once merged every node of
//     it is in the map or stands in there;
// (d) fleetmapd --retire-after with a --retire-at already passed retires at start, once, says
//     so in its log, `fleetmap log` and the status page, and says why when nothing goes.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <ctime>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "dated_corridor_foray.h"
#include "fleet_processes.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "http_get.h"
#include "random_robot_map.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace retirement_fleet {
namespace {

// Unused for 5 days by day 20: the night experiences of day 1 go, the day ones used that day
// stay. 100 days: nothing is old enough.
constexpr const char* kRetireAfterDays = "5";
constexpr const char* kLongRetireAfterDays = "100";

std::string IsoUtc(std::int64_t ns) {
  const std::time_t seconds = static_cast<std::time_t>(ns / 1'000'000'000);
  std::tm utc{};
  gmtime_r(&seconds, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

// The UTC HH:MM of a minute `lead` from now (negative: past).
std::string TimeOfDayFromNow(std::chrono::seconds lead) {
  const std::time_t t = std::chrono::system_clock::to_time_t(
      std::chrono::floor<std::chrono::minutes>(std::chrono::system_clock::now() + lead));
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[8];
  std::snprintf(text, sizeof text, "%02d:%02d", utc.tm_hour, utc.tm_min);
  return text;
}

std::set<Uuid> RevisionNodeIds(const std::string& uri, RevisionNumber r) {
  std::set<Uuid> ids;
  for (const Node& node : GraphStore::Open(uri)->versions().NodesAt(r, false)) ids.insert(node.id);
  return ids;
}

std::set<Uuid> LocalNodeIds(const TestRobot& robot) {
  return NodeIds(GraphStore::Open("sqlite:" + (robot.map_dir / "map.db").string())->ReadMap());
}

RevisionNumber Head(const std::string& uri) {
  return GraphStore::Open(uri)->versions().HeadRevision();
}

// The nodes a plan (RetirementPlanJson) retires.
std::set<Uuid> PlanRetires(const nlohmann::json& plan) {
  std::set<Uuid> ids;
  for (const nlohmann::json& node : plan.at("retired")) {
    ids.insert(Uuid::Parse(node.at("node").get<std::string>()));
  }
  return ids;
}

std::set<Uuid> JsonIds(const nlohmann::json& list) {
  std::set<Uuid> ids;
  for (const nlohmann::json& id : list) ids.insert(Uuid::Parse(id.get<std::string>()));
  return ids;
}

// A node as the map stores it, landmarks included, for byte-for-byte comparison.
std::string NodeRecord(const Node& node) {
  return node.id.ToString() + " " + std::to_string(node.stamp_ns) + " " + node.robot.ToString() +
         " " + node.outing.ToString() + " " + node.landmarks_blob;
}

std::string EdgeRecord(const Edge& edge) {
  std::string record = edge.id.ToString() + " " + edge.from.ToString() + " " + edge.to.ToString() +
                       " " + std::to_string(static_cast<int>(edge.kind)) + " " +
                       edge.path.ToString();
  for (int i = 0; i < 3; ++i) record += " " + std::to_string(edge.from_T_to.translation()[i]);
  return record;
}

// Every node and edge of a store `fleetmap checkout` wrote, by id.
struct CheckedOut {
  std::map<Uuid, std::string> nodes, edges;
};

CheckedOut ReadCheckout(const std::filesystem::path& file) {
  const GraphBatch map = GraphStore::Open("sqlite:" + file.string())->ReadMap();
  CheckedOut out;
  for (const Node& node : map.nodes) out.nodes[node.id] = NodeRecord(node);
  for (const Edge& edge : map.edges) out.edges[edge.id] = EdgeRecord(edge);
  return out;
}

template <typename Backend>
class RetirementFleetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
    uri_ = backend_.Uri();
  }

  CliRun Cli(std::vector<std::string> args) {
    args.push_back("--store");
    args.push_back(uri_);
    CliRun run = RunFleetmapCli(dir_.path(), args);
    EXPECT_EQ(run.exit_code, 0) << DescribeCliRun(args, run);
    return run;
  }
  nlohmann::json CliJson(std::vector<std::string> args) {
    args.push_back("--json");
    const CliRun run = Cli(args);
    const nlohmann::json json = nlohmann::json::parse(run.out, nullptr, false);
    EXPECT_FALSE(json.is_discarded()) << run.out << run.err;
    return json;
  }

  SyncOutcome Sync(const TestRobot& robot, const Fleetmapd& server,
                   std::vector<std::string> extra = {"--wait-merge"}) {
    extra.push_back("--policy");
    extra.push_back("copy");
    const std::filesystem::path log = dir_ / (robot.name + ".log");
    return FinishSync(*StartSync(robot, server.address, log, extra), log);
  }

  // The three robots drive the corridor (see the file comment) and sync in turn through
  // `server`, each waiting for its merge: revisions 1, 2 and 3.
  void DriveTheCorridor(const Fleetmapd& server) {
    surveyor_ = RegisterRobot(uri_, "surveyor", dir_ / "surveyor");
    night_shift_ = RegisterRobot(uri_, "night-shift", dir_ / "night-shift");
    day_shift_ = RegisterRobot(uri_, "day-shift", dir_ / "day-shift");
    WriteLocalMap(surveyor_, DatedCorridorForay(surveyor_.id, {{0.0, 0}}, 0));
    WriteLocalMap(night_shift_,
                  DatedCorridorForay(night_shift_.id, {{0.0, 0}, {40.0, 1}, {80.0, 0}}, 1));
    WriteLocalMap(day_shift_, DatedCorridorForay(day_shift_.id, {{0.0, 0}}, 20));
    RevisionNumber revision = 0;
    for (const TestRobot* robot : {&surveyor_, &night_shift_, &day_shift_}) {
      const SyncOutcome outcome = Sync(*robot, server);
      ASSERT_EQ(outcome.exit, 0);
      ASSERT_EQ(outcome.result["merge_state"], "merged") << outcome.result.dump();
      EXPECT_EQ(outcome.result["revision"], ++revision) << outcome.result.dump();
    }
    ASSERT_EQ(Head(uri_), 3);
    // The night stretch was added, beside the day survey.
    ASSERT_GT(RevisionNodeIds(uri_, 2).size(), RevisionNodeIds(uri_, 1).size());
  }

  void StopServer(Fleetmapd& server) {
    server.process->Signal(SIGTERM);
    ASSERT_EQ(server.process->Wait(std::chrono::milliseconds(15'000)), 0) << server.Log();
  }

  Backend backend_;
  ScratchDir dir_{"fleetmap-retirement-fleet"};
  std::string uri_;
  TestRobot surveyor_, night_shift_, day_shift_;
};
TYPED_TEST_SUITE(RetirementFleetTest, StoreBackends, BackendNames);

// (a) The dry run lists exactly what the retirement hides, the log tells both, and the revert
// brings back every node whole with the same edges.
TYPED_TEST(RetirementFleetTest, DryRunListsWhatRetireHidesAndRevertRestoresItWhole) {
  Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  ASSERT_NO_FATAL_FAILURE(this->DriveTheCorridor(server));
  const std::int64_t now_ns = At(12, 0, 20);
  const std::vector<std::string> retire = {"retire", "--retire-after", kRetireAfterDays, "--now",
                                           IsoUtc(now_ns)};

  // The dry run: what would go and why, and nothing written.
  std::vector<std::string> dry_args = retire;
  dry_args.push_back("--dry-run");
  const nlohmann::json dry = this->CliJson(dry_args);
  ASSERT_EQ(dry["dry_run"], true) << dry.dump();
  const nlohmann::json& plan = dry["plan"];
  const std::set<Uuid> planned = PlanRetires(plan);
  EXPECT_EQ(plan["head"], 3);
  EXPECT_EQ(plan["now_ns"], now_ns);
  EXPECT_EQ(plan["cutoff_ns"], now_ns - 5 * kDay);
  ASSERT_FALSE(planned.empty()) << plan.dump(2);
  EXPECT_GE(plan["candidates"].get<std::size_t>(), planned.size());
  const std::set<Uuid> at_3 = RevisionNodeIds(this->uri_, 3);
  const std::set<Uuid> night = [&] {
    std::set<Uuid> added;
    for (const Uuid& id : RevisionNodeIds(this->uri_, 2)) {
      if (!RevisionNodeIds(this->uri_, 1).contains(id)) added.insert(id);
    }
    return added;
  }();
  for (const nlohmann::json& node : plan["retired"]) {
    const Uuid id = Uuid::Parse(node["node"].get<std::string>());
    // Only night experiences, unused since before the cutoff, each held by one that stays.
    EXPECT_TRUE(night.contains(id)) << node.dump();
    EXPECT_LT(node["last_used_ns"].get<std::int64_t>(), now_ns - 5 * kDay) << node.dump();
    const Uuid held_by = Uuid::Parse(node["held_by"].get<std::string>());
    EXPECT_TRUE(at_3.contains(held_by) && !planned.contains(held_by)) << node.dump();
    EXPECT_LE(node["held_by_m"].get<double>(), 8.0) << node.dump();
  }
  EXPECT_EQ(Head(this->uri_), 3) << "a dry run writes nothing";
  const CliRun dry_text = this->Cli(dry_args);
  EXPECT_TRUE(Contains(dry_text.out, std::to_string(planned.size()) + " nodes would be retired"))
      << dry_text.out;
  EXPECT_TRUE(Contains(dry_text.out, planned.begin()->ToString())) << dry_text.out;
  EXPECT_TRUE(Contains(dry_text.out, "PLACE HELD BY")) << dry_text.out;

  // The retirement hides exactly that, and says how to undo it.
  std::vector<std::string> real_args = retire;
  real_args.insert(real_args.end(), {"--author", "night-audit"});
  const nlohmann::json real = this->CliJson(real_args);
  ASSERT_EQ(real["revision"], 4) << real.dump();
  EXPECT_EQ(PlanRetires(real["plan"]), planned);
  EXPECT_EQ(real["hidden"]["nodes"], planned.size());
  EXPECT_GT(real["hidden"]["edges"].get<int>(), 0);
  const nlohmann::json diff = this->CliJson({"diff", "3", "4"});
  EXPECT_EQ(JsonIds(diff["removed"]["nodes"]), planned);
  EXPECT_TRUE(diff["added"]["nodes"].empty()) << diff.dump();
  EXPECT_EQ(RevisionNodeIds(this->uri_, 4).size(), at_3.size() - planned.size());

  const CliRun log = this->Cli({"log"});
  EXPECT_TRUE(Contains(log.out, "retirement of " + std::to_string(planned.size()) +
                                    " nodes unused since " + IsoUtc(now_ns - 5 * kDay)))
      << log.out;

  // The revert restores it, and reads as a restore.
  const CliRun revert = this->Cli({"revert", "4"});
  EXPECT_TRUE(Contains(revert.out, "restored " + std::to_string(planned.size()) + " nodes"))
      << revert.out;
  ASSERT_EQ(Head(this->uri_), 5);
  const nlohmann::json history = this->CliJson({"log"});
  ASSERT_EQ(history.size(), 5u);
  EXPECT_EQ(history[3]["kind"], "retire");
  EXPECT_EQ(history[3]["author"], "night-audit");
  EXPECT_EQ(PlanRetires(history[3]["report"]), planned);
  EXPECT_EQ(history[4]["kind"], "revert");
  EXPECT_EQ(history[4]["restores"], "retire");
  EXPECT_EQ(history[4]["added"]["nodes"], planned.size());
  EXPECT_EQ(history[4]["added"]["edges"], real["hidden"]["edges"]);
  EXPECT_TRUE(Contains(this->Cli({"log"}).out,
                       "revision 4: restored " + std::to_string(planned.size()) + " nodes"));

  // Whole: the head after the revert is the map before the retirement, node for node (ids,
  // stamps, robots, outings, landmark bytes) and edge for edge.
  const std::filesystem::path before = this->dir_ / "before.db";
  const std::filesystem::path after = this->dir_ / "after.db";
  this->Cli({"checkout", "--revision", "3", "--out", "sqlite:" + before.string()});
  this->Cli({"checkout", "--out", "sqlite:" + after.string()});
  const CheckedOut was = ReadCheckout(before);
  const CheckedOut is = ReadCheckout(after);
  EXPECT_EQ(is.nodes.size(), at_3.size());
  EXPECT_TRUE(was.nodes == is.nodes) << "a node came back changed or not at all";
  EXPECT_TRUE(was.edges == is.edges)
      << was.edges.size() << " edges before, " << is.edges.size() << " after the revert";
  for (const Uuid& id : planned) {
    EXPECT_TRUE(is.nodes.contains(id) && !is.nodes.at(id).empty()) << id.ToString();
  }
  const nlohmann::json none = this->CliJson({"diff", "3", "5"});
  EXPECT_TRUE(none["added"]["nodes"].empty() && none["removed"]["nodes"].empty() &&
              none["added"]["edges"].empty() && none["removed"]["edges"].empty())
      << none.dump();
  this->StopServer(server);
}

// (b) A channel pinned before the retirement keeps its experiences; the head loses them.
TYPED_TEST(RetirementFleetTest, AChannelBehindTheHeadKeepsWhatItHeld) {
  Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "fleetmapd.log");
  ASSERT_FALSE(server.address.empty());
  ASSERT_NO_FATAL_FAILURE(this->DriveTheCorridor(server));
  this->Cli({"channel", "set", "stable", "3", "--why", "before the retirement"});
  // The surveyor (it built none of the night nodes) follows stable, the day shift the head.
  const std::vector<std::string> on_stable = {"--channel", "stable"};
  ASSERT_EQ(this->Sync(this->surveyor_, server, on_stable).result["revision"], 3);
  ASSERT_EQ(this->Sync(this->day_shift_, server, {}).result["revision"], 3);
  const std::set<Uuid> stable_held = LocalNodeIds(this->surveyor_);
  const std::set<Uuid> head_held = LocalNodeIds(this->day_shift_);
  const std::set<Uuid> at_3 = RevisionNodeIds(this->uri_, 3);
  ASSERT_TRUE(std::includes(stable_held.begin(), stable_held.end(), at_3.begin(), at_3.end()));
  ASSERT_TRUE(std::includes(head_held.begin(), head_held.end(), at_3.begin(), at_3.end()));

  // By the map's own clock (day 20, the newest stamp it has seen).
  const nlohmann::json retired = this->CliJson({"retire", "--retire-after", kRetireAfterDays});
  ASSERT_EQ(retired["revision"], 4) << retired.dump();
  const std::set<Uuid> gone = PlanRetires(retired["plan"]);
  ASSERT_FALSE(gone.empty());

  const SyncOutcome stable = this->Sync(this->surveyor_, server, on_stable);
  EXPECT_EQ(stable.result["revision"], 3) << stable.result.dump();
  EXPECT_EQ(stable.result["removed_nodes"], 0) << stable.result.dump();
  EXPECT_EQ(LocalNodeIds(this->surveyor_), stable_held) << "the pinned robot lost experiences";

  const SyncOutcome head = this->Sync(this->day_shift_, server, {});
  EXPECT_EQ(head.result["revision"], 4) << head.result.dump();
  EXPECT_EQ(head.result["removed_nodes"], gone.size()) << head.result.dump();
  std::set<Uuid> expected;
  std::set_difference(head_held.begin(), head_held.end(), gone.begin(), gone.end(),
                      std::inserter(expected, expected.end()));
  EXPECT_EQ(LocalNodeIds(this->day_shift_), expected);
  this->StopServer(server);
}

// (c) A robot's queued push that builds on a node the retirement would take keeps it; merged
// after the retirement, every node of it is in the map or stands in there.
TYPED_TEST(RetirementFleetTest, AQueuedSubmissionKeepsTheNodeItBuildsOn) {
  {
    Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "fleetmapd.log");
    ASSERT_FALSE(server.address.empty());
    ASSERT_NO_FATAL_FAILURE(this->DriveTheCorridor(server));
    // The day shift holds the whole of revision 3, night nodes included.
    ASSERT_EQ(this->Sync(this->day_shift_, server, {}).result["revision"], 3);
    this->StopServer(server);
  }
  const std::vector<std::string> retire = {"retire", "--retire-after", kRetireAfterDays};
  std::vector<std::string> dry_run = retire;
  dry_run.push_back("--dry-run");
  const nlohmann::json before = this->CliJson(dry_run)["plan"];
  const std::set<Uuid> would_go = PlanRetires(before);
  ASSERT_FALSE(would_go.empty());
  EXPECT_EQ(before["kept_for_submissions"], 0);
  const Uuid anchor = *would_go.begin();
  ASSERT_TRUE(LocalNodeIds(this->day_shift_).contains(anchor));

  // The day shift builds on from that node and pushes; the merge is held for 8 s.
  const GraphBatch chain = RandomChainFrom(this->day_shift_.id, anchor, 6, 77);
  WriteLocalMap(this->day_shift_, chain);
  Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "fleetmapd-held.log",
                                    {"--debug-merge-pause-ms", "8000"});
  ASSERT_FALSE(server.address.empty());
  const SyncOutcome pushed = this->Sync(this->day_shift_, server, {});
  ASSERT_EQ(pushed.exit, 0);
  const Uuid submission = Uuid::Parse(pushed.result["submission"].get<std::string>());
  {
    const std::optional<Submission> queued =
        GraphStore::Open(this->uri_)->versions().FindSubmission(submission);
    ASSERT_TRUE(queued);
    ASSERT_EQ(queued->state, SubmissionState::kQueued) << "merged before the retirement planned";
  }

  const nlohmann::json held = this->CliJson(dry_run)["plan"];
  EXPECT_GE(held["kept_for_submissions"].get<int>(), 1) << held.dump(2);
  EXPECT_FALSE(PlanRetires(held).contains(anchor));
  const nlohmann::json retired = this->CliJson(retire);
  ASSERT_EQ(retired["revision"], 4) << retired.dump();
  EXPECT_FALSE(PlanRetires(retired["plan"]).contains(anchor));
  EXPECT_TRUE(RevisionNodeIds(this->uri_, 4).contains(anchor));

  // The merge goes through after the retirement (a conflict with it is retried on its head).
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  std::optional<Submission> merged;
  while (std::chrono::steady_clock::now() < deadline) {
    merged = GraphStore::Open(this->uri_)->versions().FindSubmission(submission);
    if (merged && merged->state != SubmissionState::kQueued) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  ASSERT_TRUE(merged && merged->state == SubmissionState::kMerged) << server.Log();
  const RevisionNumber head = Head(this->uri_);
  EXPECT_GT(merged->revision, 4);
  std::unique_ptr<GraphStore> store = GraphStore::Open(this->uri_);
  std::set<Uuid> at_head;
  for (const Node& node : store->versions().NodesAt(head, false)) at_head.insert(node.id);
  EXPECT_TRUE(at_head.contains(anchor));
  // Every node the day shift ever pushed (its survey, omitted where the map localised it, and
  // the chain) is in the map or stands in there.
  std::size_t pushed_nodes = 0;
  const std::unique_ptr<Repository> repository = Repository::Open(this->uri_);
  for (const Submission& of_robot : repository->Submissions()) {
    if (of_robot.robot != this->day_shift_.id) continue;
    for (const Node& node : repository->ReadSubmission(of_robot.id).nodes) {
      ++pushed_nodes;
      const std::optional<NodeStandIn> stand_in = store->versions().FindStandIn(node.id);
      EXPECT_TRUE(at_head.contains(node.id) || (stand_in && at_head.contains(stand_in->stand_in)))
          << node.id.ToString() << " is neither in the map nor stands in there";
    }
  }
  EXPECT_GT(pushed_nodes, chain.nodes.size());
  bool joined = false;
  for (const Edge& edge : store->versions().EdgesAt(head)) {
    joined = joined || (edge.from == anchor && edge.to == chain.nodes.front().id);
  }
  EXPECT_TRUE(joined) << "the edge the robot built from the kept node is not in the map";
  this->StopServer(server);
}

// (d) fleetmapd retires on schedule: a --retire-at already passed today runs at start; nothing
// old enough says why; once retired since its time it waits for the next day.
TYPED_TEST(RetirementFleetTest, FleetmapdRetiresOnScheduleOnceAndSaysSo) {
  {
    Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "fleetmapd.log");
    ASSERT_FALSE(server.address.empty());
    ASSERT_NO_FATAL_FAILURE(this->DriveTheCorridor(server));
    this->StopServer(server);
  }
  // Retirement needs a time: its own, or the dream's to follow.
  const ProgramRun refused = RunProgram(this->dir_.path(),
                                        {FLEETMAPD_PATH, "--store", this->uri_, "--listen",
                                         "127.0.0.1:0", "--retire-after", kRetireAfterDays},
                                        {}, std::chrono::seconds(30));
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_TRUE(Contains(refused.err, "--retire-after needs --retire-at")) << refused.err;
  const std::string at = TimeOfDayFromNow(-std::chrono::seconds(150));
  // Nothing unused for 100 days: it says why each candidate stayed, and writes nothing.
  {
    Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "long.log",
                                      {"--retire-after", kLongRetireAfterDays, "--retire-at", at});
    ASSERT_FALSE(server.address.empty());
    ASSERT_TRUE(server.LogContains("retire: nothing to retire (0 candidates kept",
                                   std::chrono::milliseconds(30'000)))
        << server.Log();
    EXPECT_TRUE(Contains(server.Log(), "running it now")) << server.Log();
    this->StopServer(server);
  }
  EXPECT_EQ(Head(this->uri_), 3);

  const std::vector<std::string> args = {"--retire-after", kRetireAfterDays, "--retire-at", at,
                                         "--http",         "127.0.0.1:0"};
  Fleetmapd server = StartFleetmapd(this->uri_, this->dir_ / "retire.log", args);
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> http_line =
      server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  ASSERT_TRUE(http_line);
  const std::string http = http_line->substr(http_line->rfind(' ') + 1);
  ASSERT_TRUE(server.LogContains("nodes retired as revision 4", std::chrono::milliseconds(30'000)))
      << server.Log();
  const nlohmann::json history = this->CliJson({"log"});
  ASSERT_EQ(history.size(), 4u);
  const nlohmann::json& retirement = history[3];
  EXPECT_EQ(retirement["kind"], "retire");
  EXPECT_EQ(retirement["author"], "fleetmapd");
  const std::size_t retired = PlanRetires(retirement["report"]).size();
  EXPECT_GT(retired, 0u);
  EXPECT_EQ(retirement["hidden"]["nodes"], retired);
  EXPECT_TRUE(
      Contains(server.Log(), "retire: " + std::to_string(retired) + " nodes retired as revision 4"))
      << server.Log();

  // The status page's history: the retirement with what it hid, then its revert as a restore.
  const auto page_shows = [&](const std::string& text) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (std::chrono::steady_clock::now() < deadline) {
      if (Contains(HttpGet(http, "/"), text)) return true;
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
    return false;
  };
  EXPECT_TRUE(page_shows("<td>retire</td><td></td><td>fleetmapd</td>")) << HttpGet(http, "/");
  EXPECT_TRUE(page_shows("<td class=\"num\">" + std::to_string(retired) +
                         "</td><td><a class=\"change\" href=\"/?change=4\">"))
      << HttpGet(http, "/");
  this->Cli({"revert", "4"});
  EXPECT_TRUE(page_shows("<td>revert <span class=\"of\">restores revision 4</span></td>"))
      << HttpGet(http, "/");
  this->StopServer(server);

  // Retired since its time: the next start waits for the next day.
  Fleetmapd again = StartFleetmapd(this->uri_, this->dir_ / "again.log", args);
  ASSERT_FALSE(again.address.empty());
  EXPECT_TRUE(again.LogContains("retire: scheduled daily at " + at)) << again.Log();
  EXPECT_FALSE(again.LogContains("retire: starting", std::chrono::milliseconds(2'000)))
      << again.Log();
  EXPECT_EQ(Head(this->uri_), 5);
  this->StopServer(again);
}

}  // namespace
}  // namespace retirement_fleet
}  // namespace fleetmap::testing
