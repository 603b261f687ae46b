// What every experiment on the synthetic world shares: the appearance vocabulary, trained on
// drives apart from the scheduled outings, and where an outing starts.
#pragma once

#include <memory>

#include "fleetmap/ebn/appearance_index.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/world/world.h"

namespace fleetmap {

// A vocabulary trained on four drives in different light and weather, rendered apart from the
// scheduled outings so that no held-out frame shapes it. Deterministic for a world. Throws
// Error(kInvalidArgument) for a world that shows no landmarks. `options` shape it (MERGE's
// words by default; an appearance index's are finer).
std::shared_ptr<const AppearanceVocabulary> TrainWorldVocabulary(
    const World& world, const VocabularyOptions& options = {});

// Outings start docked at the depot: the map's earliest experience, saved at the loop's start
// (arc length 0) where every scheduled outing begins. A position, not a localisation. An
// outing elsewhere, or an empty map, starts lost.
OutingStart DepotStart(const Outing& outing, const ExperienceMap& map);

}  // namespace fleetmap
