// The prepared statements of the PostgreSQL VersionStore (postgres_version_store.cc), named
// "version_...": the SQL apart from the calls that run it, as sqlite_version_statements.h does for
// SQLite.
#pragma once

#include <pqxx/pqxx>

namespace fleetmap::internal {

// Prepares every statement on `c` (one named step per family: submissions, claims, revisions,
// element versions, the map at a revision, seen nodes, settings, retirement).
void PrepareVersionStatements(pqxx::connection& c);

}  // namespace fleetmap::internal
