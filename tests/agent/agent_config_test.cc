// fleetmap-agent as a service (docs/operations.md, "Run as services"): its options from a --config
// TOML file, in a section per subcommand, with the command line winning; the robot's token from a
// file (as the systemd unit hands it over, a credential) or from the environment, and never on
// the command line: /proc/PID/cmdline of the daemon run as the unit runs it holds no token.
// Unknown keys and sections, a token in the file and unreadable token files are refused (exit 2)
// with what is wrong named. Real fleetmapd and fleetmap-agent processes on 127.0.0.1.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "fleet_processes.h"
#include "fleetmap/core/child_process.h"
#include "program_run.h"
#include "random_robot_map.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using testing::Contains;
using testing::DescribeRun;
using testing::ProgramRun;
using testing::WriteWholeFile;

// The agent's --json result: the last line of `out` that is a JSON object (null when none is).
nlohmann::json LastResult(const std::string& out) {
  nlohmann::json result;
  std::istringstream lines(out);
  for (std::string line; std::getline(lines, line);) {
    if (line.starts_with("{")) result = nlohmann::json::parse(line);
  }
  return result;
}

const fs::path kExampleConfig = fs::path(FLEETMAP_SOURCE_DIR) / "packaging/config/agent.toml";
constexpr int kMapNodes = 6;

class AgentConfigTest : public ::testing::Test {
 protected:
  void SetUp() override {
    store_uri_ = "sqlite:" + (dir_ / "fleet.db").string();
    robot_ = testing::RegisterRobot(store_uri_, "rover-1", dir_ / "robot");
    testing::WriteLocalMap(robot_, testing::RandomRobotMap(robot_.id, kMapNodes, 11, 30));
    token_file_ = dir_ / "token";
    WriteSecretFile(token_file_, robot_.token + "\n");
  }

  // A token file as `fleetmap robot add`'s user keeps it: readable by its owner only (the
  // agent refuses one others can read).
  static void WriteSecretFile(const fs::path& path, const std::string& text) {
    WriteWholeFile(path, text);
    fs::permissions(path, fs::perms::owner_read | fs::perms::owner_write,
                    fs::perm_options::replace);
  }

  void StartServer() {
    server_ = testing::StartFleetmapd(store_uri_, dir_ / "fleetmapd.log");
    ASSERT_FALSE(server_.address.empty());
  }

  // `fleetmap-agent ARGS` run to its end, with `environment` added.
  ProgramRun Run(const std::vector<std::string>& args,
                 std::vector<std::pair<std::string, std::string>> environment = {}) {
    std::vector<std::string> argv = {FLEETMAP_AGENT_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    return testing::RunProgram(dir_.path(), argv, std::move(environment));
  }

  // A config file with a [sync] section naming this robot, its map and the server.
  fs::path SyncConfig(const std::string& name, const std::string& extra_lines) {
    const fs::path config = dir_ / name;
    WriteWholeFile(config, "[sync]\nserver = \"" + server_.address + "\"\nrobot = \"" +
                               robot_.id.ToString() + "\"\nmap-dir = \"" + robot_.map_dir.string() +
                               "\"\n" + extra_lines);
    return config;
  }

  ScratchDir dir_{"fleetmap-agent-config"};
  std::string store_uri_;
  testing::TestRobot robot_;
  fs::path token_file_;
  testing::Fleetmapd server_;
};

// The unit's command line: the example config, `daemon --token-file %d/token`, and here the
// paths a test needs. FLEETMAP_TOKEN holds a wrong token: the file the unit names wins.
TEST_F(AgentConfigTest, TheDaemonRunAsTheUnitRunsItSyncsWithTheTokenFileAndNoTokenInArgv) {
  StartServer();
  const fs::path dock = dir_ / "docked";
  const fs::path log = dir_ / "agent.log";
  const std::vector<std::string> argv = {FLEETMAP_AGENT_PATH,
                                         "--config",
                                         kExampleConfig.string(),
                                         "daemon",
                                         "--token-file",
                                         token_file_.string(),
                                         "--server",
                                         server_.address,
                                         "--robot",
                                         robot_.id.ToString(),
                                         "--map-dir",
                                         robot_.map_dir.string(),
                                         "--dock-file",
                                         dock.string(),
                                         "--json"};
  ChildProcess daemon(
      argv, {.stderr_file = log, .environment = {{"FLEETMAP_TOKEN", std::string(64, '0')}}});
  for (int i = 0; i < 100 && !Contains(testing::ReadLog(log), "waiting for"); ++i) {
    std::this_thread::sleep_for(milliseconds(50));
  }
  ASSERT_TRUE(Contains(testing::ReadLog(log), "waiting for " + dock.string()))
      << testing::ReadLog(log);

  std::ifstream cmdline_file("/proc/" + std::to_string(daemon.pid()) + "/cmdline");
  const std::string cmdline{std::istreambuf_iterator<char>(cmdline_file),
                            std::istreambuf_iterator<char>()};
  EXPECT_TRUE(Contains(cmdline, token_file_.string())) << cmdline;
  EXPECT_FALSE(Contains(cmdline, robot_.token)) << "the token is in /proc/PID/cmdline";

  std::ofstream(dock).put('\n');
  const std::optional<std::string> line = daemon.ReadLineContaining("{", milliseconds(120'000));
  ASSERT_TRUE(line.has_value()) << testing::ReadLog(log);
  const nlohmann::json result = nlohmann::json::parse(*line);
  EXPECT_EQ(result["pushed_nodes"], kMapNodes);
  // wait-merge = true and policy = "tod+paths" come from the example file.
  EXPECT_EQ(result["merge_state"], "merged");
  daemon.Signal(SIGTERM);
  EXPECT_EQ(daemon.Wait(milliseconds(10'000)), std::optional<int>(0)) << testing::ReadLog(log);
  const ProgramRun status = Run({"status", "--map-dir", robot_.map_dir.string(), "--json"});
  ASSERT_EQ(status.exit_code, 0) << DescribeRun(status);
  const std::string policy = LastResult(status.out)["policy"].get<std::string>();
  EXPECT_TRUE(Contains(policy, "tod") && Contains(policy, "paths")) << policy;
}

TEST_F(AgentConfigTest, TheTokenComesFromTheConfigFilesTokenFileOrTheEnvironment) {
  StartServer();
  const fs::path with_file =
      SyncConfig("with-file.toml", "token-file = \"" + token_file_.string() + "\"\n");
  const ProgramRun first = Run({"--config", with_file.string(), "sync", "--json"});
  ASSERT_EQ(first.exit_code, 0) << DescribeRun(first);
  EXPECT_EQ(LastResult(first.out)["pushed_nodes"], kMapNodes);

  // No token in the file: the environment's. A wrong one is refused, so it is the one used.
  const fs::path without = SyncConfig("without.toml", "");
  const ProgramRun from_env =
      Run({"--config", without.string(), "sync", "--json"}, {{"FLEETMAP_TOKEN", robot_.token}});
  ASSERT_EQ(from_env.exit_code, 0) << DescribeRun(from_env);
  EXPECT_EQ(LastResult(from_env.out)["pushed_nodes"], 0);
  const ProgramRun wrong = Run({"--config", without.string(), "sync", "--json"},
                               {{"FLEETMAP_TOKEN", std::string(64, '0')}});
  EXPECT_EQ(wrong.exit_code, 2) << DescribeRun(wrong);
  EXPECT_TRUE(Contains(wrong.err, "BAD_TOKEN")) << wrong.err;
  const ProgramRun none = Run({"--config", without.string(), "sync"}, {{"FLEETMAP_TOKEN", ""}});
  EXPECT_EQ(none.exit_code, 2) << DescribeRun(none);
  EXPECT_TRUE(Contains(none.err, "no token")) << none.err;
}

TEST_F(AgentConfigTest, TheCommandLineWinsAndEachSectionIsItsSubcommandsOnly) {
  StartServer();
  const fs::path config = SyncConfig(
      "policy.toml", "token-file = \"" + token_file_.string() + "\"\npolicy = \"nonsense\"\n");
  const ProgramRun from_file = Run({"--config", config.string(), "sync"});
  EXPECT_EQ(from_file.exit_code, 2) << DescribeRun(from_file);
  EXPECT_TRUE(Contains(from_file.err, "\"nonsense\"")) << from_file.err;
  // After the subcommand too, as the unit writes it.
  const ProgramRun flag = Run({"sync", "--config", config.string(), "--policy", "copy", "--json"});
  ASSERT_EQ(flag.exit_code, 0) << DescribeRun(flag);
  EXPECT_EQ(LastResult(flag.out)["pushed_nodes"], kMapNodes);

  // A [daemon] section sets nothing for `sync`.
  const fs::path daemon_only = dir_ / "daemon-only.toml";
  WriteWholeFile(daemon_only,
                 "[daemon]\npolicy = \"nonsense\"\ndock-file = \"/nonexistent/docked\"\n");
  const ProgramRun sync = Run({"--config", daemon_only.string(), "sync", "--server",
                               server_.address, "--robot", robot_.id.ToString(), "--map-dir",
                               robot_.map_dir.string(), "--token-file", token_file_.string()});
  EXPECT_EQ(sync.exit_code, 0) << DescribeRun(sync);
}

TEST_F(AgentConfigTest, UnknownKeysSectionsTokensAndMalformedLinesInTheFileAreRefused) {
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"[daemon]\ndock-flie = \"/run/fleetmap-agent/docked\"\n", "daemon.dock-flie"},
      {"[deamon]\nserver = \"depot:7420\"\n", "deamon"},
      {"[sync]\ntoken = \"" + std::string(64, 'a') + "\"\n", "not allowed"},
      {"[sync]\nserver depot:7420\n", "server depot:7420"},
  };
  for (const auto& [text, named] : cases) {
    const fs::path config = dir_ / "bad.toml";
    WriteWholeFile(config, text);
    const ProgramRun run =
        Run({"--config", config.string(), "sync", "--server", "127.0.0.1:1", "--robot",
             robot_.id.ToString(), "--token-file", token_file_.string()});
    EXPECT_EQ(run.exit_code, 2) << text << DescribeRun(run);
    EXPECT_TRUE(Contains(run.err, named)) << text << run.err;
    EXPECT_TRUE(Contains(run.err, config.string())) << text << run.err;
    EXPECT_FALSE(Contains(run.err, "connecting")) << "it dialled: " << run.err;
  }
  const fs::path absent = dir_ / "absent.toml";
  const ProgramRun missing = Run({"--config", absent.string(), "status"});
  EXPECT_EQ(missing.exit_code, 2) << DescribeRun(missing);
  EXPECT_TRUE(Contains(missing.err, absent.string() + " was not readable")) << missing.err;
}

TEST_F(AgentConfigTest, UnreadableEmptyOrDoubledTokensAreNamedBeforeDialling) {
  const std::vector<std::string> sync = {"sync",
                                         "--server",
                                         "127.0.0.1:1",
                                         "--robot",
                                         robot_.id.ToString(),
                                         "--map-dir",
                                         robot_.map_dir.string()};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = sync;
    args.insert(args.end(), extra.begin(), extra.end());
    return Run(args);
  };
  const fs::path absent = dir_ / "no-token";
  const ProgramRun missing = with({"--token-file", absent.string()});
  EXPECT_EQ(missing.exit_code, 2) << DescribeRun(missing);
  EXPECT_TRUE(Contains(missing.err, "cannot read --token-file " + absent.string())) << missing.err;
  const fs::path empty = dir_ / "empty-token";
  WriteSecretFile(empty, "\n");
  const ProgramRun blank = with({"--token-file", empty.string()});
  EXPECT_EQ(blank.exit_code, 2) << DescribeRun(blank);
  EXPECT_TRUE(Contains(blank.err, "--token-file " + empty.string() + " is empty")) << blank.err;
  const ProgramRun both = with({"--token-file", token_file_.string(), "--token", robot_.token});
  EXPECT_EQ(both.exit_code, 2) << DescribeRun(both);
  EXPECT_TRUE(Contains(both.err, "excludes")) << both.err;
}

// A channel name or a route the server would refuse is named before dialling.
TEST_F(AgentConfigTest, ABadChannelOrRouteIsNamedBeforeDialling) {
  const std::vector<std::string> sync = {"sync",
                                         "--server",
                                         "127.0.0.1:1",
                                         "--robot",
                                         robot_.id.ToString(),
                                         "--map-dir",
                                         robot_.map_dir.string(),
                                         "--token-file",
                                         token_file_.string()};
  auto with = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = sync;
    args.insert(args.end(), extra.begin(), extra.end());
    return Run(args);
  };
  const ProgramRun channel = with({"--channel", "Stable Release"});
  EXPECT_EQ(channel.exit_code, 2) << DescribeRun(channel);
  EXPECT_TRUE(Contains(channel.err, "channel name \"Stable Release\"")) << channel.err;
  const ProgramRun route = with({"--route", "anchor not-a-uuid; 0 0 0"});
  EXPECT_EQ(route.exit_code, 2) << DescribeRun(route);
  EXPECT_TRUE(Contains(route.err, "--route anchor not-a-uuid")) << route.err;
  const ProgramRun radius = with({"--route", Uuid::Generate().ToString(), "--route-radius", "-3"});
  EXPECT_EQ(radius.exit_code, 2) << DescribeRun(radius);
  EXPECT_TRUE(Contains(radius.err, "radius")) << radius.err;
}

// A token file everyone could read (mode 0644) was accepted without a word.
// As ssh refuses such a key, the agent refuses a token file its group or others can read,
// saying how to fix it, before it dials; at 0600 the same file syncs.
TEST_F(AgentConfigTest, ATokenFileOthersCanReadIsRefusedUntilItIsPrivate) {
  StartServer();
  const std::vector<std::string> sync = {"sync",
                                         "--server",
                                         server_.address,
                                         "--robot",
                                         robot_.id.ToString(),
                                         "--map-dir",
                                         robot_.map_dir.string(),
                                         "--token-file",
                                         token_file_.string(),
                                         "--json"};
  for (const fs::perms loose : {fs::perms::others_read, fs::perms::group_read}) {
    fs::permissions(token_file_, fs::perms::owner_read | fs::perms::owner_write | loose,
                    fs::perm_options::replace);
    const ProgramRun refused = Run(sync);
    EXPECT_EQ(refused.exit_code, 2) << DescribeRun(refused);
    EXPECT_TRUE(Contains(refused.err, "chmod 600 " + token_file_.string())) << refused.err;
    EXPECT_FALSE(Contains(refused.err, "connecting")) << "it dialled: " << refused.err;
  }
  EXPECT_EQ(testing::ReadLog(dir_ / "fleetmapd.log").find("session 127.0.0.1"), std::string::npos)
      << "a refused token file still reached the server";
  fs::permissions(token_file_, fs::perms::owner_read | fs::perms::owner_write,
                  fs::perm_options::replace);
  const ProgramRun synced = Run(sync);
  ASSERT_EQ(synced.exit_code, 0) << DescribeRun(synced);
  EXPECT_EQ(LastResult(synced.out)["pushed_nodes"], kMapNodes);
}
}  // namespace
}  // namespace fleetmap
