// A plain sqlite3 connection for the raw baselines (raw_baseline.h, raw_sensor_index.h): opened
// with the pragmas GraphStore's SQLite backend uses, so a baseline differs from our store by
// the API layer only. Every failure throws Error(kBackend) naming the file and the SQL.
#pragma once

#include <sqlite3.h>

#include <memory>
#include <string>

#include "fleetmap/store/graph_store.h"

namespace fleetmap::bench {

struct SqliteStatementFinalizer {
  void operator()(sqlite3_stmt* s) const { sqlite3_finalize(s); }
};
using SqliteStatement = std::unique_ptr<sqlite3_stmt, SqliteStatementFinalizer>;

class RawSqliteConnection {
 public:
  // WAL; synchronous FULL (kSynchronous) or OFF; foreign keys on; 32 MiB cache.
  RawSqliteConnection(const std::string& path, Durability durability);
  ~RawSqliteConnection();
  RawSqliteConnection(const RawSqliteConnection&) = delete;
  RawSqliteConnection& operator=(const RawSqliteConnection&) = delete;

  sqlite3* db() const { return db_; }
  void Exec(const char* sql);
  SqliteStatement Prepare(const char* sql);
  // SQLITE_ROW or SQLITE_DONE; anything else throws (after rewinding the statement).
  int Step(sqlite3_stmt* s);
  // Step() then rewind, for statements without results.
  void Run(sqlite3_stmt* s);
  // Runs body between BEGIN IMMEDIATE and COMMIT; rolls back if it throws.
  template <typename Body>
  void InTransaction(Body&& body) {
    Exec("BEGIN IMMEDIATE");
    try {
      body();
      Exec("COMMIT");
    } catch (...) {
      RollbackIfOpen();
      throw;
    }
  }
  [[noreturn]] void Fail(const std::string& what) const;

 private:
  void RollbackIfOpen();

  std::string path_;
  sqlite3* db_ = nullptr;
};

}  // namespace fleetmap::bench
