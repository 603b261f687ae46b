// Runs the built `fleetmap` executable as a child process, the way a user runs it, for the
// tests of its commands. FLEETMAP_CLI (the executable's path) is defined by tests/CMakeLists.txt
// for every test target that uses this.
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "fleetmap/core/child_process.h"

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

}  // namespace fleetmap::testing
