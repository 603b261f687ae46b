// A program run as a child process, for the tools and tests that drive real fleetmapd and
// fleetmap-agent processes (the fleet demo, the cross-process tests): start with arguments and
// extra environment, read its stdout line by line with a deadline, signal it, wait for it with
// a deadline. Its stderr goes to a file (or is inherited), so a chatty child never blocks on a
// full pipe nobody reads.
//
// The destructor SIGKILLs and reaps a child still running, so no process outlives its owner's
// scope, also when a test fails half-way. Not thread-safe; one owner.
#pragma once

#include <chrono>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace fleetmap {

struct ChildProcessOptions {
  // Where the child's stderr goes: a file (appended to), or the parent's stderr when empty.
  std::filesystem::path stderr_file;
  // Added to (or replacing in) the parent's environment: NAME, value.
  std::vector<std::pair<std::string, std::string>> environment;
};

class ChildProcess {
 public:
  // Starts argv[0] (a path) with argv. Throws Error(kNotFound) when it cannot be started.
  explicit ChildProcess(const std::vector<std::string>& argv,
                        const ChildProcessOptions& options = {});
  ~ChildProcess();
  ChildProcess(ChildProcess&& other) noexcept;
  ChildProcess& operator=(ChildProcess&&) = delete;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // The next line of stdout without its newline; nullopt at end of output or when none
  // arrives within `timeout`.
  std::optional<std::string> ReadLine(std::chrono::milliseconds timeout);
  // Reads the first line containing `needle` (discarding the lines before it) within `timeout`.
  std::optional<std::string> ReadLineContaining(const std::string& needle,
                                                std::chrono::milliseconds timeout);
  // Everything left on stdout until it closes or `timeout` passes.
  std::string ReadRest(std::chrono::milliseconds timeout);

  void Signal(int signal_number);
  // The exit status when the child ends within `timeout`: its exit code, or 128 + the signal
  // that ended it. nullopt while it still runs.
  std::optional<int> Wait(std::chrono::milliseconds timeout);
  bool running();
  int pid() const { return pid_; }

 private:
  // Reads what is available within `timeout` into buffer_; false at end of output.
  bool Fill(std::chrono::steady_clock::time_point deadline);

  int pid_ = -1;
  int stdout_fd_ = -1;
  std::string buffer_;
  bool eof_ = false;
  std::optional<int> status_;
};

}  // namespace fleetmap
