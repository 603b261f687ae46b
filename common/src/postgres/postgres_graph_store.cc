// Placeholder until the PostgreSQL backend lands (being written now).
#include "backends.h"
#include "fleetmap/common/error.h"

namespace fleetmap::internal {

std::unique_ptr<GraphStore> OpenPostgresGraphStore(const std::string& uri, const StoreOptions&) {
  throw Error(ErrorCode::kBackend, "PostgreSQL backend not built yet: " + RedactPassword(uri));
}

std::string RedactPassword(const std::string& uri) {
  return uri;
}

}  // namespace fleetmap::internal
