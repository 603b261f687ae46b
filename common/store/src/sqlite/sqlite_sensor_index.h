// The SQLite SensorIndex (sqlite_sensor_index.cc), made by the SQLite GraphStore.
#pragma once

#include <sqlite3.h>

#include <memory>

#include "fleetmap/store/sensor_index.h"

namespace fleetmap::internal {

// A SensorIndex on connection `db`, sharing whatever transaction is open on it.
// REQUIRES: db migrated to schema 3 or later; the result is destroyed before db is closed
// (it holds prepared statements).
std::unique_ptr<SensorIndex> NewSqliteSensorIndex(sqlite3* db);

}  // namespace fleetmap::internal
