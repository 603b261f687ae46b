// Raw baselines for `fleetmap bench graph`: the chain workload (chain_workload.h) written
// directly against sqlite3 prepared statements and libpqxx, the code one would write without
// GraphStore; and for `bench limits`, the sensor index's bulk ingest by plain COPY. They run on
// tables created by GraphStore's own migrations and open their connections with the same settings,
// so what differs is our API layer only.
//
// Scratch-database helpers for the PostgreSQL runs live here too, so libpqxx stays in one file.
#pragma once

#include <memory>
#include <span>
#include <string>

#include "chain_workload.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"

namespace fleetmap::bench {

// Opens the SQLite file at path with GraphStore's pragmas (WAL; synchronous FULL or OFF by
// durability; foreign keys on; 32 MiB cache). REQUIRES: the file already holds the schema
// (create it by opening a GraphStore on it first).
std::unique_ptr<ChainWorkload> OpenRawSqliteChain(const std::string& path, Durability durability);

// Connects to a PostgreSQL database by URI; buffered durability sets synchronous_commit = off
// on the session. REQUIRES: the database already holds the schema. Batch writes use COPY.
std::unique_ptr<ChainWorkload> OpenRawPostgresChain(const std::string& uri, Durability durability);

// Sensor index rows COPYed straight into the data table, one transaction per Insert (files
// get their rows as first met). REQUIRES: the schema, platform and sensors exist.
class RawPostgresIngest {
 public:
  virtual ~RawPostgresIngest() = default;
  virtual void Insert(std::span<const Datum> rows) = 0;
};
std::unique_ptr<RawPostgresIngest> OpenRawPostgresIngest(const std::string& uri,
                                                         Durability durability);

// Empties every graph table of the database at uri (the schema stays).
void TruncatePostgresGraphTables(const std::string& uri);

// Collects planner statistics for the graph tables (what autovacuum would do later).
void AnalyzePostgresGraphTables(const std::string& uri);

// `uri` naming `database` instead: "postgresql://u@h:5432/postgres?x=y" with "db" gives
// "postgresql://u@h:5432/db?x=y". Throws Error(kInvalidArgument) for a URI without "://".
std::string UriWithDatabase(const std::string& uri, const std::string& database);

// CREATE DATABASE / DROP DATABASE ... WITH (FORCE) through a connection to admin_uri.
// REQUIRES: name is a plain identifier ([a-z0-9_]).
void CreatePostgresDatabase(const std::string& admin_uri, const std::string& name);
void DropPostgresDatabase(const std::string& admin_uri, const std::string& name);

}  // namespace fleetmap::bench
