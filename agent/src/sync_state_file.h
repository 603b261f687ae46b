// The sync state as a file (local_map.h: DIR/sync.json): JSON, UUIDs in canonical text, so a
// person can read what the agent believes the server has. Its id sets are in map.db
// (id_tables.h); the file names the generation of them that goes with it, and their sizes.
#pragma once

#include <filesystem>
#include <string>

#include "fleetmap/agent/local_map.h"

namespace fleetmap::agent_internal {

// The state's scalars, and its sets' generation and sizes; not the sets.
std::string SyncStateToJson(const SyncState& state);

// A state as a file holds it: without its sets, unless the file came from an agent that wrote
// them inline (ids_inline: the sets are in `state`, to be moved into map.db).
struct StoredSyncState {
  SyncState state;
  SyncStateCounts counts;
  bool ids_inline = false;
};
// Throws Error(kCorrupt) naming `source` for text that is not a state this build reads.
StoredSyncState SyncStateFromJson(const std::string& text, const std::string& source);

// The state in `path`; the empty state when the file does not exist. Throws as
// SyncStateFromJson, Error(kBackend) when it cannot be read.
StoredSyncState ReadSyncState(const std::filesystem::path& path);
// Writes `text` to `path` so that a crash leaves either the old file or the new one whole
// (fleetmap/core/staged_file.h: path.tmp, fsync, rename, fsync of the directory), with the
// agent's choices: mode 0644, and whatever is at path.tmp replaced, never written through.
// Throws Error(kBackend) naming the file.
void WriteFileAtomically(const std::filesystem::path& path, const std::string& text);

}  // namespace fleetmap::agent_internal
