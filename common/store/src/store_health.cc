#include "fleetmap/store/store_health.h"

namespace fleetmap {

IdSample StoreHealth::DanglingEdges(std::size_t examples) {
  return DoSampleIds(
      "FROM edges e WHERE NOT EXISTS (SELECT 1 FROM nodes n WHERE n.id = e.from_id)"
      " OR NOT EXISTS (SELECT 1 FROM nodes n WHERE n.id = e.to_id)"
      " OR (e.path_id IS NOT NULL AND NOT EXISTS (SELECT 1 FROM paths p WHERE p.id = e.path_id))",
      "e.id", examples);
}

IdSample StoreHealth::OrphanVersions(std::size_t examples) {
  // element_versions.kind: 1 node, 2 edge, 3 path.
  return DoSampleIds(
      "FROM element_versions v WHERE"
      " (v.kind = 1 AND NOT EXISTS (SELECT 1 FROM nodes x WHERE x.id = v.id))"
      " OR (v.kind = 2 AND NOT EXISTS (SELECT 1 FROM edges x WHERE x.id = v.id))"
      " OR (v.kind = 3 AND NOT EXISTS (SELECT 1 FROM paths x WHERE x.id = v.id))"
      " OR v.added_rev > (SELECT coalesce(max(number), 0) FROM revisions)"
      " OR v.hidden_rev > (SELECT coalesce(max(number), 0) FROM revisions)",
      "v.id", examples);
}

}  // namespace fleetmap
