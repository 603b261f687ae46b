#include "fleetmap/core/staged_file.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "scratch_dir.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

std::string ReadText(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

void WriteText(const fs::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(StagedFile, ReplacesTheFileOnlyWhenCommitted) {
  const ScratchDir dir("fleetmap-staged-file");
  const fs::path path = dir / "out.txt";
  WriteText(path, "old\n");
  {
    StagedFile file(path);
    file.stream() << "half of it";
    EXPECT_TRUE(fs::exists(path.string() + ".tmp"));
    EXPECT_EQ(ReadText(path), "old\n");
  }  // not committed: as if the writer failed
  EXPECT_EQ(ReadText(path), "old\n");
  EXPECT_FALSE(fs::exists(path.string() + ".tmp"));

  StagedFile file(path);
  file.stream() << "new\n";
  file.Commit();
  EXPECT_EQ(ReadText(path), "new\n");
  EXPECT_FALSE(fs::exists(path.string() + ".tmp"));
}

TEST(StagedFile, TakesItsPermissionsLessTheUmask) {
  const ScratchDir dir("fleetmap-staged-file");
  StagedFileOptions options;
  options.permissions = fs::perms::owner_read | fs::perms::owner_write;
  StagedFile file(dir / "private.txt", options);
  file.Commit();
  EXPECT_EQ(fs::status(dir / "private.txt").permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
}

// Never written through a symbolic link at PATH.tmp. By default the link is
// refused and left alone; with replace_foreign_staging it is unlinked (the name only). A
// regular file there (a killed write's leftover) is replaced either way.
TEST(StagedFile, NeverWritesThroughALinkAtTheStagingName) {
  const ScratchDir dir("fleetmap-staged-file");
  const fs::path victim = dir / "victim.txt";
  WriteText(victim, "precious\n");
  const fs::path path = dir / "out.txt";
  const fs::path staging = path.string() + ".tmp";
  fs::create_symlink(victim, staging);
  ExpectError(
      ErrorCode::kConflict, [&] { StagedFile file(path); },
      staging.string() + " is a symbolic link");
  EXPECT_TRUE(fs::is_symlink(staging));
  EXPECT_EQ(ReadText(victim), "precious\n");

  StagedFileOptions replace;
  replace.replace_foreign_staging = true;
  {
    StagedFile file(path, replace);
    file.stream() << "written\n";
    file.Commit();
  }
  EXPECT_EQ(ReadText(path), "written\n");
  EXPECT_FALSE(fs::is_symlink(path));
  EXPECT_EQ(ReadText(victim), "precious\n");

  WriteText(staging, "a leftover");
  StagedFile file(path);
  file.stream() << "again\n";
  file.Commit();
  EXPECT_EQ(ReadText(path), "again\n");
}

TEST(StagedFile, NamesWhatItCannotWrite) {
  const ScratchDir dir("fleetmap-staged-file");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { StagedFile file(dir.path()); }, "is a directory");
  const fs::path nowhere = dir / "no-such-dir" / "out.txt";
  ExpectError(
      ErrorCode::kBackend, [&] { StagedFile file(nowhere); },
      "cannot create " + nowhere.string() + ".tmp");
  ExpectError(
      ErrorCode::kBackend, [&] { SyncToDisk(dir / "no-such-file"); }, "no-such-file");
}

}  // namespace
}  // namespace fleetmap
