// The range checks of the conditions' parameter structs: one message form for every field.
#pragma once

#include <cmath>
#include <sstream>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap::conditions_internal {

// Throws Error(kInvalidArgument) "<what>: <field> must be in [lo, hi], got v" unless lo <= v <=
// hi (a NaN is never in range). An open end ("(lo" or "hi)") excludes its bound.
inline void RequireInRange(const std::string& what, const std::string& field, double value,
                           double lo, double hi, bool lo_open = false, bool hi_open = false) {
  const bool above = lo_open ? value > lo : value >= lo;
  const bool below = hi_open ? value < hi : value <= hi;
  if (above && below && std::isfinite(value)) return;
  std::ostringstream message;
  message << what << ": " << field << " must be in " << (lo_open ? "(" : "[") << lo << ", " << hi
          << (hi_open ? ")" : "]") << ", got " << value;
  throw Error(ErrorCode::kInvalidArgument, message.str());
}

[[noreturn]] inline void RejectParameter(const std::string& what, const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, what + ": " + message);
}

}  // namespace fleetmap::conditions_internal
