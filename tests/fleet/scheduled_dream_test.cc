// The nightly dream on schedule, across real processes on 127.0.0.1:
// fleetmapd --dream-at a few seconds ahead dreams while five real agents keep
// syncing through it, leaves a candidate without moving the head, reports it in /metrics, and
// `fleetmap promote` makes it the next revision, which the agents then download.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <csignal>
#include <ctime>
#include <mutex>
#include <thread>

#include "corridor_robot_map.h"
#include "fleet_processes.h"
#include "fleetmap/repository/dream_candidates.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap_cli_run.h"
#include "http_get.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

using std::chrono::steady_clock;

// The UTC HH:MM:SS of the first whole second at least `lead` from now (`lead` may be negative).
std::string TimeAhead(std::chrono::seconds lead, std::chrono::system_clock::time_point* at) {
  const auto now = std::chrono::system_clock::now();
  *at = std::chrono::ceil<std::chrono::seconds>(now + lead);
  const std::time_t t = std::chrono::system_clock::to_time_t(*at);
  std::tm utc{};
  gmtime_r(&t, &utc);
  char text[16];
  std::snprintf(text, sizeof text, "%02d:%02d:%02d", utc.tm_hour, utc.tm_min, utc.tm_sec);
  return text;
}

template <typename Backend>
class ScheduledDreamTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-scheduled-dream"};
};
TYPED_TEST_SUITE(ScheduledDreamTest, StoreBackends, BackendNames);

TYPED_TEST(ScheduledDreamTest, RunsAtItsTimeWhileAgentsSyncAndPromoteMakesTheRevision) {
  const std::string uri = this->backend_.Uri();
  // Five submissions of corridor outings, merged (the repository trains and stores its
  // vocabulary on the first): four groups and the newest, held out.
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    const std::vector<CorridorOuting> outings = {
        {0, 0.0}, {1, 30.0}, {0, 60.0}, {1, 10.0}, {1, 0.0}};
    for (const CorridorOuting& outing : outings) {
      const Uuid id = Uuid::Generate();
      repository->Push(id, Uuid::Generate(), "surveyor", CorridorRobotMap({outing}));
      ASSERT_FALSE(repository->Merge(id).already_merged);
    }
  }
  std::vector<TestRobot> robots;
  for (int i = 0; i < 5; ++i) {
    robots.push_back(RegisterRobot(uri, "robot-" + std::to_string(i),
                                   this->dir_ / ("robot-" + std::to_string(i))));
    WriteLocalMap(robots.back(), RandomRobotMap(robots.back().id, 20, 100 + i));
  }
  std::chrono::system_clock::time_point dream_time;
  const std::string at = TimeAhead(std::chrono::seconds(6), &dream_time);
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log",
                                    {"--dream-at", at, "--http", "127.0.0.1:0"});
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> http_line =
      server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  ASSERT_TRUE(http_line);
  const std::string http = http_line->substr(http_line->rfind(' ') + 1);
  EXPECT_NE(HttpGet(http, "/metrics").find("fleetmap_dream_running 0"), std::string::npos);

  // Five agents sync over and over (their first sync pushes) until the dream is done; each
  // sync's end is recorded.
  std::atomic<bool> stop{false};
  std::mutex mutex;
  std::vector<steady_clock::time_point> synced;
  std::atomic<int> failures{0};
  std::vector<std::thread> agents;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    agents.emplace_back([&, i] {
      const auto log = this->dir_ / ("agent-" + std::to_string(i) + ".log");
      while (!stop.load()) {
        SyncOutcome outcome = FinishSync(*StartSync(robots[i], server.address, log), log);
        if (outcome.exit != 0) ++failures;
        std::lock_guard lock(mutex);
        synced.push_back(steady_clock::now());
      }
    });
  }
  // The dream starts at its time (bounded: a minute from now at most).
  const auto deadline = steady_clock::now() + std::chrono::seconds(60);
  std::optional<steady_clock::time_point> dream_started, dream_done;
  while (steady_clock::now() < deadline && !dream_done) {
    const std::string log = server.Log();
    if (!dream_started && log.find("dream: starting") != std::string::npos) {
      dream_started = steady_clock::now();
    }
    if (log.find("dream: candidate") != std::string::npos) dream_done = steady_clock::now();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // Let the agents run a little past the dream, then stop them.
  std::this_thread::sleep_for(std::chrono::seconds(1));
  stop = true;
  for (std::thread& agent : agents) agent.join();
  ASSERT_TRUE(dream_started && dream_done) << server.Log();
  EXPECT_GE(std::chrono::system_clock::now(), dream_time);  // not before its time
  EXPECT_EQ(failures.load(), 0);
  // Syncs went through while the dream ran: it blocks neither pushes nor downloads.
  std::size_t during = 0;
  for (const auto& t : synced) during += (t >= *dream_started && t <= *dream_done) ? 1 : 0;
  std::printf("dream ran %.2f s; %zu of %zu syncs ended while it ran\n",
              std::chrono::duration<double>(*dream_done - *dream_started).count(), during,
              synced.size());
  EXPECT_GE(during, 1u) << "dream ran "
                        << std::chrono::duration<double>(*dream_done - *dream_started).count()
                        << " s; " << synced.size() << " syncs in all";

  // The candidate: the head did not move for it (5 + one merge per robot), and /metrics and
  // the status page say what it was.
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  const std::vector<DreamCandidateRecord> candidates = DreamCandidates(store->versions()).List();
  ASSERT_EQ(candidates.size(), 1u);
  const DreamCandidateRecord& c = candidates.front();
  EXPECT_EQ(c.orders, 24u);  // four groups
  const RevisionNumber head = store->versions().HeadRevision();
  EXPECT_EQ(head, 5 + static_cast<RevisionNumber>(robots.size()));
  const std::string metrics = HttpGet(http, "/metrics");
  EXPECT_NE(metrics.find("fleetmap_dreams_total 1"), std::string::npos) << metrics;
  EXPECT_NE(metrics.find("fleetmap_dream_last_score{candidate=\"" + c.id.ToString() + "\"}"),
            std::string::npos)
      << metrics;
  const std::string page = HttpGet(http, "/");
  EXPECT_NE(page.find("Nightly dream"), std::string::npos);
  EXPECT_NE(page.find(c.id.ToString()), std::string::npos);

  // Promote it, with fleetmapd serving: the next revision, whose report states the score. A
  // candidate that only ties the order merged (as these corridor outings make it) is refused
  // without --force.
  std::vector<std::string> args = {"promote", c.id.ToString(), "--store",
                                   uri,       "--author",      "night-shift"};
  if (!c.merged_order_score || c.score >= *c.merged_order_score) {
    const CliRun refused = RunFleetmapCli(this->dir_.path(), args);
    EXPECT_NE(refused.exit_code, 0) << DescribeCliRun(args, refused);
    EXPECT_TRUE(Contains(refused.err, "--force")) << refused.err;
    args.push_back("--force");
  }
  const CliRun promote = RunFleetmapCli(this->dir_.path(), args);
  ASSERT_EQ(promote.exit_code, 0) << DescribeCliRun(args, promote);
  EXPECT_TRUE(Contains(promote.out, "revision " + std::to_string(head + 1) + " promotes"))
      << promote.out;
  EXPECT_TRUE(Contains(promote.out, "held-out score: P(gap > 10 m)")) << promote.out;
  const std::optional<Revision> promoted = store->versions().FindRevision(head + 1);
  ASSERT_TRUE(promoted);
  EXPECT_EQ(promoted->kind, RevisionKind::kPromote);
  EXPECT_EQ(DreamCandidateFromJson(promoted->report).score, c.score);
  // A robot syncing now downloads the promoted revision.
  const auto log = this->dir_ / "after.log";
  const SyncOutcome after = FinishSync(*StartSync(robots[0], server.address, log), log);
  EXPECT_EQ(after.result["revision"], head + 1) << after.result.dump();
}

// A dream killed half-way is run again when fleetmapd next starts (its
// time of day long past), once, saying so; not again at the start after it finished. First a
// dream by hand (`fleetmap dream-now`) is killed, then fleetmapd's own run of it, mid-way.
TYPED_TEST(ScheduledDreamTest, ADreamKilledMidWayRunsOnceWhenFleetmapdStartsAgain) {
  const std::string uri = this->backend_.Uri();
  {
    const std::unique_ptr<Repository> repository = Repository::Open(uri);
    for (const CorridorOuting& outing :
         std::vector<CorridorOuting>{{0, 0.0}, {1, 30.0}, {0, 60.0}, {1, 10.0}, {1, 0.0}}) {
      const Uuid id = Uuid::Generate();
      repository->Push(id, Uuid::Generate(), "surveyor", CorridorRobotMap({outing}));
      ASSERT_FALSE(repository->Merge(id).already_merged);
    }
  }
  const auto candidates = [&] {
    std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
    return DreamCandidates(store->versions()).List().size();
  };
  // Killed once its progress shows.
  const std::filesystem::path by_hand_log = this->dir_ / "dream-now.log";
  {
    ChildProcess by_hand({FLEETMAP_CLI, "dream-now", "--store", uri},
                         {.stderr_file = by_hand_log, .environment = {}});
    const auto deadline = steady_clock::now() + std::chrono::seconds(60);
    while (ReadLog(by_hand_log).find("dreaming") == std::string::npos &&
           steady_clock::now() < deadline && by_hand.running()) {
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
    by_hand.Signal(SIGKILL);
    ASSERT_EQ(by_hand.Wait(std::chrono::milliseconds(10'000)), 128 + SIGKILL)
        << ReadLog(by_hand_log);
  }
  ASSERT_EQ(candidates(), 0u);

  // Its time of day passed two and a half minutes ago: the dream runs at start all the same, and is
  // killed with fleetmapd as it runs.
  std::chrono::system_clock::time_point past;
  const std::string at = TimeAhead(-std::chrono::seconds(150), &past);
  const std::vector<std::string> args = {"--dream-at", at};
  {
    Fleetmapd first = StartFleetmapd(uri, this->dir_ / "first.log", args);
    ASSERT_TRUE(first.LogContains("dream: starting", std::chrono::milliseconds(10'000)))
        << first.Log();
    EXPECT_TRUE(Contains(first.Log(), "missed")) << first.Log();
    first.process->Signal(SIGKILL);
    first.process->Wait(std::chrono::milliseconds(10'000));
    ASSERT_FALSE(Contains(first.Log(), "dream: candidate")) << "the dream ended before the kill";
  }
  ASSERT_EQ(candidates(), 0u);

  // Started again: runs it, to the end.
  {
    Fleetmapd second = StartFleetmapd(uri, this->dir_ / "second.log", args);
    ASSERT_TRUE(second.LogContains("dream: candidate", std::chrono::milliseconds(120'000)))
        << second.Log();
    EXPECT_TRUE(Contains(second.Log(), "missed")) << second.Log();
    second.process->Signal(SIGTERM);
    second.process->Wait(std::chrono::milliseconds(10'000));
  }
  EXPECT_EQ(candidates(), 1u);

  // And once only: the next start waits for the next night.
  Fleetmapd third = StartFleetmapd(uri, this->dir_ / "third.log", args);
  ASSERT_TRUE(third.LogContains("dream: scheduled daily at " + at)) << third.Log();
  EXPECT_FALSE(third.LogContains("dream: starting", std::chrono::milliseconds(2'000)))
      << third.Log();
  EXPECT_EQ(candidates(), 1u);
}

}  // namespace
}  // namespace fleetmap::testing
