// Writing a map into a new store: `checkout`, `download` and `dream --out` hand a robot (or a
// person) a map of its own, so they never mix it into a store that already holds one.
#pragma once

#include <string>

#include "fleetmap/core/graph.h"
#include "fleetmap/store/graph_store.h"

namespace fleetmap::cli {

// Throws Error(kConflict) naming `uri` and `option` when the store there already holds nodes.
// An SQLite file that does not exist yet is new and is not created here, so a command that
// fails later leaves nothing behind.
void RequireNewStore(const std::string& uri, const std::string& option);

// Opens (creating) the store at `uri`, checks again that it holds no nodes, writes `map` in one
// atomic batch and returns what the store then holds.
StoreStats WriteNewStore(const std::string& uri, const std::string& option, const GraphBatch& map);

}  // namespace fleetmap::cli
