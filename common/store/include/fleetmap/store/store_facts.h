// What is in a map store, at a glance: what `fleetmap info` prints (in the manner of
// `mcap info` or RTAB-Map's database viewer). Read from the store's own tables; only reads.
#pragma once

#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/store_health.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

struct StoreFacts {
  std::string uri;     // as the store names itself (passwords removed)
  std::string engine;  // StoreHealth::Engine
  int schema_version = 0;
  std::int64_t bytes_on_disk = 0;
  StoreStats stored;  // everything stored, hidden elements too
  RevisionNumber head = 0;
  StoreStats at_head;  // the map at the head revision (nodes, edges, paths, landmark bytes)
  std::optional<Revision> last_revision;
  // Submissions by state name ("receiving", "queued", "merged", "failed"); states with none
  // are absent.
  std::map<std::string, std::int64_t> submissions;
  std::vector<RobotNodes> robots;         // robots with nodes in the store
  std::optional<std::int64_t> oldest_ns;  // the oldest node's stamp, UTC; none when empty
  std::optional<std::int64_t> newest_ns;
};

// Reads the facts of `store`. Throws what the store throws (Error(kBackend) and the like).
StoreFacts DescribeStore(GraphStore& store);

}  // namespace fleetmap
