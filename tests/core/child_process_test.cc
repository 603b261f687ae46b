// ChildProcess (child_process.h): what the cross-process tests and the demo rely on.
#include "fleetmap/core/child_process.h"

#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

using std::chrono::milliseconds;

TEST(ChildProcess, ReadsLinesAndTheExitCode) {
  ChildProcess child({"/bin/sh", "-c", "echo one; echo two $GREETING; exit 3"},
                     {.stderr_file = {}, .environment = {{"GREETING", "hello"}}});
  EXPECT_EQ(child.ReadLine(milliseconds(5000)), "one");
  EXPECT_EQ(child.ReadLineContaining("two", milliseconds(5000)), "two hello");
  EXPECT_EQ(child.ReadLine(milliseconds(5000)), std::nullopt);  // end of output
  EXPECT_EQ(child.Wait(milliseconds(5000)), 3);
}

TEST(ChildProcess, ReadingGivesUpAtItsDeadlineAndASignalEndsTheChild) {
  // exec: the shell becomes the sleeper, so the SIGKILL below ends it and nothing is left
  // holding the test's stderr open for ctest to wait on.
  ChildProcess child({"/bin/sh", "-c", "exec sleep 30"});
  const auto start = std::chrono::steady_clock::now();
  EXPECT_EQ(child.ReadLine(milliseconds(200)), std::nullopt);
  EXPECT_LT(std::chrono::steady_clock::now() - start, milliseconds(5000));
  EXPECT_TRUE(child.running());
  child.Signal(SIGKILL);
  EXPECT_EQ(child.Wait(milliseconds(5000)), 128 + SIGKILL);
}

TEST(ChildProcess, AProgramThatDoesNotExistIsNotFound) {
  EXPECT_THROW(ChildProcess({"/nonexistent/fleetmapd"}), Error);
}

}  // namespace
}  // namespace fleetmap
