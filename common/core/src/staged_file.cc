#include "fleetmap/core/staged_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cstring>
#include <string>
#include <system_error>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// An output buffer over a file descriptor it does not own: std::ofstream can only open by
// name, and opening by name again would follow whatever is at the name by then.
class DescriptorBuffer final : public std::streambuf {
 public:
  explicit DescriptorBuffer(int fd) : fd_(fd) { setp(buffer_.data(), buffer_.data() + size()); }

  // The errno of the first failed write; 0 while none failed.
  int error() const { return error_; }

 protected:
  int_type overflow(int_type c) override {
    if (!Drain()) return traits_type::eof();
    if (!traits_type::eq_int_type(c, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(c);
      pbump(1);
    }
    return traits_type::not_eof(c);
  }
  int sync() override { return Drain() ? 0 : -1; }

 private:
  std::size_t size() const { return buffer_.size(); }

  bool Drain() {
    for (const char* next = pbase(); next < pptr();) {
      const ssize_t n = ::write(fd_, next, static_cast<std::size_t>(pptr() - next));
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) {
        if (error_ == 0) error_ = errno;
        return false;
      }
      next += n;
    }
    setp(buffer_.data(), buffer_.data() + size());
    return true;
  }

  int fd_;
  int error_ = 0;
  std::array<char, 1 << 16> buffer_{};
};

}  // namespace

void SyncToDisk(const std::filesystem::path& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  const bool failed = fd < 0 || ::fsync(fd) != 0;
  const int error = errno;
  if (fd >= 0) ::close(fd);
  if (failed) {
    throw Error(ErrorCode::kBackend,
                "cannot sync " + path.string() + " to disk: " + std::strerror(error));
  }
}

StagedFile::StagedFile(const std::filesystem::path& path, const StagedFileOptions& options)
    : path_(path), staging_(path.string() + ".tmp") {
  if (std::filesystem::is_directory(path_)) {
    throw Error(ErrorCode::kInvalidArgument, path_.string() + " is a directory");
  }
  CreateStaging(options);
  buffer_ = std::make_unique<DescriptorBuffer>(fd_);
  stream_.rdbuf(buffer_.get());
}

void StagedFile::CreateStaging(const StagedFileOptions& options) {
  constexpr int kFlags = O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC;
  const auto mode = static_cast<mode_t>(options.permissions);
  fd_ = ::open(staging_.c_str(), kFlags, mode);
  if (fd_ >= 0 || errno != EEXIST) {
    if (fd_ < 0) Fail("cannot create " + staging_.string(), errno);
    return;
  }
  struct stat st {};
  if (!options.replace_foreign_staging && ::lstat(staging_.c_str(), &st) == 0 &&
      !S_ISREG(st.st_mode)) {
    throw Error(ErrorCode::kConflict,
                staging_.string() +
                    (S_ISLNK(st.st_mode) ? " is a symbolic link" : " is not a regular file") +
                    ", where " + path_.string() +
                    " is staged; it is not written through: remove it and try again");
  }
  // Unlinking removes the name only (never what a link would point to), and O_EXCL refuses
  // whatever may have taken the name meanwhile.
  if (::unlink(staging_.c_str()) != 0 && errno != ENOENT) {
    Fail("cannot remove the stale " + staging_.string(), errno);
  }
  fd_ = ::open(staging_.c_str(), kFlags, mode);
  if (fd_ < 0) Fail("cannot create " + staging_.string(), errno);
}

StagedFile::~StagedFile() {
  if (fd_ >= 0) ::close(fd_);
  if (committed_) return;
  std::error_code ignored;
  std::filesystem::remove(staging_, ignored);
}

void StagedFile::Commit() {
  stream_.flush();
  const int write_error = static_cast<DescriptorBuffer&>(*buffer_).error();
  if (!stream_ || write_error != 0) Fail("cannot write " + staging_.string(), write_error);
  // Durable before it is renamed into place, so a power cut cannot leave PATH empty.
  if (::fsync(fd_) != 0) Fail("cannot sync " + staging_.string(), errno);
  const int fd = fd_;
  fd_ = -1;
  if (::close(fd) != 0) Fail("cannot close " + staging_.string(), errno);
  std::error_code renamed;
  std::filesystem::rename(staging_, path_, renamed);
  if (renamed) {
    throw Error(ErrorCode::kBackend, "cannot rename " + staging_.string() + " into place as " +
                                         path_.string() + ": " + renamed.message());
  }
  // The staging name is gone: nothing of ours is left there to remove.
  committed_ = true;
  SyncToDisk(path_.parent_path().empty() ? std::filesystem::path(".") : path_.parent_path());
}

void StagedFile::Fail(const std::string& what, int error) const {
  throw Error(ErrorCode::kBackend,
              what + (error != 0 ? std::string(": ") + std::strerror(error) : std::string()));
}

}  // namespace fleetmap
