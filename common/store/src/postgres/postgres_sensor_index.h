// The PostgreSQL SensorIndex (postgres_sensor_index.cc), made by the PostgreSQL GraphStore.
#pragma once

#include <memory>

#include "fleetmap/store/sensor_index.h"
#include "postgres/pg_session.h"

namespace fleetmap::internal {

// A SensorIndex on the connection of `session`, sharing its explicit Transaction.
// REQUIRES: the session's database migrated to schema 3 or later; `session` outlives the
// result.
std::unique_ptr<SensorIndex> NewPostgresSensorIndex(PgSession& session);

}  // namespace fleetmap::internal
