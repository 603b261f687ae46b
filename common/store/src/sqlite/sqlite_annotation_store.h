// The SQLite AnnotationStore (sqlite_annotation_store.cc), made by the SQLite GraphStore.
#pragma once

#include <sqlite3.h>

#include <memory>

#include "fleetmap/store/annotation_store.h"

namespace fleetmap::internal {

// An AnnotationStore on connection `db`, sharing whatever transaction is open on it.
// REQUIRES: db migrated to schema 4 or later; the result is destroyed before db is closed.
std::unique_ptr<AnnotationStore> NewSqliteAnnotationStore(sqlite3* db);

}  // namespace fleetmap::internal
