// Whether a stored element is part of the map at a revision (VersionStore's versions).
#pragma once

#include <optional>

#include "fleetmap/store/version_store.h"

namespace fleetmap {

// Visible at `head`: added by then and not hidden by then.
inline bool VisibleAt(const std::optional<ElementVersion>& version, RevisionNumber head) {
  return version && version->added <= head && (!version->hidden || *version->hidden > head);
}

}  // namespace fleetmap
