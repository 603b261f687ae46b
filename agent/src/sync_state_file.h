// The sync state as a file (local_map.h: DIR/sync.json): JSON, UUIDs in canonical text, so a
// person can read what the agent believes the server has.
#pragma once

#include <filesystem>
#include <string>

#include "fleetmap/agent/local_map.h"

namespace fleetmap::agent_internal {

std::string SyncStateToJson(const SyncState& state);
// Throws Error(kCorrupt) naming `source` for text that is not a state this build writes.
SyncState SyncStateFromJson(const std::string& text, const std::string& source);

// The state in `path`; the empty state when the file does not exist. Throws as
// SyncStateFromJson, Error(kBackend) when it cannot be read.
SyncState ReadSyncState(const std::filesystem::path& path);
// Writes `text` to `path` so that a crash leaves either the old file or the new one whole
// (fleetmap/core/staged_file.h: path.tmp, fsync, rename, fsync of the directory), with the
// agent's choices: mode 0644, and whatever is at path.tmp replaced, never written through.
// Throws Error(kBackend) naming the file.
void WriteFileAtomically(const std::filesystem::path& path, const std::string& text);

}  // namespace fleetmap::agent_internal
