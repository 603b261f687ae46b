// A file written whole or not at all: the content goes to PATH.tmp, which is flushed, synced
// and renamed over PATH only once it is complete, and the rename is made durable by syncing
// PATH's directory. A crash or a failure leaves PATH either as it was or complete; the .tmp of
// a failure is removed on the way out. Used by `fleetmap export` and `render` (their --out) and
// by the agent (its sync state).
//
// PATH.tmp is created exclusively (O_CREAT | O_EXCL | O_NOFOLLOW) and written through the
// descriptor that created it, so nothing is ever written through a symbolic link someone put
// at PATH.tmp. A regular file there is what a killed write leaves: it is
// removed and the file created anew. Anything else there (a link, a directory) is refused and
// left as it is, or, with replace_foreign_staging, unlinked (which removes the name only,
// never what a link points to). Not thread-safe.
#pragma once

#include <filesystem>
#include <memory>
#include <ostream>
#include <streambuf>

namespace fleetmap {

// fsync of a file or a directory (for a directory: the names created or renamed in it survive
// a power cut). Throws Error(kBackend) naming it.
void SyncToDisk(const std::filesystem::path& path);

struct StagedFileOptions {
  // Of the new file, less the umask. The default is what a shell's `>` creates.
  std::filesystem::perms permissions = static_cast<std::filesystem::perms>(0666);
  // A symbolic link or anything else but a regular file at PATH.tmp: false refuses it (a
  // command tells its user, who put it there); true unlinks it (a daemon's own directory,
  // where nobody would answer the refusal).
  bool replace_foreign_staging = false;
};

class StagedFile {
 public:
  // Creates PATH.tmp. Throws Error(kInvalidArgument) when PATH is a directory,
  // Error(kConflict) naming PATH.tmp when something kept there is not a regular file, and
  // Error(kBackend) naming PATH.tmp when it cannot be removed or created (no such directory,
  // no permission).
  explicit StagedFile(const std::filesystem::path& path, const StagedFileOptions& options = {});
  // Removes PATH.tmp unless committed.
  ~StagedFile();
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  // Where the content goes; failed writes surface at Commit.
  std::ostream& stream() { return stream_; }

  // Flushes and syncs PATH.tmp, renames it over PATH and syncs PATH's directory. Throws
  // Error(kBackend) naming the file and the step that failed. Call at most once.
  void Commit();

 private:
  void CreateStaging(const StagedFileOptions& options);
  [[noreturn]] void Fail(const std::string& what, int error) const;

  std::filesystem::path path_;
  std::filesystem::path staging_;
  int fd_ = -1;
  std::unique_ptr<std::streambuf> buffer_;
  std::ostream stream_{nullptr};
  bool committed_ = false;
};

}  // namespace fleetmap
