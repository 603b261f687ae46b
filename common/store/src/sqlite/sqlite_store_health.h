// The SQLite StoreHealth (sqlite_store_health.cc), made by the SQLite GraphStore.
#pragma once

#include <sqlite3.h>

#include <memory>
#include <string>

#include "fleetmap/store/store_health.h"

namespace fleetmap::internal {

// A StoreHealth on connection `db` of the file at `path`. REQUIRES: db migrated; the result
// is destroyed before db is closed.
std::unique_ptr<StoreHealth> NewSqliteStoreHealth(sqlite3* db, std::string path);

}  // namespace fleetmap::internal
