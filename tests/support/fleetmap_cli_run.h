// Runs the built `fleetmap` executable as a child process, the way a user runs it, for the
// tests of its commands. FLEETMAP_CLI (the executable's path) is defined by tests/CMakeLists.txt
// for every test target that uses this.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"
#include "scratch_dir.h"

namespace fleetmap::testing {

struct CliRun {
  int exit_code = -1;  // -1 when it did not end in time (it is killed then)
  std::string out, err;
};

// Runs `fleetmap ARGS...`; stderr goes through a file in `scratch_dir` so a chatty command never
// blocks on a pipe. Waits at most `timeout` for it to finish.
inline CliRun RunFleetmapCli(const std::filesystem::path& scratch_dir,
                             const std::vector<std::string>& args,
                             std::chrono::seconds timeout = std::chrono::seconds(120)) {
  const std::filesystem::path err_file = scratch_dir / "cli.stderr";
  std::filesystem::remove(err_file);
  std::vector<std::string> argv{FLEETMAP_CLI};
  argv.insert(argv.end(), args.begin(), args.end());
  CliRun run;
  {
    ChildProcess child(argv, {.stderr_file = err_file, .environment = {}});
    run.out = child.ReadRest(timeout);
    run.exit_code = child.Wait(std::chrono::seconds(10)).value_or(-1);
  }  // a child still running is killed here, before its stderr is read
  std::ifstream err(err_file, std::ios::binary);
  run.err.assign(std::istreambuf_iterator<char>(err), std::istreambuf_iterator<char>());
  return run;
}

// The whole file as bytes ("" when it cannot be read): what a command wrote, or left alone.
inline std::string ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

inline bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

// The command line, its exit code and both streams: what a failed expectation should show.
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

  ScratchDir dir_;
  std::string store_ = "sqlite:" + (dir_ / "repository.db").string();
};

}  // namespace fleetmap::testing
