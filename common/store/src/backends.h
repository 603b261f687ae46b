// Constructors of the GraphStore backends; GraphStore::Open picks one by URI scheme.
#pragma once

#include <memory>
#include <string>

#include "fleetmap/store/graph_store.h"

namespace fleetmap::internal {

std::unique_ptr<GraphStore> OpenSqliteGraphStore(const std::string& path,
                                                 const StoreOptions& options);
std::unique_ptr<GraphStore> OpenPostgresGraphStore(const std::string& uri,
                                                   const StoreOptions& options);

// "postgresql://user:secret@host/db" -> "postgresql://user@host/db", for logs and errors.
std::string RedactPassword(const std::string& uri);

}  // namespace fleetmap::internal
