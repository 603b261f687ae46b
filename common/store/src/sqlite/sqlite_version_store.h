// The SQLite VersionStore (sqlite_version_store.cc), made by the SQLite GraphStore.
#pragma once

#include <sqlite3.h>

#include <memory>

#include "fleetmap/store/version_store.h"

namespace fleetmap::internal {

// A VersionStore on connection `db`, sharing whatever transaction is open on it.
// REQUIRES: db migrated to schema 2 or later; the result is destroyed before db is closed
// (it holds prepared statements).
std::unique_ptr<VersionStore> NewSqliteVersionStore(sqlite3* db);

}  // namespace fleetmap::internal
