// Asserts that a call throws fleetmap::Error with a given code, and optionally that its message
// names something (a UUID, a revision, a file): errors must say what went wrong where.
#pragma once

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

inline void ExpectError(ErrorCode code, const std::function<void()>& fn,
                        const std::string& mention = "") {
  try {
    fn();
    ADD_FAILURE() << "expected error " << ErrorCodeName(code);
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), code) << e.what();
    if (!mention.empty()) {
      EXPECT_NE(std::string(e.what()).find(mention), std::string::npos)
          << "'" << e.what() << "' should mention " << mention;
    }
  }
}

}  // namespace fleetmap
