// The PostgreSQL AnnotationStore (postgres_annotation_store.cc), made by the PostgreSQL
// GraphStore.
#pragma once

#include <memory>

#include "fleetmap/store/annotation_store.h"
#include "postgres/pg_session.h"

namespace fleetmap::internal {

// An AnnotationStore on `session`, sharing its explicit Transaction. REQUIRES: the database
// migrated to schema 4 or later; session outlives the result.
std::unique_ptr<AnnotationStore> NewPostgresAnnotationStore(PgSession& session);

}  // namespace fleetmap::internal
