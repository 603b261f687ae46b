// Runs the built `fleetmap` executable as a child process, the way a user runs it, for the
// tests of its commands. FLEETMAP_CLI (the executable's path) is defined by tests/CMakeLists.txt
// for every test target that uses this.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "program_run.h"
#include "scratch_dir.h"

namespace fleetmap::testing {

using CliRun = ProgramRun;

// Runs `fleetmap ARGS...` (RunProgram).
inline CliRun RunFleetmapCli(const std::filesystem::path& scratch_dir,
                             const std::vector<std::string>& args,
                             std::chrono::seconds timeout = std::chrono::seconds(120)) {
  std::vector<std::string> argv{FLEETMAP_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  return RunProgram(scratch_dir, argv, {}, timeout);
}

// The command line, its exit code and both streams: what a failed expectation should show.
// The CLI run in the scratch directory DIR.
inline CliRun RunCli(const ScratchDir& dir, const std::vector<std::string>& args) {
  return RunFleetmapCli(dir.path(), args);
}

inline std::string DescribeCliRun(const std::vector<std::string>& args, const CliRun& run) {
  std::string text = "fleetmap";
  for (const std::string& arg : args) text += " " + arg;
  return text + "\nexit " + std::to_string(run.exit_code) + "\nstdout:\n" + run.out + "stderr:\n" +
         run.err;
}

// Runs `fleetmap ARGS` and expects it to succeed (exit 0) or, unless `succeed`, to fail: a
// non-zero exit with fleetmap's error prefix ("fleetmap: ") on stderr.
inline CliRun RunFleetmapCliExpecting(const std::filesystem::path& scratch_dir,
                                      const std::vector<std::string>& args, bool succeed) {
  CliRun run = RunFleetmapCli(scratch_dir, args);
  if (succeed) {
    EXPECT_EQ(run.exit_code, 0) << DescribeCliRun(args, run);
  } else {
    EXPECT_NE(run.exit_code, 0) << DescribeCliRun(args, run);
    EXPECT_TRUE(Contains(run.err, "fleetmap: ")) << DescribeCliRun(args, run);
  }
  return run;
}

// A test of `fleetmap` commands on one repository: a scratch directory, the repository's URI (an
// SQLite file in it, unless the test names another store) and runners of the built CLI.
class FleetmapCliTest : public ::testing::Test {
 protected:
  explicit FleetmapCliTest(const std::string& scratch_prefix) : dir_(scratch_prefix) {}

  // Runs the CLI; expects success unless told otherwise (RunFleetmapCliExpecting).
  CliRun Run(const std::vector<std::string>& args, bool succeed = true) {
    return RunFleetmapCliExpecting(dir_.path(), args, succeed);
  }
  // Runs the CLI on the test's repository (--store appended).
  CliRun RunOn(std::vector<std::string> args, bool succeed = true) {
    args.push_back("--store");
    args.push_back(store_);
    return Run(args, succeed);
  }

  // Runs the CLI expecting it to fail (on the test's repository unless `args` name a --store),
  // naming each of `mentions` on stderr and leaving neither `out_file` nor `out_file`.tmp:
  // what a command that writes one file (`export`, `render`) must do with bad input.
  CliRun ExpectRefusedWithoutOutput(std::vector<std::string> args,
                                    const std::filesystem::path& out_file,
                                    const std::vector<std::string>& mentions) {
    if (std::find(args.begin(), args.end(), "--store") == args.end()) {
      args.push_back("--store");
      args.push_back(store_);
    }
    CliRun r = Run(args, /*succeed=*/false);
    for (const std::string& mention : mentions) {
      EXPECT_TRUE(Contains(r.err, mention)) << "should mention '" << mention << "'\n"
                                            << DescribeCliRun(args, r);
    }
    EXPECT_FALSE(std::filesystem::exists(out_file)) << DescribeCliRun(args, r);
    EXPECT_FALSE(std::filesystem::exists(out_file.string() + ".tmp")) << DescribeCliRun(args, r);
    return r;
  }

  ScratchDir dir_;
  std::string store_ = "sqlite:" + (dir_ / "repository.db").string();
};

}  // namespace fleetmap::testing
