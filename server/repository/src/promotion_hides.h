// Which nodes a promotion hides (Repository::Promote, seed 004 §VI-E). The candidate replaces
// what the merges of its groups added, so the nodes of those merges it did without are hidden,
// except what the map has built on since: a node an edge of another revision (a later merge)
// hangs from is kept, with the shortest chain of would-be-hidden nodes joining it to the rest
// of the map, so a later merge is never cut off the map.
#pragma once

#include <set>
#include <vector>

#include "fleetmap/store/version_store.h"

namespace fleetmap {

// `merged_groups`: the candidate's groups (submissions) in the order the server merged them;
// `visible`: the nodes at `head`; `kept`: the candidate's nodes. Returns the nodes to hide, in
// a stable order. Throws as the store does.
std::vector<Uuid> NodesPromotionHides(VersionStore& versions, RevisionNumber head,
                                      const std::vector<Uuid>& merged_groups,
                                      const std::set<Uuid>& visible, const std::set<Uuid>& kept);

}  // namespace fleetmap
