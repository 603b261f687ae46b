#include "fleetmap/core/error.h"

namespace fleetmap {

std::string_view ErrorCodeName(ErrorCode code) {
  switch (code) {
    case ErrorCode::kInvalidArgument:
      return "invalid-argument";
    case ErrorCode::kNotFound:
      return "not-found";
    case ErrorCode::kConflict:
      return "conflict";
    case ErrorCode::kIntegrity:
      return "integrity";
    case ErrorCode::kSchemaTooNew:
      return "schema-too-new";
    case ErrorCode::kCorrupt:
      return "corrupt";
    case ErrorCode::kBackend:
      return "backend";
  }
  return "unknown";
}

Error::Error(ErrorCode code, const std::string& message)
    : std::runtime_error(std::string(ErrorCodeName(code)) + ": " + message),
      code_(code),
      message_(message) {}

}  // namespace fleetmap
