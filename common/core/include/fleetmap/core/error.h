// The project's error type. Every backend, codec and parser reports failure by throwing
// fleetmap::Error with a code a caller can branch on and a message a person can act on
// (which file, which UUID, which statement). Library exceptions (libpqxx, SQLite, protobuf)
// are caught at the boundary that produced them and rethrown as this type.
#pragma once

#include <stdexcept>
#include <string>
#include <string_view>

namespace fleetmap {

enum class ErrorCode {
  kInvalidArgument,  // the caller passed something malformed (bad UUID text, bad URI)
  kNotFound,         // an unknown UUID or a missing file
  kConflict,         // same UUID already stored with different content
  kIntegrity,        // refused because it would break the graph (dangling edge endpoint)
  kSchemaTooNew,     // the database was written by a newer fleetmap
  kCorrupt,          // stored bytes that do not decode
  kBackend,          // the database itself failed (I/O, connection, SQL)
};

// Short stable name of a code, e.g. "not-found".
std::string_view ErrorCodeName(ErrorCode code);

class Error : public std::runtime_error {
 public:
  Error(ErrorCode code, const std::string& message);

  ErrorCode code() const { return code_; }
  // The message without the code's name in front (what() has "code-name: message"), for
  // adding context: Error(e.code(), "context: " + e.message()).
  const std::string& message() const { return message_; }

 private:
  ErrorCode code_;
  std::string message_;
};

}  // namespace fleetmap
