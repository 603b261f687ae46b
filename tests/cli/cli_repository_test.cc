// The repository commands of `fleetmap` (init, push, submissions, merge, log, checkout, diff,
// download, revert, dream, retire; seed 004 §IV–§VI) end to end: the built executable run as a
// subprocess against real stores, with robot maps built by the EBN builder on the
// two-condition corridor. Bad input must exit non-zero, say what was wrong, and change nothing.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "corridor_robot_map.h"
#include "fleetmap/map_management/held_out_replay.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/repository/repository.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap_cli_run.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using RunResult = testing::CliRun;

using testing::Contains;
using testing::DescribeCliRun;
using testing::ReadWholeFile;

using testing::RunCli;

// A robot's map of the given corridor outings (0: day, 1: night), built into a new SQLite
// store at `file`, as the robot would keep it.
void BuildRobotMap(const std::filesystem::path& file, const std::vector<int>& conditions) {
  std::vector<CorridorOuting> outings;
  for (const int condition : conditions) outings.push_back({condition});
  BuildCorridorRobotMap(*GraphStore::Open("sqlite:" + file.string()), outings);
}

// The robot maps every test pushes, built once per process.
struct RobotMaps {
  ScratchDir dir{"fleetmap-cli-maps"};
  std::string day, night, both;  // sqlite URIs
  RobotMaps() {
    BuildRobotMap(dir / "day.db", {0});
    BuildRobotMap(dir / "night.db", {1});
    BuildRobotMap(dir / "both.db", {0, 1});
    day = "sqlite:" + (dir / "day.db").string();
    night = "sqlite:" + (dir / "night.db").string();
    both = "sqlite:" + (dir / "both.db").string();
  }
};
const RobotMaps& Maps() {
  static const RobotMaps maps;
  return maps;
}

std::int64_t NodesIn(const std::string& uri) {
  return GraphStore::Open(uri)->Stats().nodes;
}

class CliRepositoryTest : public testing::FleetmapCliTest {
 protected:
  CliRepositoryTest() : FleetmapCliTest("fleetmap-cli-test") {}

  nlohmann::json Json(std::vector<std::string> args) {
    args.push_back("--json");
    const RunResult r = RunOn(args);
    return nlohmann::json::parse(r.out);
  }
  // Everything the repository records, as its own commands print it.
  std::string Snapshot() {
    return RunOn({"log", "--json"}).out + RunOn({"submissions", "--json"}).out;
  }

  // Pushes the day and night robot maps and merges both: revisions 1 and 2.
  void PushAndMergeDayAndNight() {
    RunOn({"init"});
    RunOn({"push", "--map", Maps().day, "--robot", robot_day_, "--author", "robot-day", "--id",
           day_});
    RunOn({"push", "--map", Maps().night, "--robot", robot_night_, "--author", "robot-night",
           "--id", night_});
    RunOn({"merge", "--all"});
  }

  const std::string day_ = Uuid::Generate().ToString();
  const std::string night_ = Uuid::Generate().ToString();
  const std::string robot_day_ = Uuid::Generate().ToString();
  const std::string robot_night_ = Uuid::Generate().ToString();
};

TEST_F(CliRepositoryTest, InitPushMergeLogCheckoutDiffDownloadRevertDreamOnSqlite) {
  const RunResult init = RunOn({"init"});
  EXPECT_TRUE(Contains(init.out, "repository " + store_)) << init.out;
  EXPECT_TRUE(Contains(init.out, "head revision  0")) << init.out;
  EXPECT_TRUE(std::regex_search(init.out, std::regex("schema version [0-9]+"))) << init.out;

  // Push two robot maps: day, then night.
  const RunResult push = RunOn(
      {"push", "--map", Maps().day, "--robot", robot_day_, "--author", "robot-day", "--id", day_});
  EXPECT_TRUE(Contains(push.out, "submission " + day_)) << push.out;
  EXPECT_TRUE(Contains(push.out, "queued")) << push.out;
  EXPECT_TRUE(std::regex_search(push.out, std::regex("[1-9][0-9]* nodes"))) << push.out;
  RunOn({"push", "--map", Maps().night, "--robot", robot_night_, "--author", "robot-night", "--id",
         night_});

  const RunResult listed = RunOn({"submissions"});
  EXPECT_TRUE(Contains(listed.out, day_) && Contains(listed.out, night_)) << listed.out;
  EXPECT_TRUE(Contains(listed.out, "robot-night")) << listed.out;
  nlohmann::json submissions = Json({"submissions"});
  ASSERT_EQ(submissions.size(), 2u);
  EXPECT_EQ(submissions[0]["id"], day_);  // in the order received
  EXPECT_EQ(submissions[1]["state"], "queued");
  EXPECT_GT(submissions[1]["bytes"].get<std::int64_t>(), 0);
  EXPECT_TRUE(std::regex_match(submissions[0]["received"].get<std::string>(),
                               std::regex("\\d{4}-\\d\\d-\\d\\dT\\d\\d:\\d\\d:\\d\\dZ")));

  // MERGE every queued submission in the order received: revisions 1 and 2.
  const RunResult merged = RunOn({"merge", "--all"});
  EXPECT_TRUE(Contains(merged.out, day_ + " -> revision 1")) << merged.out;
  EXPECT_TRUE(Contains(merged.out, night_ + " -> revision 2")) << merged.out;
  EXPECT_TRUE(Contains(merged.out, "segments")) << merged.out;
  const RunResult again = RunOn({"merge", night_});
  EXPECT_TRUE(Contains(again.out, "already merged as revision 2")) << again.out;
  EXPECT_TRUE(Contains(RunOn({"merge", "--all"}).out, "nothing to merge"));

  const RunResult log = RunOn({"log"});
  EXPECT_TRUE(Contains(log.out, "submission " + night_)) << log.out;
  nlohmann::json history = Json({"log"});
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0]["author"], "robot-day");
  EXPECT_EQ(history[1]["kind"], "merge");
  EXPECT_EQ(history[1]["submission"], night_);
  const std::int64_t night_nodes = history[1]["added"]["nodes"].get<std::int64_t>();
  EXPECT_GT(night_nodes, 0);  // the night looks like nothing the day map holds
  EXPECT_EQ(history[1]["report"]["nodes_added"].get<std::int64_t>(), night_nodes);

  // Checkout of the head into a new store holds exactly the repository's map.
  std::int64_t head_nodes = 0, revision_1_nodes = 0;
  {
    const auto repository = Repository::Open(store_);
    head_nodes = static_cast<std::int64_t>(repository->Checkout().nodes.size());
    revision_1_nodes = static_cast<std::int64_t>(repository->Checkout(1).nodes.size());
  }
  const std::string checkout = "sqlite:" + (dir_ / "checkout.db").string();
  const RunResult out = RunOn({"checkout", "--out", checkout});
  EXPECT_TRUE(Contains(out.out, "checked out revision 2")) << out.out;
  EXPECT_EQ(NodesIn(checkout), head_nodes);
  const std::string checkout_1 = "sqlite:" + (dir_ / "checkout-1.db").string();
  RunOn({"checkout", "--revision", "1", "--out", checkout_1});
  EXPECT_EQ(NodesIn(checkout_1), revision_1_nodes);

  const RunResult diff = RunOn({"diff", "1", "2"});
  EXPECT_TRUE(Contains(diff.out, "nodes  +" + std::to_string(night_nodes) + " -0")) << diff.out;
  nlohmann::json changes = Json({"diff", "1", "2"});
  EXPECT_EQ(static_cast<std::int64_t>(changes["added"]["nodes"].size()), night_nodes);
  EXPECT_TRUE(changes["removed"]["nodes"].empty());

  // DOWNLOAD: the whole map, and by time of day around a mission at 00:01 UTC (the corridor's
  // stamps are the first two minutes after midnight), and one at noon, which keeps nothing.
  const std::string copy = "sqlite:" + (dir_ / "copy.db").string();
  const RunResult copied = RunOn({"download", "--policy", "copy", "--out", copy});
  EXPECT_TRUE(Contains(copied.out, "download \"copy\"")) << copied.out;
  EXPECT_EQ(NodesIn(copy), head_nodes);
  const std::string tod = "sqlite:" + (dir_ / "tod.db").string();
  nlohmann::json report = Json({"download", "--policy", "tod", "--mission-start", "00:01",
                                "--window-min", "60", "--out", tod});
  EXPECT_EQ(report["policy"], "tod");
  EXPECT_EQ(report["nodes"].get<std::int64_t>(), head_nodes);
  EXPECT_EQ(NodesIn(tod), head_nodes);
  const std::string noon = "sqlite:" + (dir_ / "noon.db").string();
  const RunResult at_noon = RunOn({"download", "--policy", "tod+paths", "--mission-start", "12:00",
                                   "--window-min", "60", "--out", noon});
  EXPECT_TRUE(Contains(at_noon.out, "nodes      0 picked")) << at_noon.out;
  EXPECT_EQ(NodesIn(noon), 0);
  const std::string paths = "sqlite:" + (dir_ / "paths.db").string();
  report = Json({"download", "--policy", "tod+paths", "--mission-start", "00:01", "--revision", "2",
                 "--out", paths});
  EXPECT_GT(NodesIn(paths), 0);
  EXPECT_LE(NodesIn(paths), head_nodes);
  EXPECT_EQ(report["nodes"].get<std::int64_t>(), NodesIn(paths));

  // Revert revision 2: the night is hidden, and the log shows it.
  const RunResult reverted = RunOn({"revert", "2", "--author", "operator"});
  EXPECT_TRUE(Contains(reverted.out, "revision 3 reverts revision 2")) << reverted.out;
  EXPECT_TRUE(Contains(reverted.out, "hid " + std::to_string(night_nodes) + " nodes"))
      << reverted.out;
  history = Json({"log"});
  ASSERT_EQ(history.size(), 3u);
  EXPECT_EQ(history[2]["kind"], "revert");
  EXPECT_EQ(history[2]["reverted"], 2);
  EXPECT_EQ(history[2]["author"], "operator");
  EXPECT_EQ(history[2]["hidden"]["nodes"].get<std::int64_t>(), night_nodes);
  EXPECT_TRUE(Contains(RunOn({"log"}).out, "revert  revision 2"));

  // Dreaming over the two submissions, judged by a third robot's map of both conditions.
  const std::string held_out = Uuid::Generate().ToString();
  RunOn({"push", "--map", Maps().both, "--robot", Uuid::Generate().ToString(), "--id", held_out});
  const std::string best = "sqlite:" + (dir_ / "dream.db").string();
  const RunResult dream = RunOn({"dream", "--groups", day_ + "," + night_, "--held-out", held_out,
                                 "--group-seconds", "100", "--out", best});
  const std::string& text = dream.out;
  EXPECT_TRUE(Contains(text, "2 of 2! orders")) << text;
  EXPECT_TRUE(std::regex_search(text, std::regex("\n0 1 +[0-9.]+ ")) &&
              std::regex_search(text, std::regex("\n1 0 +[0-9.]+ ")))
      << text;
  EXPECT_TRUE(std::regex_search(text, std::regex("best order: (0 1|1 0) "))) << text;
  EXPECT_TRUE(Contains(text, "T_M mean")) << text;
  EXPECT_TRUE(Contains(text, "Eq. 8: with T_G = 100.0 s")) << text;
  EXPECT_GT(NodesIn(best), 0);
  // Dreaming only reads the repository.
  EXPECT_EQ(Json({"log"}).size(), 3u);
}

// Bytes below 0x20 (but the newline ending each line) and DEL: what a terminal acts on.
std::string ControlBytesIn(const std::string& text) {
  std::string found;
  for (const char c : text) {
    const auto byte = static_cast<unsigned char>(c);
    if ((byte < 0x20 && c != '\n') || byte == 0x7f) found += std::to_string(byte) + " ";
  }
  return found;
}

std::size_t LinesIn(const std::string& text) {
  return static_cast<std::size_t>(std::count(text.begin(), text.end(), '\n'));
}

// An author with a newline and an escape sequence (stored as given) cannot
// forge a row of `fleetmap log` or `submissions`, nor clear the terminal: every table prints
// it escaped on its own row, as do push, merge and revert; --json keeps it as it is.
TEST_F(CliRepositoryTest, AnAuthorWithControlCharactersCannotForgeATableRow) {
  const std::string author = "eve\n3 | merge | forged\x1b[2J";
  const std::string printed = "eve\\n3 | merge | forged\\x1b[2J";
  RunOn({"init"});
  const RunResult push =
      RunOn({"push", "--map", Maps().day, "--robot", robot_day_, "--author", author, "--id", day_});
  RunOn({"push", "--map", Maps().night, "--robot", robot_night_, "--author", "robot-night", "--id",
         night_});
  const RunResult merge = RunOn({"merge", "--all"});
  const RunResult revert = RunOn({"revert", "1", "--author", author});
  const RunResult log = RunOn({"log"});
  const RunResult submissions = RunOn({"submissions"});
  for (const RunResult* r : {&push, &merge, &revert, &log, &submissions}) {
    EXPECT_EQ(ControlBytesIn(r->out), "") << r->out;
  }
  EXPECT_TRUE(Contains(push.out, printed)) << push.out;
  EXPECT_TRUE(Contains(revert.out, printed)) << revert.out;
  EXPECT_EQ(LinesIn(log.out), 1u + 3u) << log.out;  // the header, two merges and the revert
  EXPECT_EQ(LinesIn(submissions.out), 1u + 2u) << submissions.out;
  EXPECT_TRUE(Contains(log.out, printed)) << log.out;
  EXPECT_TRUE(Contains(submissions.out, printed)) << submissions.out;
  EXPECT_EQ(Json({"log"})[0]["author"], author);
  EXPECT_EQ(Json({"submissions"})[0]["author"], author);
}

// `fleetmap promote` refuses a candidate that only ties the order the
// server merged (two submissions: one group, one order, the merged one), giving both scores
// and the way round; --force promotes it.
TEST_F(CliRepositoryTest, PromoteRefusesACandidateThatDoesNotBeatTheMergedOrderWithoutForce) {
  PushAndMergeDayAndNight();
  const nlohmann::json candidate = Json({"dream-now"});
  ASSERT_TRUE(candidate.contains("id")) << candidate.dump();
  const std::string id = candidate["id"].get<std::string>();
  const RunResult refused = RunOn({"promote", id}, /*succeed=*/false);
  EXPECT_TRUE(Contains(refused.err, "cannot promote " + id)) << refused.err;
  EXPECT_TRUE(Contains(refused.err, "does not beat the order the server merged")) << refused.err;
  EXPECT_TRUE(std::regex_search(refused.err, std::regex("([0-9.]+) vs \\1"))) << refused.err;
  EXPECT_TRUE(Contains(refused.err, "--force")) << refused.err;
  EXPECT_EQ(Json({"log"}).size(), 2u) << "nothing promoted";
  const RunResult forced = RunOn({"promote", id, "--force", "--author", "operator"});
  EXPECT_TRUE(Contains(forced.out, "revision 3 promotes dream candidate " + id)) << forced.out;
  EXPECT_TRUE(Contains(RunOn({"promote", "--help"}).out, "--force"));
}

TEST_F(CliRepositoryTest, BadInputExitsNonZeroNamesTheProblemAndChangesNothing) {
  PushAndMergeDayAndNight();
  const std::string before = Snapshot();
  const std::string out = "sqlite:" + (dir_ / "out.db").string();
  const auto refused = [&](const std::vector<std::string>& args,
                           const std::vector<std::string>& mentions) {
    std::vector<std::string> with_store = args;
    with_store.push_back("--store");
    with_store.push_back(store_);
    const RunResult r = Run(with_store, /*succeed=*/false);
    for (const std::string& mention : mentions) {
      EXPECT_TRUE(Contains(r.err, mention)) << "should mention '" << mention << "'\n"
                                            << DescribeCliRun(with_store, r);
    }
    EXPECT_FALSE(std::filesystem::exists(dir_ / "out.db")) << DescribeCliRun(with_store, r);
  };

  // An unknown submission: nothing merged, not even the known one named before it.
  const std::string unknown = Uuid::Generate().ToString();
  refused({"merge", day_, unknown}, {"no submission " + unknown});
  refused({"merge", "not-a-uuid"}, {"'not-a-uuid' is not a UUID"});
  refused({"dream", "--groups", day_ + "," + unknown, "--held-out", night_}, {unknown});
  // Revisions out of range.
  refused({"checkout", "--revision", "9", "--out", out}, {"no revision 9", "0", "2 (the head)"});
  refused({"diff", "1", "9"}, {"no revision 9"});
  refused({"revert", "9"}, {"no revision 9"});
  refused({"download", "--policy", "copy", "--revision", "-1", "--out", out}, {"no revision -1"});
  // Bad policies and mission times.
  refused({"download", "--policy", "fastest", "--mission-start", "08:00", "--out", out},
          {"\"fastest\""});
  refused({"download", "--policy", "tod", "--mission-start", "25:00", "--out", out},
          {"--mission-start '25:00'", "HH:MM"});
  refused({"download", "--policy", "tod", "--mission-start", "noon", "--out", out},
          {"--mission-start 'noon'"});
  refused({"download", "--policy", "tod", "--out", out}, {"--mission-start"});
  // An --out store that already holds a map is never written into.
  const std::int64_t day_nodes = NodesIn(Maps().day);
  refused({"checkout", "--out", Maps().day}, {"--out " + Maps().day, "already holds a map"});
  refused({"download", "--policy", "copy", "--out", Maps().day}, {"already holds a map"});
  EXPECT_EQ(NodesIn(Maps().day), day_nodes);
  // A --map file that is not a database.
  const std::filesystem::path text = dir_ / "notes.txt";
  std::ofstream(text) << "not a map store\n";
  refused({"push", "--map", "sqlite:" + text.string(), "--robot", robot_day_},
          {"--map sqlite:" + text.string()});
  EXPECT_EQ(ReadWholeFile(text), "not a map store\n");
  refused({"push", "--map", "sqlite:" + (dir_ / "missing.db").string(), "--robot", robot_day_},
          {"missing.db"});
  EXPECT_FALSE(std::filesystem::exists(dir_ / "missing.db"));
  refused({"push", "--map", Maps().day, "--robot", "robot-7"}, {"--robot 'robot-7'"});
  // A retirement needs a clock it can read; one with nothing unused that long writes nothing.
  refused({"retire", "--now", "yesterday"}, {"--now 'yesterday'", "ISO 8601"});
  const RunResult nothing = RunOn({"retire", "--retire-after", "36500"});
  EXPECT_TRUE(Contains(nothing.out, "nothing to retire at revision 2")) << nothing.out;

  EXPECT_EQ(Snapshot(), before);
  // A repository that does not exist is not created by reading it.
  const RunResult missing =
      Run({"log", "--store", "sqlite:" + (dir_ / "nowhere.db").string()}, /*succeed=*/false);
  EXPECT_TRUE(Contains(missing.err, "fleetmap init")) << missing.err;
  EXPECT_FALSE(std::filesystem::exists(dir_ / "nowhere.db"));
}

// A robot's map must already be a fleetmap store. An empty file given as --map (a map never
// written, a copy cut short) was opened as a new store, created and migrated, and the push then
// failed for want of nodes with the file grown to a whole empty store. It must be refused as
// it is and stay 0 bytes; so must an SQLite database of something else.
TEST_F(CliRepositoryTest, PushRefusesAnEmptyMapFileAndLeavesItEmpty) {
  RunOn({"init"});
  const std::string before = Snapshot();
  const std::filesystem::path empty = dir_ / "empty.db";
  std::ofstream(empty).close();
  const std::string map = "sqlite:" + empty.string();
  const std::vector<std::string> args = {"push",     "--map",   map,   "--robot",
                                         robot_day_, "--store", store_};
  const RunResult r = RunCli(dir_, args);
  EXPECT_NE(r.exit_code, 0) << DescribeCliRun(args, r);
  EXPECT_TRUE(Contains(r.err, "fleetmap: ")) << DescribeCliRun(args, r);
  EXPECT_TRUE(Contains(
      r.err, "--map " + map + " is not a fleetmap map store (empty file); nothing was pushed"))
      << DescribeCliRun(args, r);
  EXPECT_EQ(std::filesystem::file_size(empty), 0u);
  EXPECT_FALSE(std::filesystem::exists(empty.string() + "-wal"));
  EXPECT_FALSE(std::filesystem::exists(empty.string() + "-journal"));

  // An SQLite database that holds something else: refused, byte for byte as it was.
  const std::filesystem::path other = dir_ / "other.db";
  {
    sqlite3* db = nullptr;
    ASSERT_EQ(sqlite3_open(other.c_str(), &db), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(db, "CREATE TABLE notes (text TEXT); INSERT INTO notes VALUES ('hi')",
                           nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(db);
  }
  const std::string other_bytes = ReadWholeFile(other);
  const std::vector<std::string> other_args = {
      "push", "--map", "sqlite:" + other.string(), "--robot", robot_day_, "--store", store_};
  const RunResult o = RunCli(dir_, other_args);
  EXPECT_NE(o.exit_code, 0) << DescribeCliRun(other_args, o);
  EXPECT_TRUE(Contains(o.err, "is not a fleetmap map store (an SQLite database without"))
      << DescribeCliRun(other_args, o);
  EXPECT_TRUE(ReadWholeFile(other) == other_bytes) << "refusing " << other << " changed it";
  EXPECT_EQ(Snapshot(), before);
}

TEST_F(CliRepositoryTest, DreamingBeforeAnyMergeTrainsAVocabularyAndStoresNothing) {
  RunOn({"init"});
  const std::string held_out = Uuid::Generate().ToString();
  RunOn({"push", "--map", Maps().day, "--robot", robot_day_, "--id", day_});
  RunOn({"push", "--map", Maps().night, "--robot", robot_night_, "--id", night_});
  RunOn({"push", "--map", Maps().both, "--robot", robot_day_, "--id", held_out});
  const std::string before = Snapshot();
  const nlohmann::json dream =
      Json({"dream", "--groups", night_ + "," + day_, "--held-out", held_out, "--max-orders", "1"});
  ASSERT_EQ(dream["orders"].size(), 1u);
  EXPECT_EQ(dream["orders"][0]["frames"], NodesIn(Maps().both));
  EXPECT_EQ(dream["orders"][0]["nodes"], NodesIn(Maps().day) + NodesIn(Maps().night));
  EXPECT_EQ(Snapshot(), before);
  const auto repository = Repository::Open(store_);
  EXPECT_FALSE(repository->versions().FindSetting("appearance.vocabulary").has_value());
}

TEST_F(CliRepositoryTest, PushMergeLogOnPostgres) {
  if (auto why = testing::PostgresBackend::Unavailable()) GTEST_SKIP() << *why;
  testing::PostgresBackend backend;
  store_ = backend.Uri();
  const RunResult init = RunOn({"init"});
  EXPECT_TRUE(Contains(init.out, "head revision  0")) << init.out;
  PushAndMergeDayAndNight();
  nlohmann::json history = Json({"log"});
  ASSERT_EQ(history.size(), 2u);
  EXPECT_EQ(history[0]["submission"], day_);
  EXPECT_EQ(history[1]["submission"], night_);
  EXPECT_GT(history[1]["added"]["nodes"].get<std::int64_t>(), 0);
  const nlohmann::json submissions = Json({"submissions"});
  ASSERT_EQ(submissions.size(), 2u);
  EXPECT_EQ(submissions[1]["state"], "merged");
  EXPECT_EQ(submissions[1]["revision"], 2);
  EXPECT_TRUE(Contains(RunOn({"merge", day_}).out, "already merged as revision 1"));
}

// The scorer `fleetmap dream` ranks candidate maps by (policies/held_out_replay.h): a robot map
// of a day and a night outing, replayed against a day-only map, localises by day only.
TEST(HeldOutReplayTest, ScoresAMapByHowFarHeldOutOutingsTravelUnlocalised) {
  const auto read = [](const std::string& uri) { return GraphStore::Open(uri)->ReadMap(); };
  const GraphBatch day = read(Maps().day), both = read(Maps().both);
  const std::vector<HeldOutOuting> outings = HeldOutOutings(both);
  ASSERT_EQ(outings.size(), 2u);
  EXPECT_LE(outings[0].frames.front().stamp_ns, outings[1].frames.front().stamp_ns);
  // Consecutive nodes are joined by the robot's metric edges: the replay moves between them.
  EXPECT_GT(outings[0].frames[1].prev_T_this.translation().norm(), 1.0);

  const ExperienceMap day_map =
      ExperienceMap::FromGraph(day.nodes, day.edges, SharedCorridorVocabulary());
  const ExperienceMap both_map =
      ExperienceMap::FromGraph(both.nodes, both.edges, SharedCorridorVocabulary());
  const HeldOutReplay by_day = ReplayHeldOut(day_map, outings);
  const HeldOutReplay by_both = ReplayHeldOut(both_map, outings);
  EXPECT_EQ(by_day.outings, 2u);
  EXPECT_EQ(by_day.frames, both.nodes.size());
  EXPECT_EQ(by_day.gaps_m.size(), by_day.frames);
  EXPECT_EQ(by_both.localised_frames, by_both.frames);  // it holds every held-out view
  EXPECT_EQ(by_both.ProbabilityGapExceeds(10.0), 0.0);
  // The night outing finds nothing in the day map: about half the frames stay unlocalised and
  // their visual odometry runs on past 10 m.
  EXPECT_NEAR(by_day.FractionNotLocalised(), 0.5, 0.1);
  EXPECT_GT(by_day.ProbabilityGapExceeds(10.0), 0.2);
  EXPECT_GT(HeldOutScore(by_day), HeldOutScore(by_both));
  // Equal P: the share not localised decides, without reordering different P.
  HeldOutReplay fewer = by_both, more = by_both;
  more.localised_frames = more.frames / 2;
  EXPECT_LT(HeldOutScore(fewer), HeldOutScore(more));
  EXPECT_LT(HeldOutScore(more), HeldOutScore(by_day));
}

}  // namespace
}  // namespace fleetmap
