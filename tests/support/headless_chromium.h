// Headless Chromium (Debian's chromium, installed by scripts/setup) on a page of a server on
// 127.0.0.1, for the status page's browser tests: a screenshot, or the DOM its scripts built.
#pragma once

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "scratch_dir.h"

namespace fleetmap {

inline std::string ChromiumPath() {
  const char* configured = std::getenv("FLEETMAP_CHROMIUM");
  return configured != nullptr ? configured : "/usr/bin/chromium";
}

// Runs headless Chromium on `url` with `mode_flag` (--screenshot=..., --dump-dom) in a fresh
// profile under `scratch`, bounded to 60 s; returns its standard output. Fails the test
// (not skips: CI installs Chromium) when Chromium is missing or fails.
inline std::string RunChromium(const ScratchDir& scratch, const std::string& mode_flag,
                               const std::string& url) {
  const std::string chromium = ChromiumPath();
  if (!std::filesystem::exists(chromium)) {
    ADD_FAILURE() << "Chromium not found at " << chromium
                  << ": the status page browser tests need it (scripts/setup installs it: "
                     "apt-get install chromium; or set FLEETMAP_CHROMIUM)";
    return "";
  }
  const auto profile = scratch / "profile";
  const auto log = scratch / "chromium.log";
  const std::string command = "timeout -k 5 60 '" + chromium +
                              "' --headless --no-sandbox --disable-gpu --disable-dev-shm-usage "
                              "--no-first-run --hide-scrollbars --window-size=1200,800 "
                              "--user-data-dir='" +
                              profile.string() + "' " + mode_flag + " '" + url + "' 2>>'" +
                              log.string() + "'";
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) {
    ADD_FAILURE() << "cannot run " << command;
    return "";
  }
  std::string output;
  char buffer[4096];
  for (std::size_t n; (n = std::fread(buffer, 1, sizeof buffer, pipe)) > 0;)
    output.append(buffer, n);
  const int status = pclose(pipe);
  if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
    std::ifstream log_in(log);
    std::stringstream log_text;
    log_text << log_in.rdbuf();
    ADD_FAILURE() << "chromium failed (status " << status << "): " << command << "\n"
                  << log_text.str().substr(0, 4000);
  }
  return output;
}

}  // namespace fleetmap
