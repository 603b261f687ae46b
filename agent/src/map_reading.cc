// Reading the robot's map for its installs (map_reading.h).
#include "map_reading.h"

namespace fleetmap::agent_internal {

void SortById(GraphBatch& batch) {
  SortById(batch.nodes);
  SortById(batch.edges);
  SortById(batch.paths);
}

bool InAny(const ElementIds& a, const ElementIds& b, const Uuid& id, int kind) {
  return OfKind(a, kind).contains(id) || OfKind(b, kind).contains(id);
}

GraphBatch ReadWholeMap(const std::string& uri) {
  const std::unique_ptr<GraphStore> store = GraphStore::Open(uri);
  return store->ReadMap();
}

}  // namespace fleetmap::agent_internal
