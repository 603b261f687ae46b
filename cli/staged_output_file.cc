#include "staged_output_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap::cli {

StagedOutputFile::StagedOutputFile(const std::string& path) : path_(path), staging_(path + ".tmp") {
  if (std::filesystem::is_directory(path_)) {
    throw Error(ErrorCode::kInvalidArgument, "cannot write --out " + path + ": a directory");
  }
  stream_.open(staging_, std::ios::binary | std::ios::trunc);
  if (!stream_.is_open()) Fail("cannot create " + staging_.string(), errno);
}

StagedOutputFile::~StagedOutputFile() {
  if (committed_) return;
  stream_.close();
  std::error_code ignored;
  std::filesystem::remove(staging_, ignored);
}

void StagedOutputFile::Commit() {
  stream_.flush();
  if (!stream_) Fail("cannot write " + staging_.string(), errno);
  stream_.close();
  if (stream_.fail()) Fail("cannot close " + staging_.string(), errno);
  // Durable before it is renamed into place, so a power cut cannot leave FILE empty.
  const int fd = ::open(staging_.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0 || ::fsync(fd) != 0) {
    const int error = errno;
    if (fd >= 0) ::close(fd);
    Fail("cannot sync " + staging_.string(), error);
  }
  ::close(fd);
  std::error_code renamed;
  std::filesystem::rename(staging_, path_, renamed);
  if (renamed) {
    throw Error(ErrorCode::kInvalidArgument, "cannot write --out " + path_.string() +
                                                 ": cannot rename " + staging_.string() +
                                                 " into place: " + renamed.message());
  }
  committed_ = true;
}

void StagedOutputFile::Fail(const std::string& what, int error) const {
  throw Error(ErrorCode::kInvalidArgument,
              "cannot write --out " + path_.string() + ": " + what +
                  (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
}

}  // namespace fleetmap::cli
