// The repository layout of record files (seed 000 §5.1: "a well-defined directory structure
// that is organised by the platform and sensors used to collect them, and time of
// collection"). Under a root (which users may mount anywhere):
//
//   PLATFORM/SENSOR/YYYY-MM-DD/PLATFORM-SENSOR-YYYYMMDD-HHMMSS.rec
//
// with the date and time in UTC, of the file's first record. The SQL index stores paths
// relative to the root (RelativeToRoot), so moving or re-mounting the root loses nothing.
// Pure functions of their arguments (no filesystem access except RelativeToRoot's path
// normalisation, which does not touch the disk), but for LinkUnderRoot; thread-safe.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string_view>

namespace fleetmap {

// Throws Error(kInvalidArgument) when `name` cannot be one path component of the layout:
// empty, ".", "..", or holding '/', '\\' or a NUL byte. `what` names the argument in the
// message ("platform", "sensor").
void CheckLayoutName(std::string_view name, std::string_view what);

// The file for a platform's sensor whose first record is at `stamp_ns` (UTC nanoseconds),
// relative to the root, e.g. "husky1/bumblebee/2014-06-02/husky1-bumblebee-20140602-093015.rec".
// Throws Error(kInvalidArgument) for a bad platform or sensor name.
std::filesystem::path RecordFilePath(std::string_view platform, std::string_view sensor,
                                     std::int64_t stamp_ns);

// `file` relative to `root` (both made absolute and lexically normalised first; symbolic links
// are not resolved). Throws Error(kInvalidArgument) naming both when `file` is not under
// `root` (or is the root itself).
std::filesystem::path RelativeToRoot(const std::filesystem::path& root,
                                     const std::filesystem::path& file);

// The inverse for reading: `root` / `relative`. Throws Error(kInvalidArgument) when `relative`
// is absolute or climbs out of the root with "..", since index rows must not point outside it.
std::filesystem::path ResolveUnderRoot(const std::filesystem::path& root,
                                       const std::filesystem::path& relative);

// Record roots are not followed through symbolic links: a link under the root may lead out of
// it (to another user's files, to /etc), and a file reached through one would be indexed under
// a path that does not say where its bytes lie. Returns the first path on the way from `root`
// to `file` that is a symbolic link (from the root's child down to `file` itself), or `file`
// when its path passes through a link before a "..", which lexical normalisation hides; nullopt
// when the way is free of links. `root` itself may be a link (a root mounted elsewhere). Reads
// the file system (lstat of each component). Throws Error(kInvalidArgument) as RelativeToRoot
// when `file` is not under `root`.
std::optional<std::filesystem::path> LinkUnderRoot(const std::filesystem::path& root,
                                                   const std::filesystem::path& file);

}  // namespace fleetmap
