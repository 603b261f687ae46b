// Runs a built program (fleetmap, fleetmapd, fleetmap-agent) as a child process to its end, the
// way a user runs it, and keeps its exit code, stdout and stderr for the test to check.
#pragma once

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "fleetmap/core/child_process.h"

namespace fleetmap::testing {

struct ProgramRun {
  int exit_code = -1;  // -1 when it did not end in time (it is killed then)
  std::string out, err;
};

// Runs the program argv[0] with argv (and `environment` added to this process's); stderr goes
// through a file in `scratch_dir` so a chatty program never blocks on a pipe. Waits at most
// `timeout` for it to finish.
inline ProgramRun RunProgram(const std::filesystem::path& scratch_dir,
                             const std::vector<std::string>& argv,
                             std::vector<std::pair<std::string, std::string>> environment = {},
                             std::chrono::seconds timeout = std::chrono::seconds(120)) {
  const std::filesystem::path err_file = scratch_dir / "program.stderr";
  std::filesystem::remove(err_file);
  ProgramRun run;
  {
    ChildProcess child(argv, {.stderr_file = err_file, .environment = std::move(environment)});
    run.out = child.ReadRest(timeout);
    run.exit_code = child.Wait(std::chrono::seconds(10)).value_or(-1);
  }  // a child still running is killed here, before its stderr is read
  std::ifstream err(err_file, std::ios::binary);
  run.err.assign(std::istreambuf_iterator<char>(err), std::istreambuf_iterator<char>());
  return run;
}

// The exit code and both streams: what a failed expectation should show.
inline std::string DescribeRun(const ProgramRun& run) {
  return "exit " + std::to_string(run.exit_code) + "\nstdout:\n" + run.out + "\nstderr:\n" +
         run.err;
}

// The whole file as bytes ("" when it cannot be read): what a command wrote, or left alone.
inline std::string ReadWholeFile(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream bytes;
  bytes << in.rdbuf();
  return bytes.str();
}

// Replaces `path` with `text` (a config file, a token file for the program to read).
inline void WriteWholeFile(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary | std::ios::trunc) << text;
}

inline bool Contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

}  // namespace fleetmap::testing
