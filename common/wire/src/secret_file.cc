#include "fleetmap/wire/secret_file.h"

#include <sys/stat.h>

#include <cstdio>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

void RequirePrivateSecretFile(const std::filesystem::path& path, std::string_view what) {
  struct stat status {};
  if (::stat(path.c_str(), &status) != 0) return;
  const mode_t mode = status.st_mode & 07777;
  if ((mode & (S_IRWXG | S_IRWXO)) == 0) return;
  char octal[8];
  std::snprintf(octal, sizeof octal, "%04o", static_cast<unsigned>(mode));
  throw Error(ErrorCode::kInvalidArgument,
              std::string(what) + " " + path.string() +
                  " can be read or written by its group or others (mode " + octal +
                  "); a secret must be private to its owner, as ssh requires of keys: run "
                  "`chmod 600 " +
                  path.string() + "`");
}

}  // namespace fleetmap
