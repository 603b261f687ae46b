// See raw_sqlite_connection.h.
#include "raw_sqlite_connection.h"

#include "fleetmap/core/error.h"

namespace fleetmap::bench {

RawSqliteConnection::RawSqliteConnection(const std::string& path, Durability durability)
    : path_(path) {
  // The flags GraphStore's SQLite backend uses.
  const int flags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_NOMUTEX;
  const int rc = sqlite3_open_v2(path.c_str(), &db_, flags, nullptr);
  if (rc != SQLITE_OK) {
    const std::string message = db_ ? sqlite3_errmsg(db_) : sqlite3_errstr(rc);
    sqlite3_close(db_);
    throw Error(ErrorCode::kBackend, "raw sqlite baseline: cannot open " + path + ": " + message);
  }
  try {
    Exec("PRAGMA journal_mode=WAL");
    Exec(durability == Durability::kSynchronous ? "PRAGMA synchronous=FULL"
                                                : "PRAGMA synchronous=OFF");
    Exec("PRAGMA foreign_keys=ON");
    Exec("PRAGMA cache_size=-32768");
  } catch (...) {
    sqlite3_close(db_);
    throw;
  }
}

// Statements are finalized by their owners before this runs (they are members declared after
// the connection, or released first); sqlite3_close_v2 would otherwise defer the close.
RawSqliteConnection::~RawSqliteConnection() {
  sqlite3_close_v2(db_);
}

void RawSqliteConnection::Fail(const std::string& what) const {
  throw Error(ErrorCode::kBackend,
              "raw sqlite baseline " + path_ + ": " + what + ": " + sqlite3_errmsg(db_));
}

void RawSqliteConnection::Exec(const char* sql) {
  if (sqlite3_exec(db_, sql, nullptr, nullptr, nullptr) != SQLITE_OK) Fail(sql);
}

SqliteStatement RawSqliteConnection::Prepare(const char* sql) {
  sqlite3_stmt* s = nullptr;
  if (sqlite3_prepare_v3(db_, sql, -1, SQLITE_PREPARE_PERSISTENT, &s, nullptr) != SQLITE_OK) {
    Fail(std::string("prepare ") + sql);
  }
  return SqliteStatement(s);
}

int RawSqliteConnection::Step(sqlite3_stmt* s) {
  const int rc = sqlite3_step(s);
  if (rc == SQLITE_ROW || rc == SQLITE_DONE) return rc;
  const std::string sql = sqlite3_sql(s);
  sqlite3_reset(s);
  Fail(sql);
}

void RawSqliteConnection::Run(sqlite3_stmt* s) {
  Step(s);
  sqlite3_reset(s);
}

void RawSqliteConnection::RollbackIfOpen() {
  if (!sqlite3_get_autocommit(db_)) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
}

}  // namespace fleetmap::bench
