// The PostgreSQL VersionStore (postgres_version_store.cc), made by the PostgreSQL GraphStore.
#pragma once

#include <memory>

#include "fleetmap/store/version_store.h"
#include "postgres/pg_session.h"

namespace fleetmap::internal {

// A VersionStore on the connection of `session`, sharing its explicit Transaction.
// REQUIRES: the session's database migrated to schema 2 or later; `session` outlives the
// result.
std::unique_ptr<VersionStore> NewPostgresVersionStore(PgSession& session);

}  // namespace fleetmap::internal
