// The robot's own work the server holds and its map lost (a deleted or emptied map.db, a lost
// sync.json): after an install, its submissions the installed revision does not hold are asked
// for (sync.proto OwnSubmissionsRequest), fetched a chunk at a time as it pushed them, checked
// against their digests and written back into map.db as unmerged (LocalMap::RestoreSubmission).
#pragma once

#include <cstddef>
#include <functional>
#include <string>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/agent/sync_client.h"

namespace fleetmap::agent_internal {

struct OwnWorkRestored {
  std::size_t submissions = 0;  // restored into map.db
  std::size_t elements = 0;     // written (those map.db held already are not counted)
  std::size_t dangling_edges = 0;
  bool complete = false;  // every submission listed was restored (the restore is finished)
};

// REQUIRES: `client` is past its hello, in a session of this map's robot. Throws what the
// client throws, and Error(kCorrupt) for a submission whose chunks do not match its digest.
OwnWorkRestored RestoreOwnWork(SyncClient& client, LocalMap& map,
                               const std::function<void(const std::string&)>& progress);

}  // namespace fleetmap::agent_internal
