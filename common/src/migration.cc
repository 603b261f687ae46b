#include "migration.h"

#include "fleetmap/common/error.h"

namespace fleetmap::internal {

void RefuseNewerSchema(const std::string& store, int current, int latest) {
  if (current <= latest) return;
  throw Error(ErrorCode::kSchemaTooNew, "store " + store + " has schema version " +
                                            std::to_string(current) +
                                            ", newer than this fleetmap (knows up to " +
                                            std::to_string(latest) + "); use a newer fleetmap");
}

}  // namespace fleetmap::internal
