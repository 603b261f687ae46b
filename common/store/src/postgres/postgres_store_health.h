// The PostgreSQL StoreHealth (postgres_store_health.cc), made by the PostgreSQL GraphStore.
#pragma once

#include <memory>

#include "fleetmap/store/store_health.h"
#include "postgres/pg_session.h"

namespace fleetmap::internal {

// A StoreHealth on the connection of `session`. REQUIRES: the database migrated; `session`
// outlives the result.
std::unique_ptr<StoreHealth> NewPostgresStoreHealth(PgSession& session);

}  // namespace fleetmap::internal
