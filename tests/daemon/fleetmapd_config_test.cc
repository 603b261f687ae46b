// fleetmapd --config FILE (docs/operations.md, "Run as services"): its options from a TOML file
// with the command line winning over the file; an unknown key, a malformed line, a bad value and a
// missing file each refused (exit 2) with the key or the file named, before any store is made;
// and the example config the packages install (packaging/config/fleetmapd.toml) serving a store
// of each backend with only its paths overridden, the way the systemd unit runs it.
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "program_run.h"
#include "scratch_dir.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using testing::BackendNames;
using testing::Contains;
using testing::DescribeRun;
using testing::ProgramRun;
using testing::ReadWholeFile;
using testing::RunProgram;
using testing::StoreBackends;
using testing::WriteWholeFile;

const fs::path kExampleConfig = fs::path(FLEETMAP_SOURCE_DIR) / "packaging/config/fleetmapd.toml";

// fleetmapd started with `args` until it serves: its stdout lines up to "listening on" (and the
// "http on" line after it when `http`), then SIGTERM; it must drain and exit 0.
struct Served {
  std::string listening;  // the "fleetmapd listening on" line; empty when it did not serve
  std::string http;       // the "http on" line
  std::string log;
};

Served ServeThenStop(const std::vector<std::string>& args, const fs::path& log, bool http) {
  std::vector<std::string> argv = {FLEETMAPD_PATH};
  argv.insert(argv.end(), args.begin(), args.end());
  ChildProcess server(argv, {.stderr_file = log, .environment = {}});
  Served served;
  served.listening = server.ReadLineContaining("listening on", milliseconds(30'000)).value_or("");
  if (!served.listening.empty() && http) {
    served.http = server.ReadLine(milliseconds(10'000)).value_or("");
  }
  server.Signal(SIGTERM);
  EXPECT_EQ(server.Wait(milliseconds(20'000)), std::optional<int>(0));
  served.log = ReadWholeFile(log);
  return served;
}

template <typename Backend>
class FleetmapdConfigBackendTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (const auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
  }
  Backend backend_;
  ScratchDir dir_{"fleetmapd-config"};
};

TYPED_TEST_SUITE(FleetmapdConfigBackendTest, StoreBackends, BackendNames);

// The store, the addresses and a limit all from the file: fleetmapd serves that store.
TYPED_TEST(FleetmapdConfigBackendTest, ServesTheStoreTheConfigFileNames) {
  const fs::path config = this->dir_ / "fleetmapd.toml";
  WriteWholeFile(config, "# the depot\nstore = \"" + this->backend_.Uri() +
                             "\"\nlisten = \"127.0.0.1:0\"\nhttp = \"127.0.0.1:0\"\n"
                             "max-submission-mib = 64\n");
  const Served served =
      ServeThenStop({"--config", config.string()}, this->dir_ / "fleetmapd.log", true);
  ASSERT_TRUE(Contains(served.listening, "fleetmapd listening on 127.0.0.1:")) << served.log;
  EXPECT_TRUE(Contains(served.http, "http on 127.0.0.1:")) << served.http;
  EXPECT_TRUE(Contains(served.log, "serving " + this->backend_.Uri())) << served.log;
}

// The example config of the packages, as the unit runs it: every key in it is one fleetmapd
// knows, and the paths a test cannot use (/var/lib, port 7420) give way to the command line.
TYPED_TEST(FleetmapdConfigBackendTest, TheInstalledExampleServesWithItsPathsOverridden) {
  const Served served =
      ServeThenStop({"--config", kExampleConfig.string(), "--store", this->backend_.Uri(),
                     "--listen", "127.0.0.1:0", "--http", "127.0.0.1:0"},
                    this->dir_ / "fleetmapd.log", true);
  ASSERT_FALSE(served.listening.empty()) << served.log;
  EXPECT_TRUE(Contains(served.http, "http on 127.0.0.1:")) << served.http;
  EXPECT_TRUE(Contains(served.log, "serving " + this->backend_.Uri())) << served.log;
}

class FleetmapdConfigTest : public ::testing::Test {
 protected:
  ProgramRun Run(const std::vector<std::string>& args) {
    std::vector<std::string> argv = {FLEETMAPD_PATH};
    argv.insert(argv.end(), args.begin(), args.end());
    return RunProgram(dir_.path(), argv, {}, std::chrono::seconds(30));
  }
  std::string StoreUri(const std::string& name) const { return "sqlite:" + (dir_ / name).string(); }

  ScratchDir dir_{"fleetmapd-config"};
};

TEST_F(FleetmapdConfigTest, TheCommandLineWinsOverTheConfigFile) {
  const fs::path config = dir_ / "fleetmapd.toml";
  WriteWholeFile(config,
                 "store = \"" + StoreUri("from-file.db") + "\"\nlisten = \"127.0.0.1:0\"\n");
  const Served served = ServeThenStop({"--config", config.string(), "--store", StoreUri("flag.db")},
                                      dir_ / "fleetmapd.log", false);
  ASSERT_FALSE(served.listening.empty()) << served.log;
  EXPECT_TRUE(Contains(served.log, "serving " + StoreUri("flag.db"))) << served.log;
  EXPECT_TRUE(fs::exists(dir_ / "flag.db"));
  EXPECT_FALSE(fs::exists(dir_ / "from-file.db"));
  // Either order on the command line: the flag still wins.
  const Served before =
      ServeThenStop({"--store", StoreUri("flag2.db"), "--config", config.string()},
                    dir_ / "fleetmapd2.log", false);
  EXPECT_TRUE(Contains(before.log, "serving " + StoreUri("flag2.db"))) << before.log;
  EXPECT_FALSE(fs::exists(dir_ / "from-file.db"));
}

// A misspelt key would otherwise leave a default nobody chose: it is refused, named with the
// file, before the store is touched.
TEST_F(FleetmapdConfigTest, AnUnknownKeyIsRefusedNamingItAndTheFile) {
  const fs::path config = dir_ / "typo.toml";
  WriteWholeFile(config, "store = \"" + StoreUri("never.db") + "\"\nmax-submision-mib = 64\n");
  const ProgramRun run = Run({"--config", config.string(), "--listen", "127.0.0.1:0"});
  EXPECT_EQ(run.exit_code, 2) << DescribeRun(run);
  EXPECT_TRUE(Contains(run.err, "max-submision-mib")) << run.err;
  EXPECT_TRUE(Contains(run.err, config.string())) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "never.db"));
  EXPECT_TRUE(run.out.empty()) << run.out;
}

TEST_F(FleetmapdConfigTest, MalformedLinesBadValuesAndMissingFilesAreNamed) {
  const std::string store = "store = \"" + StoreUri("never.db") + "\"\n";
  // A line that is no `key = value`, and a section header left open.
  for (const std::string& bad : {std::string("listen 127.0.0.1:0"), std::string("[fleetmapd")}) {
    const fs::path config = dir_ / "malformed.toml";
    WriteWholeFile(config, store + bad + "\n");
    const ProgramRun run = Run({"--config", config.string()});
    EXPECT_EQ(run.exit_code, 2) << bad << "\n" << DescribeRun(run);
    EXPECT_TRUE(Contains(run.err, bad)) << run.err;
    EXPECT_TRUE(Contains(run.err, config.string())) << run.err;
  }
  // A value the option refuses is refused as from the command line, naming the option.
  const fs::path threads = dir_ / "threads.toml";
  WriteWholeFile(threads, store + "threads = lots\n");
  const ProgramRun bad_value = Run({"--config", threads.string()});
  EXPECT_EQ(bad_value.exit_code, 2) << DescribeRun(bad_value);
  EXPECT_TRUE(Contains(bad_value.err, "--threads")) << bad_value.err;
  EXPECT_TRUE(Contains(bad_value.err, "lots")) << bad_value.err;
  // No such file, and a directory.
  for (const fs::path& missing : {dir_ / "absent.toml", dir_.path()}) {
    const ProgramRun run = Run({"--config", missing.string()});
    EXPECT_EQ(run.exit_code, 2) << DescribeRun(run);
    EXPECT_TRUE(Contains(run.err, missing.string() + " was not readable")) << run.err;
  }
  EXPECT_FALSE(fs::exists(dir_ / "never.db"));
}

}  // namespace
}  // namespace fleetmap
