// The robot's map directory (agent/include/fleetmap/agent/local_map.h) without a network: what
// is unsynced, full and incremental installs, that an install never loses local content the
// server does not have, and that a crash at any point of an install leaves map and state
// describing each other.
#include <gtest/gtest.h>
#include <sqlite3.h>
#include <sys/stat.h>

#include <fstream>
#include <nlohmann/json.hpp>

#include "corridor_robot_map.h"
#include "expect_error.h"
#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/map_chunks.h"
#include "fleetmap/store/graph_store.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

// Robot maps built once per process: a day outing and a night outing of the corridor, by
// different robots (so their elements are disjoint).
struct Maps {
  GraphBatch day = CorridorRobotMap({{0, 0.0}});
  GraphBatch night = CorridorRobotMap({{1, 0.0}});
};
const Maps& SharedMaps() {
  static const Maps maps;
  return maps;
}

GraphBatch ReadStore(const std::string& uri) {
  return GraphStore::Open(uri)->ReadMap();
}

// `map` as a full download of revision `revision`.
MapDownload FullDownload(const GraphBatch& map, std::int64_t revision) {
  MapDownload download;
  download.revision = revision;
  download.content = map;
  download.nodes = map.nodes.size();
  download.edges = map.edges.size();
  download.paths = map.paths.size();
  return download;
}

GraphBatch Join(const GraphBatch& a, const GraphBatch& b) {
  GraphBatch out = a;
  out.nodes.insert(out.nodes.end(), b.nodes.begin(), b.nodes.end());
  out.edges.insert(out.edges.end(), b.edges.begin(), b.edges.end());
  out.paths.insert(out.paths.end(), b.paths.begin(), b.paths.end());
  return out;
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream out(path, std::ios::binary);
  out << text;
}

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// The day map built into `map` and pushed (accepted by the server, not merged yet).
Uuid PushDay(LocalMap& map) {
  GraphStore::Open(map.map_uri())->Put(SharedMaps().day);
  const Uuid submission = map.BeginSubmission(map.Unsynced()).id;
  map.MarkPushed(submission);
  return submission;
}

// The sync state is staged at sync.json.tmp; a symbolic link someone put
// there is never written through (its target stays as it was) and the state is written.
TEST(AgentLocalMapTest, ASymbolicLinkAtTheStagedStateIsNotWrittenThrough) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const fs::path victim = dir / "victim.txt";
  WriteText(victim, "precious\n");
  fs::create_symlink(victim, dir / "robot" / "sync.json.tmp");
  const Uuid submission = PushDay(map);
  EXPECT_EQ(ReadText(victim), "precious\n");
  EXPECT_FALSE(fs::is_symlink(dir / "robot" / "sync.json"));
  EXPECT_NE(ReadText(dir / "robot" / "sync.json").find(submission.ToString()), std::string::npos);
}

TEST(AgentLocalMapTest, NewDirectoryHasAnEmptyMapAndNothingUnsynced) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  EXPECT_TRUE(fs::exists(dir / "robot" / "map.db"));
  const GraphBatch unsynced = map.Unsynced();
  EXPECT_TRUE(unsynced.nodes.empty() && unsynced.edges.empty() && unsynced.paths.empty());
  EXPECT_EQ(map.state().revision, 0);
}

TEST(AgentLocalMapTest, EverythingTheBuilderWroteIsUnsyncedUntilPushed) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  BuildCorridorRobotMap(*GraphStore::Open(map.map_uri()), {{0, 0.0}});
  const GraphBatch built = ReadStore(map.map_uri());
  ASSERT_GT(built.nodes.size(), 5u);

  const GraphBatch unsynced = map.Unsynced();
  EXPECT_EQ(IdsOf(unsynced), IdsOf(built));
  EXPECT_TRUE(std::is_sorted(unsynced.nodes.begin(), unsynced.nodes.end(),
                             [](const Node& a, const Node& b) { return a.id < b.id; }));

  const PendingSubmission submission = map.BeginSubmission(unsynced);
  EXPECT_EQ(submission.content, IdsOf(built));
  // Read back, the submission encodes to the same chunks: a retry is the same push.
  EXPECT_EQ(EncodeMapChunks(map.SubmissionContent(submission)), EncodeMapChunks(unsynced));
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { map.BeginSubmission(unsynced); },
      submission.id.ToString());
  map.MarkPushed(submission.id);
  EXPECT_TRUE(map.Unsynced().nodes.empty());
  EXPECT_FALSE(map.state().submission.has_value());
}

TEST(AgentLocalMapTest, PendingSubmissionAndStateSurviveReopening) {
  const ScratchDir dir("fleetmap-agent-map");
  Uuid id;
  {
    LocalMap map = LocalMap::Open(dir / "robot");
    GraphStore::Open(map.map_uri())->Put(SharedMaps().day);
    id = map.BeginSubmission(map.Unsynced()).id;
  }
  LocalMap map = LocalMap::Open(dir / "robot");
  ASSERT_TRUE(map.state().submission.has_value());
  EXPECT_EQ(map.state().submission->id, id);
  EXPECT_EQ(IdsOf(map.SubmissionContent(*map.state().submission)), IdsOf(SharedMaps().day));
}

TEST(AgentLocalMapTest, OnlyOneExclusiveOpenPerDirectory) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap first = LocalMap::Open(dir / "robot");
  ExpectError(
      ErrorCode::kConflict, [&] { LocalMap::Open(dir / "robot"); }, "in use");
  // A reader (status) still gets in, and cannot write.
  LocalMap reader = LocalMap::Open(dir / "robot", LocalMapAccess::kReadOnly);
  ExpectError(ErrorCode::kInvalidArgument, [&] { reader.Install(FullDownload({}, 1)); });
}

TEST(AgentLocalMapTest, RobotIsBoundOnce) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const Uuid robot = Uuid::Generate();
  map.BindRobot(robot);
  map.BindRobot(robot);
  const Uuid other = Uuid::Generate();
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { map.BindRobot(other); }, robot.ToString());
}

TEST(AgentLocalMapTest, FullInstallReplacesTheMapWithTheDownload) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const GraphBatch& day = SharedMaps().day;
  const InstallReport report = map.Install(FullDownload(day, 3));
  EXPECT_EQ(report.revision, 3);
  EXPECT_FALSE(report.incremental);
  EXPECT_EQ(report.nodes, day.nodes.size());
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(day));
  EXPECT_TRUE(map.Unsynced().nodes.empty());
  EXPECT_EQ(map.state().revision, 3);
  EXPECT_EQ(map.state().installed, IdsOf(day));
  EXPECT_FALSE(fs::exists(dir / "robot" / "map.db.new"));
  EXPECT_FALSE(fs::exists(dir / "robot" / "sync.json.next"));

  // A second full install replaces it (the day map is gone from the robot).
  map.Install(FullDownload(SharedMaps().night, 4));
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().night));
  // The state is on disk: a reopened directory says the same.
  const SyncState state = map.state();
  { LocalMap moved = std::move(map); }
  EXPECT_EQ(LocalMap::Open(dir / "robot").state(), state);
}

TEST(AgentLocalMapTest, IncrementalInstallAppliesRemovedAndAdded) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const GraphBatch& day = SharedMaps().day;
  const GraphBatch& night = SharedMaps().night;
  MapDownload first = FullDownload(day, 2);
  first.request.policy = "tod";
  first.request.mission_start_min = 600;
  map.Install(first);

  // Revision 5 drops one day node with every edge touching it, and adds the night map.
  const Uuid dropped = day.nodes[day.nodes.size() / 2].id;
  MapDownload next;
  next.revision = 5;
  next.base_revision = 2;
  next.request = first.request;
  next.content = night;
  next.removed.nodes.insert(dropped);
  GraphBatch expected = Join(day, night);
  std::erase_if(expected.nodes, [&](const Node& n) { return n.id == dropped; });
  for (const Edge& edge : day.edges) {
    if (edge.from == dropped || edge.to == dropped) next.removed.edges.insert(edge.id);
  }
  std::erase_if(expected.edges, [&](const Edge& e) { return next.removed.edges.contains(e.id); });
  next.nodes = expected.nodes.size();
  next.edges = expected.edges.size();
  next.paths = expected.paths.size();

  const InstallReport report = map.Install(next);
  EXPECT_TRUE(report.incremental);
  EXPECT_EQ(report.nodes, expected.nodes.size());
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(expected));
  EXPECT_EQ(map.state().installed, IdsOf(expected));
  EXPECT_EQ(map.state().revision, 5);

  // An incremental download must continue what is installed, asked for the same way.
  MapDownload stale = next;
  stale.revision = 6;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { map.Install(stale); }, "revision 2");
  MapDownload other_policy = next;
  other_policy.base_revision = 5;
  other_policy.revision = 6;
  other_policy.request.policy = "copy";
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { map.Install(other_policy); }, "parameters");
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(expected));
}

TEST(AgentLocalMapTest, CountsThatDisagreeWithTheHeaderLeaveTheMapAsItWas) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  map.Install(FullDownload(SharedMaps().day, 1));
  MapDownload wrong = FullDownload(SharedMaps().night, 2);
  wrong.nodes += 1;
  ExpectError(
      ErrorCode::kCorrupt, [&] { map.Install(wrong); }, "header");
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().day));
  EXPECT_EQ(map.state().revision, 1);
  EXPECT_FALSE(fs::exists(dir / "robot" / "map.db.new"));

  // A download that is not an integral map (an edge whose end is not sent) is refused too.
  GraphBatch broken = SharedMaps().night;
  broken.nodes.erase(broken.nodes.begin());
  ExpectError(ErrorCode::kCorrupt, [&] { map.Install(FullDownload(broken, 2)); });
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().day));
}

TEST(AgentLocalMapTest, UnsyncedContentIsKeptThroughAnInstall) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const GraphBatch& day = SharedMaps().day;
  map.Install(FullDownload(day, 1));

  // The robot drives: a new node, linked to an installed node, and a new outing's map.
  const Node& anchor = day.nodes.front();
  GraphBatch local = CorridorRobotMap({{1, 60.0}});
  Node fresh = anchor;
  fresh.id = Uuid::Generate();
  local.nodes.push_back(fresh);
  local.edges.push_back(
      Edge{Uuid::Generate(), fresh.id, anchor.id, EdgeKind::kMetric, Se3::Identity(), Uuid()});
  GraphStore::Open(map.map_uri())->Put(local);
  ASSERT_EQ(IdsOf(map.Unsynced()), IdsOf(local));

  // A pending (not yet accepted) submission of part of it stays pending and unsynced.
  const PendingSubmission pending = map.BeginSubmission(map.Unsynced());

  // The next download no longer holds the anchor; the local edge still needs it.
  const InstallReport report = map.Install(FullDownload(SharedMaps().night, 2));
  EXPECT_EQ(report.kept_unsynced, IdsOf(local).size());
  EXPECT_EQ(report.kept_for_unsynced, 1u);
  const GraphBatch installed = ReadStore(map.map_uri());
  const ElementIds ids = IdsOf(installed);
  EXPECT_TRUE(ids.Contains(IdsOf(SharedMaps().night)));
  EXPECT_TRUE(ids.Contains(IdsOf(local)));
  EXPECT_TRUE(ids.nodes.contains(anchor.id));
  EXPECT_EQ(ids.nodes.size(),
            SharedMaps().night.nodes.size() + local.nodes.size() + 1);  // + the anchor
  EXPECT_EQ(IdsOf(map.Unsynced()), IdsOf(local));  // still to push; the anchor is known
  ASSERT_TRUE(map.state().submission.has_value());
  EXPECT_EQ(map.state().submission->id, pending.id);
  EXPECT_EQ(IdsOf(map.SubmissionContent(pending)), IdsOf(local));
}

TEST(AgentLocalMapTest, PushedContentStaysUntilADownloadReflectsItsMerge) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const GraphBatch& day = SharedMaps().day;
  GraphStore::Open(map.map_uri())->Put(day);
  const Uuid submission = map.BeginSubmission(map.Unsynced()).id;
  map.MarkPushed(submission);
  ASSERT_EQ(map.state().unmerged.size(), 1u);
  EXPECT_TRUE(map.Unsynced().nodes.empty());

  // Revision 1 was chosen before the merge: the robot keeps what it pushed.
  const InstallReport before_merge = map.Install(FullDownload(SharedMaps().night, 1));
  EXPECT_EQ(before_merge.kept_unmerged, IdsOf(day).size());
  EXPECT_TRUE(IdsOf(ReadStore(map.map_uri())).Contains(IdsOf(day)));
  EXPECT_TRUE(map.Unsynced().nodes.empty());  // known to the server all the same
  ASSERT_EQ(map.state().unmerged.size(), 1u);

  // Merged as revision 2 (MERGE took only the night map's worth): a download of revision 2
  // reflects the merge, so what it left out goes.
  map.RecordMerge(submission, 2);
  const InstallReport merged = map.Install(FullDownload(SharedMaps().night, 2));
  EXPECT_EQ(merged.kept_unmerged, 0u);
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().night));
  EXPECT_TRUE(map.state().unmerged.empty());
  EXPECT_TRUE(map.state().pushed.nodes.empty());
}

// A submission the server refused stays in the robot's map through every install, survives a
// restart of the agent, and goes only after an explicit Discard.
TEST(AgentLocalMapTest, FailedSubmissionIsKeptUntilDiscarded) {
  const ScratchDir dir("fleetmap-agent-map");
  const GraphBatch& day = SharedMaps().day;
  Uuid submission;
  {
    LocalMap map = LocalMap::Open(dir / "robot");
    submission = PushDay(map);
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { map.Discard(submission); }, "has not failed");
    map.RecordFailure(submission, "edge e ends at node n, never seen");
  }
  LocalMap map = LocalMap::Open(dir / "robot");  // the state file keeps the failure
  ASSERT_EQ(map.state().unmerged.size(), 1u);
  EXPECT_TRUE(map.state().unmerged[0].failed);
  EXPECT_EQ(map.state().unmerged[0].error, "edge e ends at node n, never seen");
  for (std::int64_t revision : {3, 4}) {  // later revisions do not retire it either
    const InstallReport report = map.Install(FullDownload(SharedMaps().night, revision));
    EXPECT_EQ(report.kept_failed, IdsOf(day).size());
    EXPECT_TRUE(IdsOf(ReadStore(map.map_uri())).Contains(IdsOf(day)));
  }
  ExpectError(ErrorCode::kNotFound, [&] { map.Discard(Uuid::Generate()); });
  map.Discard(submission);
  EXPECT_TRUE(map.state().unmerged.empty());
  map.Install(FullDownload(SharedMaps().night, 5));
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().night));
}

// The digest of the installed selection as the install wrote it, the same
// read back from map.db, and after a byte of map.db changed behind the agent's back, not the
// same. The channel, the route and the last error live in the state across a reopen.
TEST(AgentLocalMapTest, TheInstalledDigestIsTheSelectionsAndSeesADamagedMap) {
  const ScratchDir dir("fleetmap-agent-map");
  const GraphBatch& day = SharedMaps().day;
  SelectionDigest expected;
  expected.Add(day);
  {
    LocalMap map = LocalMap::Open(dir / "robot");
    EXPECT_EQ(map.ReadInstalledDigest(), 0u) << "nothing installed";
    MapDownload download = FullDownload(day, 3);
    download.request.channel = "stable";
    download.request.route_anchor = day.nodes[0].id;
    download.request.route_xyz = {0, 0, 0, 0, 0, 40};
    download.request.route_radius_m = 5;
    const InstallReport report = map.Install(download);
    EXPECT_EQ(report.selection_digest, expected.value());
    EXPECT_EQ(map.state().installed_digest, expected.value());
    EXPECT_EQ(map.ReadInstalledDigest(), expected.value());
    map.RecordSyncError("link reset");
    // Content the robot built itself is not part of the selection's digest.
    GraphStore::Open(map.map_uri())->Put(SharedMaps().night);
    EXPECT_EQ(map.ReadInstalledDigest(), expected.value());
  }
  LocalMap map = LocalMap::Open(dir / "robot");
  EXPECT_EQ(map.state().installed_digest, expected.value());
  EXPECT_EQ(map.state().last_error, "link reset");
  ASSERT_TRUE(map.state().request);
  EXPECT_EQ(map.state().request->channel, "stable");
  EXPECT_EQ(map.state().request->route_anchor, day.nodes[0].id);
  EXPECT_EQ(map.state().request->route_xyz, (std::vector<double>{0, 0, 0, 0, 0, 40}));
  EXPECT_EQ(map.state().request->route_radius_m, 5.0);
  Node damaged = day.nodes[1];
  damaged.landmarks_blob.back() ^= 1;
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(map.map_path().c_str(), &db), SQLITE_OK);
    sqlite3_stmt* update = nullptr;
    ASSERT_EQ(sqlite3_prepare_v2(db, "UPDATE nodes SET landmarks = ?1 WHERE id = ?2", -1, &update,
                                 nullptr),
              SQLITE_OK);
    const std::string id = damaged.id.ToBytesString();
    sqlite3_bind_blob(update, 1, damaged.landmarks_blob.data(),
                      static_cast<int>(damaged.landmarks_blob.size()), SQLITE_TRANSIENT);
    sqlite3_bind_blob(update, 2, id.data(), static_cast<int>(id.size()), SQLITE_TRANSIENT);
    EXPECT_EQ(sqlite3_step(update), SQLITE_DONE);
    sqlite3_finalize(update);
    sqlite3_close(db);
  }
  SelectionDigest with_damage = expected;
  with_damage.Remove(day.nodes[1]);
  with_damage.Add(damaged);
  EXPECT_EQ(map.ReadInstalledDigest(), with_damage.value());
  EXPECT_NE(map.ReadInstalledDigest(), expected.value());
  map.RecordSyncError("");
  EXPECT_EQ(map.state().last_error, "");
}

// Runs `sql` on map.db behind the agent's back, as a robot's other software or a bad disk
// might.
void ChangeMapBehindTheAgent(const LocalMap& map, const std::string& sql) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(map.map_path().c_str(), &db), SQLITE_OK);
  char* error = nullptr;
  EXPECT_EQ(sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error), SQLITE_OK) << error;
  sqlite3_free(error);
  sqlite3_close(db);
}

// `bytes` as an SQL blob literal.
std::string BlobLiteral(std::string_view bytes) {
  static constexpr char kDigits[] = "0123456789abcdef";
  std::string text = "x'";
  for (const char c : bytes) {
    const auto byte = static_cast<unsigned char>(c);
    text += kDigits[byte >> 4];
    text += kDigits[byte & 15];
  }
  return text + "'";
}

// The check before each hello compares what map.db holds of the installed selection (its
// elements, their sizes) with what the install recorded, reading no landmark byte, and still
// sees a map cut, grown or emptied. A byte changed in place at the same length shows on a forced
// read-back.
TEST(AgentLocalMapTest, AnInstalledMapIsCheckedByWhatItHoldsAndReadBackOnDemand) {
  const ScratchDir dir("fleetmap-agent-map");
  const GraphBatch& day = SharedMaps().day;
  SelectionDigest expected;
  expected.Add(day);
  LocalMap map = LocalMap::Open(dir / "robot");
  EXPECT_EQ(map.CheckInstalledDigest(false), 0u) << "nothing installed";
  map.Install(FullDownload(day, 3));

  // Right after the install, the last landmark byte of an installed node flipped in place: the
  // same sizes, so the check takes the install's record, and only a read-back sees it.
  const std::string node = BlobLiteral(day.nodes[1].id.ToBytesString());
  Node damaged = day.nodes[1];
  damaged.landmarks_blob.back() ^= 1;
  const std::string flipped_tail = BlobLiteral(
      std::string_view(damaged.landmarks_blob).substr(damaged.landmarks_blob.size() - 1));
  ChangeMapBehindTheAgent(map,
                          "UPDATE nodes SET landmarks = CAST(substr(landmarks, 1, "
                          "length(landmarks) - 1) || " +
                              flipped_tail + " AS BLOB) WHERE id = " + node);
  SelectionDigest with_damage = expected;
  with_damage.Remove(day.nodes[1]);
  with_damage.Add(damaged);
  ASSERT_EQ(map.ReadInstalledDigest(), with_damage.value()) << "the change did not take";
  EXPECT_EQ(map.CheckInstalledDigest(false), expected.value());
  EXPECT_EQ(map.CheckInstalledDigest(true), with_damage.value());
  // Content the robot built itself changes nothing.
  GraphStore::Open(map.map_uri())->Put(SharedMaps().night);
  EXPECT_EQ(map.CheckInstalledDigest(false), expected.value());

  // A byte more: the sizes differ, so the check reads back and gives the digest map.db holds.
  ChangeMapBehindTheAgent(
      map, "UPDATE nodes SET landmarks = CAST(landmarks || x'00' AS BLOB) WHERE id = " + node);
  const std::uint64_t grown = map.CheckInstalledDigest(false);
  EXPECT_NE(grown, expected.value());
  EXPECT_NE(grown, with_damage.value());
  // An installed edge gone, then everything.
  ChangeMapBehindTheAgent(
      map, "DELETE FROM edges WHERE id = " + BlobLiteral(day.edges[0].id.ToBytesString()));
  const std::uint64_t cut = map.CheckInstalledDigest(false);
  EXPECT_NE(cut, grown);
  ChangeMapBehindTheAgent(map, "DELETE FROM edges; DELETE FROM nodes; DELETE FROM paths;");
  EXPECT_EQ(map.CheckInstalledDigest(false), SelectionDigest().value());
}

// A state file written before failed submissions were kept (merged_revision 0 meant failed)
// reads as failed, so an upgrade does not drop what the old agent was about to drop.
TEST(AgentLocalMapTest, OldStateWithMergedRevisionZeroReadsAsFailed) {
  const ScratchDir dir("fleetmap-agent-map");
  Uuid submission;
  {
    LocalMap map = LocalMap::Open(dir / "robot");
    submission = PushDay(map);
  }
  std::string text = ReadText(dir / "robot" / "sync.json");
  const std::string from = "\"merged_revision\": null";
  ASSERT_NE(text.find(from), std::string::npos) << text;
  text.replace(text.find(from), from.size(), "\"merged_revision\": 0");
  WriteText(dir / "robot" / "sync.json", text);
  LocalMap map = LocalMap::Open(dir / "robot");
  ASSERT_EQ(map.state().unmerged.size(), 1u);
  EXPECT_TRUE(map.state().unmerged[0].failed);
  EXPECT_FALSE(map.state().unmerged[0].merged_revision);
}

TEST(AgentLocalMapTest, IncrementalDownloadOfNothingRewritesNoMap) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  map.Install(FullDownload(SharedMaps().day, 4));
  struct stat before {};
  ASSERT_EQ(::stat(map.map_path().c_str(), &before), 0);
  MapDownload nothing;
  nothing.revision = 6;
  nothing.base_revision = 4;
  nothing.nodes = SharedMaps().day.nodes.size();
  nothing.edges = SharedMaps().day.edges.size();
  nothing.paths = SharedMaps().day.paths.size();
  const InstallReport report = map.Install(nothing);
  EXPECT_TRUE(report.incremental);
  EXPECT_EQ(report.nodes, SharedMaps().day.nodes.size());
  struct stat after {};
  ASSERT_EQ(::stat(map.map_path().c_str(), &after), 0);
  EXPECT_EQ(before.st_ino, after.st_ino);  // the same file: not replaced
  EXPECT_EQ(map.state().revision, 6);
  EXPECT_EQ(LocalMap::Open(dir / "other").state().revision, 0);
  // Counts that disagree are refused here too.
  nothing.base_revision = 6;
  nothing.revision = 7;
  nothing.nodes += 1;
  ExpectError(
      ErrorCode::kCorrupt, [&] { map.Install(nothing); }, "header");
  EXPECT_EQ(map.state().revision, 6);
}

TEST(AgentLocalMapTest, LeftoverNewMapFromACrashIsDiscardedAndTheOldMapIntact) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  SyncState before;
  {
    LocalMap map = LocalMap::Open(robot);
    map.Install(FullDownload(SharedMaps().day, 1));
    before = map.state();
  }
  // Crashed while writing map.db.new (no state written for it yet).
  WriteText(robot / "map.db.new", "half a database");
  {
    LocalMap map = LocalMap::Open(robot);
    EXPECT_FALSE(fs::exists(robot / "map.db.new"));
    EXPECT_EQ(map.state(), before);
    EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().day));
    // And an install after it works.
    map.Install(FullDownload(SharedMaps().night, 2));
    EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().night));
    before = map.state();
  }
  // Crashed after writing the next state, before the map rename: both are discarded.
  fs::copy_file(robot / "map.db", robot / "map.db.new");
  WriteText(robot / "sync.json.next", "{\"format\": 1, \"revision\": 99}");
  {
    LocalMap map = LocalMap::Open(robot);
    EXPECT_FALSE(fs::exists(robot / "map.db.new"));
    EXPECT_FALSE(fs::exists(robot / "sync.json.next"));
    EXPECT_EQ(map.state(), before);
    EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(SharedMaps().night));
  }
}

TEST(AgentLocalMapTest, CrashBetweenMapRenameAndStateRenameRollsForward) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  std::string old_state;
  SyncState after;
  {
    LocalMap map = LocalMap::Open(robot);
    map.Install(FullDownload(SharedMaps().day, 1));
    old_state = ReadText(robot / "sync.json");
    map.Install(FullDownload(SharedMaps().night, 2));
    after = map.state();
  }
  // What the disk holds when the map rename happened and the state rename did not.
  fs::rename(robot / "sync.json", robot / "sync.json.next");
  WriteText(robot / "sync.json", old_state);
  LocalMap map = LocalMap::Open(robot);
  EXPECT_EQ(map.state(), after);
  EXPECT_FALSE(fs::exists(robot / "sync.json.next"));
  // Nothing the server sent is taken for local content.
  EXPECT_TRUE(map.Unsynced().nodes.empty());
  EXPECT_TRUE(map.Unsynced().edges.empty());
}

// An incremental install reads what it changes: the nodes leaving the selection (for the
// digest), not the map; and the digest it keeps is the one the map's content gives.
TEST(AgentLocalMapTest, AnIncrementalInstallReadsWhatItChangesNotTheMap) {
  const ScratchDir dir("fleetmap-agent-map");
  LocalMap map = LocalMap::Open(dir / "robot");
  const GraphBatch& day = SharedMaps().day;
  const GraphBatch& night = SharedMaps().night;
  MapDownload first = FullDownload(Join(day, night), 2);
  map.Install(first);
  const std::size_t map_nodes = day.nodes.size() + night.nodes.size();

  // Revision 3 drops two day nodes with their edges and adds a third outing.
  const GraphBatch third = CorridorRobotMap({{0, 10.0}});
  MapDownload next;
  next.revision = 3;
  next.base_revision = 2;
  next.request = first.request;
  next.content = third;
  GraphBatch expected = Join(Join(day, night), third);
  for (const Node& node : {day.nodes[3], day.nodes[7]}) next.removed.nodes.insert(node.id);
  for (const Edge& edge : day.edges) {
    if (next.removed.nodes.contains(edge.from) || next.removed.nodes.contains(edge.to)) {
      next.removed.edges.insert(edge.id);
    }
  }
  std::erase_if(expected.nodes, [&](const Node& n) { return next.removed.nodes.contains(n.id); });
  std::erase_if(expected.edges, [&](const Edge& e) { return next.removed.edges.contains(e.id); });
  next.nodes = expected.nodes.size();
  next.edges = expected.edges.size();
  next.paths = expected.paths.size();

  const InstallReport report = map.Install(next);
  EXPECT_LE(report.nodes_read, 2u) << "of a map of " << map_nodes << " nodes";
  EXPECT_EQ(IdsOf(ReadStore(map.map_uri())), IdsOf(expected));
  EXPECT_EQ(map.state().installed, IdsOf(expected));
  EXPECT_EQ(map.state().installed_digest, map.ReadInstalledDigest());
  EXPECT_EQ(report.selection_digest, map.state().installed_digest);
  SelectionDigest digest;
  digest.Add(expected);
  EXPECT_EQ(map.state().installed_digest, digest.value());
  EXPECT_TRUE(map.Unsynced().nodes.empty());
}

// An install in place interrupted after its transaction committed rolls forward; one whose
// transaction never committed leaves the map and the state as they were.
TEST(AgentLocalMapTest, AnInterruptedInstallInPlaceRollsForwardOnlyWhenItCommitted) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  std::string old_state;
  SyncState after;
  MapDownload next;
  {
    LocalMap map = LocalMap::Open(robot);
    const MapDownload first = FullDownload(SharedMaps().day, 1);
    map.Install(first);
    old_state = ReadText(robot / "sync.json");
    next.revision = 2;
    next.base_revision = 1;
    next.request = first.request;
    next.content = SharedMaps().night;
    next.nodes = first.nodes + SharedMaps().night.nodes.size();
    next.edges = first.edges + SharedMaps().night.edges.size();
    next.paths = first.paths + SharedMaps().night.paths.size();
    map.Install(next);
    after = map.state();
    ASSERT_FALSE(after.install_token.empty());
  }
  // Committed, not renamed: rolled forward.
  fs::rename(robot / "sync.json", robot / "sync.json.next");
  WriteText(robot / "sync.json", old_state);
  {
    LocalMap map = LocalMap::Open(robot);
    EXPECT_EQ(map.state(), after);
    EXPECT_FALSE(fs::exists(robot / "sync.json.next"));
  }
  // A next state whose transaction never committed (another token): dropped.
  std::string uncommitted = ReadText(robot / "sync.json");
  const std::size_t token = uncommitted.find(after.install_token);
  ASSERT_NE(token, std::string::npos);
  uncommitted.replace(token, after.install_token.size(), "not-the-one-in-map.db");
  WriteText(robot / "sync.json.next", uncommitted);
  LocalMap map = LocalMap::Open(robot);
  EXPECT_EQ(map.state(), after);
  EXPECT_FALSE(fs::exists(robot / "sync.json.next"));
}

nlohmann::json IdsJson(const IdSet& ids) {
  nlohmann::json list = nlohmann::json::array();
  for (const Uuid& id : ids) list.push_back(id.ToString());
  return list;
}

nlohmann::json ElementsJson(const ElementIds& ids) {
  return {
      {"nodes", IdsJson(ids.nodes)}, {"edges", IdsJson(ids.edges)}, {"paths", IdsJson(ids.paths)}};
}

// `state`'s sync.json (`text`) as an agent before the id tables wrote it: format 1, every set
// inline as a list of ids.
std::string WithIdsInline(const std::string& text, const SyncState& state) {
  nlohmann::json root = nlohmann::json::parse(text);
  root["format"] = 1;
  root.erase("ids_generation");
  root.erase("installed_count");
  root.erase("pushed_count");
  root["installed"] = ElementsJson(state.installed);
  root["pushed"] = ElementsJson(state.pushed);
  if (state.submission) {
    root["submission"] = {{"id", state.submission->id.ToString()},
                          {"content", ElementsJson(state.submission->content)}};
  }
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    root["unmerged"][i].erase("count");
    root["unmerged"][i]["content"] = ElementsJson(state.unmerged[i].content);
  }
  return root.dump(1);
}

// Rows of an agent table in `db`; -1 when the table does not exist.
long long CountRows(const fs::path& db, const std::string& table) {
  sqlite3* handle = nullptr;
  if (sqlite3_open(db.c_str(), &handle) != SQLITE_OK) return -1;
  sqlite3_stmt* s = nullptr;
  long long rows = -1;
  if (sqlite3_prepare_v2(handle, ("SELECT COUNT(*) FROM " + table).c_str(), -1, &s, nullptr) ==
          SQLITE_OK &&
      sqlite3_step(s) == SQLITE_ROW) {
    rows = sqlite3_column_int64(s, 0);
  }
  sqlite3_finalize(s);
  sqlite3_close(handle);
  return rows;
}

void ExecSql(const fs::path& db, const std::string& sql) {
  sqlite3* handle = nullptr;
  ASSERT_EQ(sqlite3_open(db.c_str(), &handle), SQLITE_OK);
  EXPECT_EQ(sqlite3_exec(handle, sql.c_str(), nullptr, nullptr, nullptr), SQLITE_OK)
      << sqlite3_errmsg(handle);
  sqlite3_close(handle);
}

// A sync.json an agent wrote before the sets moved into map.db (every set as a list of ids) is
// read once, its sets moved into map.db's tables, and rewritten without them; the state is the
// same before and after, and from then on comes from map.db.
TEST(AgentLocalMapTest, AStateWithItsIdsInSyncJsonIsMovedIntoMapDbOnce) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  SyncState before;
  {
    LocalMap map = LocalMap::Open(robot);
    map.Install(FullDownload(SharedMaps().night, 3));
    PushDay(map);
    GraphStore::Open(map.map_uri())->Put(CorridorRobotMap({{0, 10.0}}));
    map.BeginSubmission(map.Unsynced());
    map.RecordSyncError("link reset");
    before = map.state();
  }
  ASSERT_EQ(before.unmerged.size(), 1u);
  ASSERT_TRUE(before.submission.has_value());
  ASSERT_FALSE(before.installed.nodes.empty());
  ASSERT_FALSE(before.pushed.nodes.empty());
  // As the old agent left the directory: the sets in sync.json, none in map.db.
  WriteText(robot / "sync.json", WithIdsInline(ReadText(robot / "sync.json"), before));
  ExecSql(robot / "map.db", "DROP TABLE agent_ids; DROP TABLE agent_submission_ids;");
  const std::string node = SharedMaps().day.nodes[0].id.ToString();
  ASSERT_NE(ReadText(robot / "sync.json").find(node), std::string::npos);

  {
    // A reader before the move: the sets' sizes from the lists.
    const LocalMap reader = LocalMap::Open(robot, LocalMapAccess::kReadOnly);
    EXPECT_EQ(reader.counts(), CountsOf(before));
  }
  {
    LocalMap map = LocalMap::Open(robot);
    SyncState expected = before;
    expected.ids_generation = map.state().ids_generation;
    EXPECT_EQ(map.state(), expected);
    EXPECT_NE(map.state().ids_generation, before.ids_generation);
  }
  const std::string moved = ReadText(robot / "sync.json");
  EXPECT_EQ(moved.find(node), std::string::npos) << moved;
  EXPECT_EQ(nlohmann::json::parse(moved)["format"], 2);
  EXPECT_GT(CountRows(robot / "map.db", "agent_ids"), 0);
  EXPECT_GT(CountRows(robot / "map.db", "agent_submission_ids"), 0);
  // And from map.db from now on, with nothing left over.
  LocalMap map = LocalMap::Open(robot);
  SyncState expected = before;
  expected.ids_generation = map.state().ids_generation;
  EXPECT_EQ(map.state(), expected);
  EXPECT_EQ(ReadText(robot / "sync.json"), moved);
  const SyncStateCounts counts = CountsOf(before);
  EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"),
            static_cast<long long>(counts.submission.size() + counts.unmerged[0].size()));
}

// The sets live in map.db and sync.json says how large they are: a reader (status) learns the
// sizes without reading a set, however large, and sync.json stays small.
TEST(AgentLocalMapTest, AReaderLearnsTheSetsSizesWithoutReadingThem) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  constexpr std::size_t kIds = 50'000;
  ElementIds large;
  for (std::size_t i = 0; i < kIds; ++i) large.nodes.insert(Uuid::Generate());
  for (std::size_t i = 0; i < kIds / 2; ++i) large.edges.insert(Uuid::Generate());
  SyncState written;
  {
    LocalMap map = LocalMap::Open(robot);
    map.MarkPushed(map.BeginSubmission(large).id);
    written = map.state();
  }
  EXPECT_LT(fs::file_size(robot / "sync.json"), 4096u);
  const LocalMap reader = LocalMap::Open(robot, LocalMapAccess::kReadOnly);
  ASSERT_EQ(reader.state().unmerged.size(), 1u);
  EXPECT_EQ(reader.state().unmerged[0].content.size(), 0u);  // not read
  EXPECT_EQ(reader.state().pushed.size(), 0u);
  const SyncStateCounts counts = reader.counts();
  ASSERT_EQ(counts.unmerged.size(), 1u);
  EXPECT_EQ(counts.unmerged[0], (ElementCount{kIds, kIds / 2, 0}));
  EXPECT_EQ(counts.pushed, (ElementCount{kIds, kIds / 2, 0}));
  // The submission's ids are in map.db once (pushed is what the unmerged submissions carry).
  EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"),
            static_cast<long long>(kIds + kIds / 2));
  EXPECT_EQ(CountRows(robot / "map.db", "agent_ids"), 0);
  // A writer reads them all back.
  LocalMap map = LocalMap::Open(robot);
  EXPECT_EQ(map.state(), written);
}

// Ids map.db holds for a set sync.json does not name (a crash between writing a submission's
// ids and the state naming it, or an install's leftover generation) are deleted at the next
// open; and a map.db lost under a sync.json takes its submissions' ids with it, which Open tells
// apart from an empty submission.
TEST(AgentLocalMapTest, IdsTheStateDoesNotNameArePrunedAndLostOnesAreNoticed) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  SyncState before;
  {
    LocalMap map = LocalMap::Open(robot);
    map.Install(FullDownload(SharedMaps().night, 2));
    PushDay(map);
    before = map.state();
  }
  const long long submission_rows = CountRows(robot / "map.db", "agent_submission_ids");
  const long long set_rows = CountRows(robot / "map.db", "agent_ids");
  ExecSql(robot / "map.db",
          "INSERT INTO agent_submission_ids VALUES (x'00112233445566778899aabbccddeeff', 0, "
          "x'00112233445566778899aabbccddeef0');"
          "INSERT INTO agent_ids VALUES ('an-old-generation', 0, 0, "
          "x'00112233445566778899aabbccddeef0');");
  {
    LocalMap map = LocalMap::Open(robot);
    EXPECT_EQ(map.state(), before);
  }
  EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"), submission_rows);
  EXPECT_EQ(CountRows(robot / "map.db", "agent_ids"), set_rows);

  // map.db lost: the day submission's ids went with it. Starting over keeps no submission whose
  // content it cannot see whole (the restore brings it back from the server).
  for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(robot.string() + "/map.db" + suffix);
  LocalMap map = LocalMap::Open(robot);
  ASSERT_EQ(map.state().unmerged.size(), 1u);
  EXPECT_EQ(map.state().revision, 2);
  map.ForgetServerCopy(Uuid::Generate());
  EXPECT_TRUE(map.state().unmerged.empty());
  EXPECT_TRUE(map.state().restore_own_work);
}

// The ids of a submission a sync stages before its hello (StageSubmission) are nobody's until
// BeginSubmission records it: a sync that stops in between leaves rows the next Open deletes;
// one recorded reads back as pending, its ids written once.
TEST(AgentLocalMapTest, AStagedSubmissionIsPendingOnceBegunAndPrunedIfNever) {
  const ScratchDir dir("fleetmap-agent-map");
  const fs::path robot = dir / "robot";
  const ElementIds day = IdsOf(SharedMaps().day);
  {
    LocalMap map = LocalMap::Open(robot);
    GraphStore::Open(map.map_uri())->Put(SharedMaps().day);
    map.StageSubmission(IdsOf(map.Unsynced()));  // and never begun
  }
  EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"),
            static_cast<long long>(day.size()));
  Uuid id;
  {
    LocalMap map = LocalMap::Open(robot);
    EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"), 0);
    const ElementIds content = IdsOf(map.Unsynced());
    const Uuid staged = map.StageSubmission(content);
    ExpectError(ErrorCode::kInvalidArgument,
                [&] { map.BeginSubmission(content, Uuid::Generate()); });
    id = map.BeginSubmission(content, staged).id;
    EXPECT_EQ(id, staged);
  }
  LocalMap map = LocalMap::Open(robot);
  ASSERT_TRUE(map.state().submission.has_value());
  EXPECT_EQ(map.state().submission->id, id);
  EXPECT_EQ(map.state().submission->content, day);
  EXPECT_EQ(CountRows(robot / "map.db", "agent_submission_ids"),
            static_cast<long long>(day.size()));
}

}  // namespace
}  // namespace fleetmap
