// The real fleetmapd binary as a child process for its tests: started on 127.0.0.1 port 0 (or
// a given address), its "listening on" line read for the bound address, its log (stderr) kept
// in a file the test can search. ChildProcess kills it when the test ends, however it ends.
#pragma once

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "fleetmap/core/child_process.h"

namespace fleetmap::testing {

struct Fleetmapd {
  std::unique_ptr<ChildProcess> process;
  std::string address;  // HOST:PORT as bound; empty when it did not start
  std::filesystem::path log;

  std::string Log() const {
    std::ifstream in(log);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  // Waits (bounded) until the log holds `text`.
  bool LogContains(const std::string& text,
                   std::chrono::milliseconds timeout = std::chrono::milliseconds(5000)) const {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    for (;;) {
      if (Log().find(text) != std::string::npos) return true;
      if (std::chrono::steady_clock::now() > deadline) return false;
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  }
};

inline Fleetmapd StartFleetmapd(const std::string& store_uri, const std::filesystem::path& log,
                                std::vector<std::string> extra = {},
                                const std::string& listen = "127.0.0.1:0") {
  std::vector<std::string> argv = {FLEETMAPD_PATH, "--store", store_uri, "--listen", listen};
  argv.insert(argv.end(), extra.begin(), extra.end());
  Fleetmapd server;
  server.log = log;
  server.process = std::make_unique<ChildProcess>(
      argv, ChildProcessOptions{.stderr_file = log, .environment = {}});
  const std::optional<std::string> line =
      server.process->ReadLineContaining("listening on", std::chrono::milliseconds(30'000));
  if (!line) {
    ADD_FAILURE() << "fleetmapd did not start:\n" << server.Log();
    return server;
  }
  server.address = line->substr(line->rfind(' ') + 1);
  return server;
}

}  // namespace fleetmap::testing
