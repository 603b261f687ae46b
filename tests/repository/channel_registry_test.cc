// Release channels and what each robot runs (channel_registry.h,
// robot_registry.h), on both stores: names and ranges refused by name, every move logged in
// order, a score check that refuses a worse revision and changes nothing, or that has nothing
// to replay, moves made at once from several connections logged as one chain, robots' reports
// kept, and the release figures (behind, map differs) each made to fail.
#include "fleetmap/repository/channel_registry.h"

#include <gtest/gtest.h>

#include <latch>
#include <mutex>
#include <thread>

#include "corridor_robot_map.h"
#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/repository/robot_registry.h"
#include "random_robot_map.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;
using testing::WallNs;

template <typename Backend>
class ChannelRegistryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    repository_ = OpenAnother();
  }

  // The repository once more, on a connection of its own: what another `fleetmap channel set`
  // process has.
  std::unique_ptr<Repository> OpenAnother() {
    RepositoryOptions options;
    options.vocabulary = SharedCorridorVocabulary();
    return Repository::Open(backend_->Uri(), options);
  }

  Uuid PushAndMerge(int condition, double start_m) {
    const Uuid id = Uuid::Generate();
    repository_->Push(id, Uuid::Generate(), "surveyor", CorridorRobotMap({{condition, start_m}}));
    EXPECT_FALSE(repository_->Merge(id).already_merged);
    return id;
  }

  std::optional<Backend> backend_;
  std::unique_ptr<Repository> repository_;
};
TYPED_TEST_SUITE(ChannelRegistryTest, StoreBackends, BackendNames);

TYPED_TEST(ChannelRegistryTest, MovesAreCheckedRecordedInOrderAndResolved) {
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(0, 30.0);
  ChannelRegistry channels(*this->repository_);
  EXPECT_EQ(channels.Resolve("head"), 2);
  EXPECT_EQ(channels.Resolve(""), 2);
  ExpectError(
      ErrorCode::kNotFound, [&] { channels.Resolve("stable"); }, "fleetmap channel set");

  ExpectError(
      ErrorCode::kInvalidArgument, [&] { channels.Set("head", 1, "ops", "", 1); },
      "always follows the head");
  for (const char* bad : {"", "Stable", "a b", "x/y", "0123456789012345678901234567890123"}) {
    SCOPED_TRACE(bad);
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { channels.Set(bad, 1, "ops", "", 1); }, "channel name");
  }
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { channels.Set("stable", 0, "ops", "", 1); }, "1 ... 2");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { channels.Set("stable", 3, "ops", "", 1); },
      "not in the history");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { channels.Set("stable", 1, "", "", 1); }, "no author");
  EXPECT_TRUE(channels.List().empty());

  const ChannelMove first = channels.Set("stable", 1, "ops", "first release", 100);
  EXPECT_EQ(first.from, 0);
  EXPECT_EQ(first.to, 1);
  const ChannelMove second = channels.Set("stable", 2, "alice", "route checked", 200);
  EXPECT_EQ(second.from, 1);
  const ChannelMove same = channels.Set("stable", 2, "bob", "again", 300);
  EXPECT_EQ(same.from, 2);
  EXPECT_EQ(same.to, 2);
  channels.Set("canary", 2, "ops", "", 150);

  EXPECT_EQ(channels.Resolve("stable"), 2);
  const std::vector<Channel> listed = channels.List();
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].name, "canary");
  EXPECT_EQ(listed[1].name, "stable");
  EXPECT_EQ(listed[1].moved_by, "alice");
  EXPECT_EQ(listed[1].moved_ns, 200);
  const std::vector<ChannelMove> log = channels.Log("stable");
  ASSERT_EQ(log.size(), 2u) << "a move to the same revision is not recorded";
  EXPECT_EQ(log[0].who, "ops");
  EXPECT_EQ(log[0].why, "first release");
  EXPECT_EQ(log[0].at_ns, 100);
  EXPECT_EQ(log[1].from, 1);
  EXPECT_EQ(log[1].to, 2);
  EXPECT_EQ(log[1].who, "alice");
  EXPECT_TRUE(channels.Log("never").empty());
}

TYPED_TEST(ChannelRegistryTest, AScoreCheckRefusesAWorseRevisionAndChangesNothing) {
  this->PushAndMerge(0, 0.0);                         // 1: day
  this->PushAndMerge(1, 0.0);                         // 2: night
  const Uuid held_out = this->PushAndMerge(1, 10.0);  // 3: night again, the held-out data
  ChannelRegistry channels(*this->repository_);
  const ScoreCheck check{held_out, 10.0};
  const RevisionScore day = channels.Score(1, check);
  const RevisionScore night = channels.Score(2, check);
  EXPECT_GT(day.score, night.score) << "the day map localises the night worse";
  EXPECT_LT(day.localised_frames, night.localised_frames);
  EXPECT_EQ(day.frames, night.frames);

  // A new channel has nothing to compare with: the check scores and records.
  const ChannelMove set = channels.Set("stable", 2, "ops", "", 10, check);
  ASSERT_TRUE(set.proposed);
  EXPECT_FALSE(set.current);
  EXPECT_DOUBLE_EQ(set.proposed->score, night.score);

  ExpectError(
      ErrorCode::kConflict, [&] { channels.Set("stable", 1, "ops", "", 20, check); },
      "stays at revision 2");
  EXPECT_EQ(channels.Resolve("stable"), 2);
  EXPECT_EQ(channels.Log("stable").size(), 1u);
  ExpectError(
      ErrorCode::kNotFound,
      [&] { channels.Set("stable", 3, "ops", "", 30, ScoreCheck{Uuid::Generate()}); },
      "no submission");
  EXPECT_EQ(channels.Resolve("stable"), 2);

  const ChannelMove forward = channels.Set("stable", 3, "ops", "", 40, check);
  ASSERT_TRUE(forward.current && forward.proposed);
  EXPECT_LE(forward.proposed->score, forward.current->score);
  const std::vector<ChannelMove> log = channels.Log("stable");
  ASSERT_EQ(log.size(), 2u);
  ASSERT_TRUE(log[1].held_out && log[1].current && log[1].proposed);
  EXPECT_EQ(*log[1].held_out, held_out);
  EXPECT_EQ(log[1].current->revision, 2);
  EXPECT_DOUBLE_EQ(log[1].current->score, forward.current->score);
}

// A held-out submission that can judge nothing: one still being received (0 bytes so far), and a
// complete one with no frames. Its replay would score 0 of 0 frames on both revisions, a tie
// that lets any move through; the move is refused naming the submission, and changes nothing.
TYPED_TEST(ChannelRegistryTest, AScoreCheckWithNothingToReplayIsRefused) {
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(1, 0.0);
  ChannelRegistry channels(*this->repository_);
  channels.Set("stable", 1, "ops", "", 10);

  const Uuid receiving = Uuid::Generate();
  this->repository_->BeginChunkedPush(receiving, Uuid::Generate(), "scout");
  const Uuid empty = Uuid::Generate();
  this->repository_->Push(empty, Uuid::Generate(), "scout", GraphBatch{});
  for (const std::string channel : {"stable", "canary"}) {  // canary: nothing to compare with
    SCOPED_TRACE(channel);
    ExpectError(
        ErrorCode::kInvalidArgument,
        [&] { channels.Set(channel, 2, "ops", "", 20, ScoreCheck{receiving}); },
        receiving.ToString() + " is not fully received");
    ExpectError(
        ErrorCode::kInvalidArgument,
        [&] { channels.Set(channel, 2, "ops", "", 30, ScoreCheck{empty}); },
        empty.ToString() + " has no frames");
  }
  EXPECT_EQ(channels.Resolve("stable"), 1);
  EXPECT_EQ(channels.Log("stable").size(), 1u);
  EXPECT_FALSE(channels.Find("canary"));
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { channels.Score(2, ScoreCheck{receiving}); },
      "not fully received");
}

// Moves of one channel from several connections at once, one mover with a score check whose
// replays let the others move the channel meanwhile. Each move is judged against the revision
// the channel holds when it lands, so the log is one chain (each move's `from` the previous
// one's `to`, and a checked move's current score is of that revision) and the channel is where
// the last logged move put it. A mover that keeps losing the race may be refused, and a checked
// move to a worse revision is, by name; nothing else may fail.
TYPED_TEST(ChannelRegistryTest, ConcurrentMovesOfOneChannelLogOneChain) {
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(1, 30.0);
  this->PushAndMerge(0, 60.0);
  const Uuid held_out = Uuid::Generate();  // pushed, not merged
  this->repository_->Push(held_out, Uuid::Generate(), "surveyor", CorridorRobotMap({{0, 30.0}}));
  constexpr int kMovers = 4;
  constexpr int kMovesEach = 8;
  std::vector<std::unique_ptr<Repository>> repositories;
  for (int i = 0; i < kMovers; ++i) repositories.push_back(this->OpenAnother());

  std::mutex mutex;
  std::size_t moves_made = 0;
  std::vector<std::string> unexpected;
  std::latch start(kMovers);
  std::vector<std::thread> movers;
  for (int i = 0; i < kMovers; ++i) {
    movers.emplace_back([&, i] {
      ChannelRegistry channels(*repositories[static_cast<std::size_t>(i)]);
      start.arrive_and_wait();
      for (int j = 0; j < kMovesEach; ++j) {
        const RevisionNumber to = 1 + (i + j) % 3;
        std::optional<ScoreCheck> check;
        if (i == 0) check = ScoreCheck{held_out, 10.0};
        try {
          const ChannelMove move = channels.Set("stable", to, "mover-" + std::to_string(i),
                                                "move " + std::to_string(j), WallNs(), check);
          const std::lock_guard<std::mutex> lock(mutex);
          if (move.from != move.to) ++moves_made;
        } catch (const Error& error) {
          const std::string what = error.what();
          const bool named = what.find("try again") != std::string::npos ||
                             (check && what.find("localises worse") != std::string::npos);
          const std::lock_guard<std::mutex> lock(mutex);
          if (error.code() != ErrorCode::kConflict || !named) unexpected.push_back(what);
        }
      }
    });
  }
  for (std::thread& mover : movers) mover.join();
  for (const std::string& what : unexpected) ADD_FAILURE() << what;

  ChannelRegistry channels(*this->repository_);
  const std::vector<ChannelMove> log = channels.Log("stable");
  ASSERT_EQ(log.size(), moves_made) << "every move made is logged, once";
  ASSERT_FALSE(log.empty());
  EXPECT_EQ(log[0].from, 0);
  std::size_t broken = 0;
  std::size_t checked = 0;
  for (std::size_t k = 0; k < log.size(); ++k) {
    EXPECT_NE(log[k].from, log[k].to) << "move " << k;
    if (k > 0 && log[k].from != log[k - 1].to) ++broken;
    if (log[k].current) {
      ++checked;
      EXPECT_EQ(log[k].current->revision, log[k].from) << "move " << k;
      EXPECT_LE(log[k].proposed->score, log[k].current->score) << "move " << k;
    }
  }
  EXPECT_EQ(broken, 0u) << "of " << log.size() << " moves, " << broken
                        << " start where the one before did not leave the channel (" << checked
                        << " checked)";
  const std::optional<Channel> stable = channels.Find("stable");
  ASSERT_TRUE(stable);
  EXPECT_EQ(stable->revision, log.back().to);
  EXPECT_EQ(stable->moved_by, log.back().who);
  EXPECT_EQ(stable->moved_ns, log.back().at_ns);
}

TYPED_TEST(ChannelRegistryTest, RobotReportsAreKeptAndJudged) {
  this->PushAndMerge(0, 0.0);
  this->PushAndMerge(0, 30.0);
  this->PushAndMerge(0, 60.0);
  ChannelRegistry channels(*this->repository_);
  channels.Set("stable", 1, "ops", "", 1);
  RobotRegistry robots(this->repository_->versions());
  const Uuid id = robots.Add("scout", 5).robot.id;

  RegisteredRobot robot = *robots.Find(id);
  EXPECT_FALSE(robot.sent || robot.installed);
  RobotRelease release = ReleaseOf(robot, 3, channels.List());
  EXPECT_EQ(release.channel, "head");
  EXPECT_EQ(release.target, 3);
  EXPECT_FALSE(release.behind) << "nothing installed";
  EXPECT_FALSE(release.map_differs);

  robots.RecordSent(id, {"stable", 1, 0xfeedULL, 10});
  robots.RecordInstalled(id, {"stable", 1, 0xfeedULL, 11});
  robots.RecordError(id, "agent: link reset", 12);
  robot = *robots.Find(id);
  ASSERT_TRUE(robot.sent && robot.installed);
  EXPECT_EQ(*robot.sent, (RobotMapRecord{"stable", 1, 0xfeedULL, 10}));
  EXPECT_EQ(robot.last_error, "agent: link reset");
  EXPECT_EQ(robot.last_error_ns, 12);
  release = ReleaseOf(robot, 3, channels.List());
  EXPECT_EQ(release.channel, "stable");
  EXPECT_EQ(release.target, 1);
  EXPECT_EQ(release.behind, 0);
  EXPECT_FALSE(release.map_differs);

  // The channel moves on: two behind. A digest other than the one sent: flagged; an unknown one
  // (0) or another revision: not judged.
  channels.Set("stable", 3, "ops", "", 2);
  release = ReleaseOf(*robots.Find(id), 3, channels.List());
  EXPECT_EQ(release.behind, 2);
  robots.RecordInstalled(id, {"stable", 1, 0xbeefULL, 13});
  EXPECT_TRUE(ReleaseOf(*robots.Find(id), 3, channels.List()).map_differs);
  EXPECT_TRUE(robots.List()[0].MapDiffers());
  robots.RecordSent(id, {"stable", 1, 0, 14});
  EXPECT_FALSE(robots.Find(id)->MapDiffers());
  robots.RecordSent(id, {"stable", 3, 0xbeefULL + 1, 15});
  EXPECT_FALSE(robots.Find(id)->MapDiffers());
  // A channel that is no longer known has no target.
  robots.RecordInstalled(id, {"retired", 3, 1, 16});
  release = ReleaseOf(*robots.Find(id), 3, channels.List());
  EXPECT_FALSE(release.target);
  EXPECT_FALSE(release.behind);
  // Long errors are cut.
  robots.RecordError(id, std::string(2000, 'x'), 17);
  EXPECT_EQ(robots.Find(id)->last_error.size(), 500u);
}

}  // namespace
}  // namespace fleetmap
