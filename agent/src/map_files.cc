// The robot's map directory's file operations (map_files.h).
#include "map_files.h"

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap::agent_internal {

namespace fs = std::filesystem;

fs::path WithSuffix(const fs::path& path, const char* suffix) {
  return path.string() + suffix;
}

void RemoveDatabaseFiles(const fs::path& db) {
  std::error_code ignored;
  fs::remove(db, ignored);
  fs::remove(WithSuffix(db, "-wal"), ignored);
  fs::remove(WithSuffix(db, "-shm"), ignored);
  fs::remove(WithSuffix(db, "-journal"), ignored);
}

bool HasLiveLog(const fs::path& db) {
  std::error_code ec;
  const auto size = fs::file_size(WithSuffix(db, "-wal"), ec);
  return !ec && size > 0;
}

void Rename(const fs::path& from, const fs::path& to) {
  if (::rename(from.c_str(), to.c_str()) != 0) {
    throw Error(ErrorCode::kBackend, "cannot rename " + from.string() + " to " + to.string() +
                                         ": " + std::strerror(errno));
  }
}

}  // namespace fleetmap::agent_internal
