// The files of a robot's map directory (local_map.h) and the file operations its opening and
// its installs share.
#pragma once

#include <filesystem>
#include <string_view>

namespace fleetmap::agent_internal {

inline constexpr const char* kStateFile = "sync.json";
inline constexpr const char* kNextStateFile = "sync.json.next";
inline constexpr const char* kMapFile = "map.db";
inline constexpr const char* kNewMapFile = "map.db.new";
inline constexpr const char* kLockFile = "agent.lock";

// Where an install in place records its token in map.db (the VersionStore's settings).
inline constexpr std::string_view kInstallTokenKey = "agent.install_token";

// `path` with `suffix` appended to its file name.
std::filesystem::path WithSuffix(const std::filesystem::path& path, const char* suffix);

// A SQLite database and the log and index files SQLite keeps beside it.
void RemoveDatabaseFiles(const std::filesystem::path& db);

// A write-ahead log with content beside `db`: another connection has it open (the last one to
// close checkpoints the log into the file and deletes it).
bool HasLiveLog(const std::filesystem::path& db);

// rename(2), or Error(kBackend) saying why not.
void Rename(const std::filesystem::path& from, const std::filesystem::path& to);

}  // namespace fleetmap::agent_internal
