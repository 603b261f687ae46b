// Every text a robot sends in its hello (its agent's name, the channel it reports, its last
// error, the revision it says it runs) and in a push (its author), through a real fleetmapd on
// both stores, read back by a real `fleetmap robot list` and `fleetmap submissions` (JSON and
// table), /metrics, the status page and fleetmapd's log: whatever the
// robot sent, each output is valid UTF-8, parses, has one line per record, and shows C1
// controls and bidirectional overrides as escapes. Texts long enough that the server's caps
// fall inside a character, from several seeds.
#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <regex>
#include <sstream>

#include "fleet_processes.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap_cli_run.h"
#include "http_get.h"
#include "raw_sync_client.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap::testing {
namespace {

// Valid UTF-8 (what protobuf lets a client send in a string), drawn from pieces that break
// naive output: multi-byte characters a byte cap cuts, C0 and C1 controls, bidirectional
// overrides, line separators, quotes and markup.
std::string HostileText(std::mt19937& random, std::size_t at_least) {
  static const char* const kPieces[] = {
      "\u20ac", "\u00e9",     "\U0001F916", "\u0085", "\u009b[2J", "\u202e", "\u2066",
      "\u2028", "\n",         "\r",         "\x1b",   "\"",        "\\",     "</td><script>",
      "&amp;",  "robot-name", " ",          "{",      "}",         "'"};
  std::string text;
  while (text.size() < at_least) text += kPieces[random() % std::size(kPieces)];
  return text;
}

std::vector<std::string> Lines(const std::string& text) {
  std::vector<std::string> lines;
  std::istringstream in(text);
  for (std::string line; std::getline(in, line);) lines.push_back(line);
  return lines;
}

// No raw character a reader would not see, line by line: C0 (but the line feeds between lines)
// and C1 controls, line separators, bidirectional overrides; and valid UTF-8.
bool ShowsEverything(const std::string& text) {
  for (const std::string& line : Lines(text)) {
    std::string backslashes_doubled;
    for (const char c : line)
      backslashes_doubled += c == '\\' ? std::string("\\\\") : std::string(1, c);
    if (!IsValidUtf8(line) || PrintableText(line) != backslashes_doubled) return false;
  }
  return true;
}

template <typename Backend>
class HostileTextTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (std::optional<std::string> why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmap-hostile-text"};
};
TYPED_TEST_SUITE(HostileTextTest, StoreBackends, BackendNames);

// The status page holds its own inline script and no other: nothing a robot said became one.
bool HasOnlyItsOwnScript(const std::string& page) {
  const std::size_t script = page.find("<script");
  return script != std::string::npos && page.find("<script", script + 1) == std::string::npos;
}

TYPED_TEST(HostileTextTest, EveryOutputOfARobotsTextsIsValidAndOneLinePerRecord) {
  const std::string uri = this->backend_.Uri();
  GraphStore::Open(uri);
  const TestRobot robot = RegisterRobot(uri, "scout", this->dir_ / "scout");
  const TestRobot other = RegisterRobot(uri, "other", this->dir_ / "other");
  Fleetmapd server = StartFleetmapd(uri, this->dir_ / "fleetmapd.log", {"--http", "127.0.0.1:0"});
  ASSERT_FALSE(server.address.empty());
  const std::optional<std::string> http_line =
      server.process->ReadLineContaining("http on", std::chrono::milliseconds(10'000));
  ASSERT_TRUE(http_line);
  const std::string http = http_line->substr(http_line->rfind(' ') + 1);

  for (const unsigned seed : {1u, 2u, 3u, 4u, 5u, 6u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    std::mt19937 random(seed);
    v1::SyncFrame hello;
    hello.mutable_hello()->set_protocol_version(kSyncProtocolVersion);
    hello.mutable_hello()->set_robot_id(robot.id.ToBytesString());
    hello.mutable_hello()->set_token(robot.token);
    hello.mutable_hello()->set_agent(HostileText(random, 300));
    v1::InstalledMap& installed = *hello.mutable_hello()->mutable_installed();
    // Past the caps (64 bytes a channel, 500 an error) by a little, so they cut characters.
    installed.set_channel(HostileText(random, 60 + random() % 10));
    installed.set_last_error(HostileText(random, 490 + random() % 20));
    installed.set_revision(seed % 2 == 0 ? std::numeric_limits<std::int64_t>::max()
                                         : static_cast<std::int64_t>(random() % 5));
    installed.set_digest(random());
    {
      RawSyncClient client(server.address);
      ASSERT_TRUE(client.Send(hello));
      const std::optional<v1::SyncFrame> welcome = client.Receive();
      ASSERT_TRUE(welcome && welcome->has_welcome()) << server.Log();
      // A push whose author is hostile too (longer than the server keeps).
      v1::SyncFrame begin;
      begin.mutable_push_begin()->set_submission_id(Uuid::Generate().ToBytesString());
      begin.mutable_push_begin()->set_author(HostileText(random, 120 + random() % 20));
      begin.mutable_push_begin()->set_chunk_count(1);
      begin.mutable_push_begin()->set_total_bytes(10);
      ASSERT_TRUE(client.Send(begin));
      const std::optional<v1::SyncFrame> ready = client.Receive();
      ASSERT_TRUE(ready && ready->has_push_ready()) << server.Log();
      v1::SyncFrame bye;
      bye.mutable_bye();
      client.Send(bye);
    }
    for (const bool as_json : {true, false}) {
      std::vector<std::string> args = {"submissions", "--store", uri};
      if (as_json) args.push_back("--json");
      const CliRun listed = RunFleetmapCli(this->dir_.path(), args);
      ASSERT_EQ(listed.exit_code, 0) << listed.err;
      EXPECT_TRUE(ShowsEverything(listed.out)) << listed.out;
      if (as_json) {
        EXPECT_EQ(nlohmann::json::parse(listed.out).size(), seed);
      } else {
        EXPECT_EQ(Lines(listed.out).size(), 1 + seed) << "a header and one line a submission";
      }
    }

    const CliRun json =
        RunFleetmapCli(this->dir_.path(), {"robot", "list", "--json", "--store", uri});
    ASSERT_EQ(json.exit_code, 0) << json.err;
    ASSERT_TRUE(ShowsEverything(json.out)) << json.out;
    const nlohmann::json robots = nlohmann::json::parse(json.out);
    ASSERT_EQ(robots.size(), 2u);
    for (const nlohmann::json& entry : robots) {
      if (entry["name"] != "scout") continue;
      EXPECT_FALSE(entry["last_error"].get<std::string>().empty());
      if (installed.revision() == std::numeric_limits<std::int64_t>::max()) {
        EXPECT_TRUE(entry["behind"].is_null()) << entry.dump();
        EXPECT_EQ(entry["map_differs"], true);
      }
    }

    const CliRun table = RunFleetmapCli(this->dir_.path(), {"robot", "list", "--store", uri});
    ASSERT_EQ(table.exit_code, 0) << table.err;
    EXPECT_EQ(Lines(table.out).size(), 3u) << "a header and one line a robot:\n" << table.out;
    EXPECT_TRUE(ShowsEverything(table.out)) << table.out;

    // The status refreshes every few seconds; each snapshot is checked as it comes.
    const std::string metrics = HttpGet(http, "/metrics");
    EXPECT_TRUE(ShowsEverything(metrics));
    for (const std::string& line : Lines(metrics)) {
      EXPECT_TRUE(line.starts_with("# ") || line.starts_with("fleetmap_")) << line;
    }
    const std::string page = HttpGet(http, "/");
    EXPECT_TRUE(IsValidUtf8(page));
    EXPECT_EQ(page.find("\u202e"), std::string::npos);
    EXPECT_EQ(page.find("\u0085"), std::string::npos);
    EXPECT_TRUE(HasOnlyItsOwnScript(page));
  }
  // The log: one line per record, all of it valid UTF-8.
  const std::string log = server.Log();
  EXPECT_TRUE(IsValidUtf8(log));
  const std::regex record(R"(^\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d\.\d{3} [a-z]+ .*)");
  for (const std::string& line : Lines(log)) {
    EXPECT_TRUE(std::regex_match(line, record)) << "a log line that is not a record: " << line;
  }
  (void)other;
}

}  // namespace
}  // namespace fleetmap::testing
