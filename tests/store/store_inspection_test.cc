// `fleetmap info` and `fleetmap doctor` below the CLI: DescribeStore (store_facts.h) and
// DiagnoseStore (store_diagnosis.h) on both backends, on healthy stores and on stores damaged
// behind the API's back the ways a store gets damaged (a tool writing with foreign keys off, a
// hand-edited history, a robot that never finished its push, a fleet with no fleetmapd).
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>
#include <vector>

#include "fleetmap/core/clock.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/store_diagnosis.h"
#include "fleetmap/store/store_facts.h"
#include "fleetmap/store/version_store.h"
#include "random_robot_map.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::RandomRobotMap;
using testing::StoreBackends;

constexpr std::int64_t kHourNs = 3'600'000'000'000;

// A submission as a robot's push leaves it: begun `age_ns` ago, one chunk, and completed
// (queued) unless `complete` is false.
Submission PushedSubmission(VersionStore& versions, const Uuid& robot, std::int64_t age_ns,
                            bool complete = true) {
  Submission header;
  header.id = Uuid::Generate();
  header.robot = robot;
  header.author = "robot-" + robot.ToString().substr(0, 4);
  header.received_ns = WallClockNs() - age_ns;
  versions.BeginSubmission(header);
  versions.PutSubmissionChunk(header.id, 0, "chunk");
  if (complete) versions.CompleteSubmission(header.id, 42);
  return *versions.FindSubmission(header.id);
}

// What MERGE leaves for a submission that adds all of `map`: a revision recording it, the map,
// the submission marked merged into it; in one transaction.
void MergeWhole(GraphStore& store, const GraphBatch& map, const Uuid& robot) {
  VersionStore& versions = store.versions();
  const Submission submission = PushedSubmission(versions, robot, kHourNs / 60);
  GraphStore::Transaction transaction = store.Begin();
  Revision revision;
  revision.number = versions.HeadRevision() + 1;
  revision.created_ns = WallClockNs();
  revision.author = submission.author;
  revision.submission = submission.id;
  versions.AppendRevision(revision, map);
  store.Put(map);
  versions.SetSubmissionState(submission.id, SubmissionState::kMerged, revision.number, "");
  transaction.Commit();
}

std::vector<std::string> Checks(const std::vector<StoreProblem>& problems) {
  std::vector<std::string> checks;
  for (const StoreProblem& p : problems) checks.push_back(p.check);
  return checks;
}

bool Mentions(const std::vector<StoreProblem>& problems, const std::string& check,
              const std::string& text) {
  return std::any_of(problems.begin(), problems.end(), [&](const StoreProblem& p) {
    return p.check == check && p.what.find(text) != std::string::npos && !p.remedy.empty();
  });
}

// A store's state without what any SQLite reader of a write-ahead-log database creates beside
// it (a read-only one too): the shared-memory index (-shm, where readers write their read
// marks; rebuilt whenever lost) and an empty log (-wal, 0 bytes: holds nothing).
std::string WithoutReaderFiles(std::string state) {
  for (const char* file : {"store.sqlite-shm ", "store.sqlite-wal 0 bytes:\n"}) {
    const std::size_t at = state.find(file);
    if (at == std::string::npos) continue;
    const std::size_t next = state.find("store.sqlite-", at + 1);
    state.erase(at, next == std::string::npos ? std::string::npos : next - at);
  }
  return state;
}

DiagnosisOptions Now() {
  DiagnosisOptions options;
  options.now_ns = WallClockNs();
  return options;
}

template <typename Backend>
class StoreInspectionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    store_ = GraphStore::Open(backend_->Uri());
    robot_a_ = Uuid::Generate();
    robot_b_ = Uuid::Generate();
    map_a_ = RandomRobotMap(robot_a_, 6, 1, 8);
    map_b_ = RandomRobotMap(robot_b_, 4, 2, 8);
    MergeWhole(*store_, map_a_, robot_a_);
    MergeWhole(*store_, map_b_, robot_b_);
  }

  std::optional<Backend> backend_;
  std::unique_ptr<GraphStore> store_;
  Uuid robot_a_, robot_b_;
  GraphBatch map_a_, map_b_;
};
TYPED_TEST_SUITE(StoreInspectionTest, StoreBackends, BackendNames);

TYPED_TEST(StoreInspectionTest, InfoCountsTheStoreTheHeadAndEachRobot) {
  const StoreFacts f = DescribeStore(*this->store_);
  EXPECT_EQ(f.uri, this->store_->uri());
  EXPECT_TRUE(f.engine.starts_with("SQLite ") || f.engine.starts_with("PostgreSQL ")) << f.engine;
  EXPECT_EQ(f.schema_version, this->store_->schema_version());
  EXPECT_GT(f.bytes_on_disk, 0);
  EXPECT_EQ(f.stored.nodes, 10);
  EXPECT_EQ(f.stored.edges, 2 * 5 + 2 * 3);
  EXPECT_EQ(f.stored.paths, 2);
  EXPECT_EQ(f.head, 2);
  EXPECT_EQ(f.at_head.nodes, 10);
  ASSERT_TRUE(f.last_revision);
  EXPECT_EQ(f.last_revision->number, 2);
  EXPECT_EQ(f.last_revision->author, "robot-" + this->robot_b_.ToString().substr(0, 4));
  EXPECT_EQ(f.submissions.at("merged"), 2);
  EXPECT_EQ(f.submissions.count("queued"), 0u);
  ASSERT_EQ(f.robots.size(), 2u);
  for (const RobotNodes& r : f.robots) {
    const GraphBatch& map = r.robot == this->robot_a_ ? this->map_a_ : this->map_b_;
    EXPECT_EQ(r.nodes, static_cast<std::int64_t>(map.nodes.size()));
    EXPECT_EQ(r.oldest_ns, map.nodes.front().stamp_ns);
    EXPECT_EQ(r.newest_ns, map.nodes.back().stamp_ns);
  }
  ASSERT_TRUE(f.oldest_ns && f.newest_ns);
  EXPECT_EQ(*f.oldest_ns,
            std::min(this->map_a_.nodes.front().stamp_ns, this->map_b_.nodes.front().stamp_ns));
  EXPECT_EQ(*f.newest_ns,
            std::max(this->map_a_.nodes.back().stamp_ns, this->map_b_.nodes.back().stamp_ns));
}

TYPED_TEST(StoreInspectionTest, AnEmptyStoreHasNoHeadNoStampsAndNoProblems) {
  TypeParam other;
  const std::unique_ptr<GraphStore> empty = GraphStore::Open(other.Uri());
  const StoreFacts f = DescribeStore(*empty);
  EXPECT_EQ(f.head, 0);
  EXPECT_FALSE(f.last_revision);
  EXPECT_FALSE(f.oldest_ns);
  EXPECT_TRUE(f.robots.empty());
  EXPECT_TRUE(DiagnoseStore(*empty, Now()).empty());
}

TYPED_TEST(StoreInspectionTest, AHealthyStoreHasNoProblemsAndDoctorChangesNothing) {
  this->store_.reset();
  const std::string before = WithoutReaderFiles(this->backend_->StoredState());
  StoreOptions read_only;
  read_only.read_only = true;
  const std::unique_ptr<GraphStore> store = GraphStore::Open(this->backend_->Uri(), read_only);
  EXPECT_EQ(Checks(DiagnoseStore(*store, Now())), std::vector<std::string>{});
  DescribeStore(*store);
  EXPECT_TRUE(WithoutReaderFiles(this->backend_->StoredState()) == before)
      << "doctor or info changed the store";
}

// An edge into nodes that are not stored, as a tool writing with foreign keys off leaves it.
TYPED_TEST(StoreInspectionTest, ADanglingEdgeIsNamedWithWhatToDo) {
  const Uuid edge = Uuid::Generate();
  const Uuid nowhere = Uuid::Generate();
  const Uuid from = this->map_a_.nodes[0].id;
  if constexpr (std::is_same_v<TypeParam, testing::SqliteBackend>) {
    const auto hex = [](const Uuid& id) {
      std::string h = id.ToString();
      h.erase(std::remove(h.begin(), h.end(), '-'), h.end());
      return "x'" + h + "'";
    };
    this->backend_->ExecRaw(
        "PRAGMA foreign_keys=OFF; INSERT INTO edges (id, from_id, to_id, kind,"
        " tx, ty, tz, qw, qx, qy, qz, path_id) VALUES (" +
        hex(edge) + ", " + hex(from) + ", " + hex(nowhere) + ", 1, 0, 0, 1, 1, 0, 0, 0, NULL)");
  } else {
    this->backend_->ExecRaw(
        "SET session_replication_role = replica; INSERT INTO edges (id, from_id, to_id, kind,"
        " tx, ty, tz, qw, qx, qy, qz, path_id) VALUES ('" +
        edge.ToString() + "', '" + from.ToString() + "', '" + nowhere.ToString() +
        "', 1, 0, 0, 1, 1, 0, 0, 0, NULL)");
  }
  const std::vector<StoreProblem> problems = DiagnoseStore(*this->store_, Now());
  EXPECT_TRUE(Mentions(problems, "dangling edges", edge.ToString()))
      << ::testing::PrintToString(Checks(problems));
  // Outside version control it counts as revision 0, so the head shows it too.
  EXPECT_TRUE(Mentions(problems, "head", edge.ToString()));
  if constexpr (std::is_same_v<TypeParam, testing::SqliteBackend>) {
    EXPECT_TRUE(Mentions(problems, "engine", "foreign_key_check"));
  }
}

TYPED_TEST(StoreInspectionTest, AnOrphanVersionAndABrokenHistoryAreNamed) {
  const Uuid ghost = Uuid::Generate();
  const std::string id = std::is_same_v<TypeParam, testing::SqliteBackend>
                             ? "x'" +
                                   [&] {
                                     std::string h = ghost.ToString();
                                     h.erase(std::remove(h.begin(), h.end(), '-'), h.end());
                                     return h;
                                   }() +
                                   "'"
                             : "'" + ghost.ToString() + "'";
  this->backend_->ExecRaw("INSERT INTO element_versions (id, kind, added_rev) VALUES (" + id +
                          ", 1, 1)");
  this->backend_->ExecRaw("UPDATE submissions SET revision = 7 WHERE revision = 2");
  const std::vector<StoreProblem> problems = DiagnoseStore(*this->store_, Now());
  EXPECT_TRUE(Mentions(problems, "orphan versions", ghost.ToString()))
      << ::testing::PrintToString(Checks(problems));
  EXPECT_TRUE(Mentions(problems, "history", "revision 7, which does not exist"));
  EXPECT_TRUE(Mentions(problems, "history", "revision 2 merged submission"));
}

TYPED_TEST(StoreInspectionTest, StuckSubmissionsAreNamedAndLiveOnesAreNot) {
  VersionStore& versions = this->store_->versions();
  const Submission stopped = PushedSubmission(versions, this->robot_a_, 30 * kHourNs, false);
  const Submission still_pushing = PushedSubmission(versions, this->robot_a_, kHourNs, false);
  const Submission unmerged = PushedSubmission(versions, this->robot_b_, 2 * kHourNs);
  const std::vector<StoreProblem> problems = DiagnoseStore(*this->store_, Now());
  EXPECT_TRUE(Mentions(problems, "submissions", stopped.id.ToString() + " from robot"));
  EXPECT_TRUE(Mentions(problems, "submissions", unmerged.id.ToString() + " from robot"));
  EXPECT_FALSE(Mentions(problems, "submissions", still_pushing.id.ToString()));
  EXPECT_EQ(problems.size(), 2u) << ::testing::PrintToString(Checks(problems));

  // Claimed by a live fleetmapd, the queued one is being merged: not stuck.
  ASSERT_TRUE(versions.ClaimQueuedSubmission("fleetmapd-a", std::chrono::minutes(10)));
  EXPECT_FALSE(
      Mentions(DiagnoseStore(*this->store_, Now()), "submissions", unmerged.id.ToString()));
  // Shorter thresholds name the young push as well.
  DiagnosisOptions strict = Now();
  strict.receiving_stuck_after = std::chrono::minutes(30);
  EXPECT_TRUE(
      Mentions(DiagnoseStore(*this->store_, strict), "submissions", still_pushing.id.ToString()));
}

}  // namespace
}  // namespace fleetmap
