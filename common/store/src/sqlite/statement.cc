#include "sqlite/statement.h"

namespace fleetmap::internal {

void ThrowSqlite(sqlite3* db, int rc, const std::string& context) {
  const std::string file = db ? sqlite3_db_filename(db, "main") : "";
  const std::string message = (db ? sqlite3_errmsg(db) : sqlite3_errstr(rc));
  const ErrorCode code = (rc & 0xff) == SQLITE_CONSTRAINT ? ErrorCode::kIntegrity
                         : (rc & 0xff) == SQLITE_CORRUPT || (rc & 0xff) == SQLITE_NOTADB
                             ? ErrorCode::kCorrupt
                             : ErrorCode::kBackend;
  throw Error(code, "sqlite " + file + ": " + message + " (in: " + context + ")");
}

void ExecSql(sqlite3* db, const char* sql) {
  char* error = nullptr;
  const int rc = sqlite3_exec(db, sql, nullptr, nullptr, &error);
  if (rc != SQLITE_OK) {
    const std::string message = error ? error : sqlite3_errstr(rc);
    sqlite3_free(error);
    ThrowSqlite(db, rc, std::string(sql).substr(0, 200) + " -> " + message);
  }
}

Statement::Statement(sqlite3* db, const char* sql) : db_(db) {
  const int rc = sqlite3_prepare_v3(db, sql, -1, SQLITE_PREPARE_PERSISTENT, &stmt_, nullptr);
  if (rc != SQLITE_OK) ThrowSqlite(db, rc, std::string("prepare: ") + sql);
}

Statement::~Statement() {
  sqlite3_finalize(stmt_);
}

bool Statement::Step() {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return true;
  if (rc == SQLITE_DONE) return false;
  ThrowSqlite(db_, rc, sqlite3_sql(stmt_));
}

int Statement::Run() {
  while (Step()) {
  }
  return sqlite3_changes(db_);
}

std::string_view Statement::Blob(int column) const {
  const void* data = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  return data ? std::string_view(static_cast<const char*>(data), static_cast<std::size_t>(size))
              : std::string_view();
}

std::string Statement::Text(int column) const {
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  return text ? std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(size))
              : std::string();
}

Uuid Statement::UuidAt(int column) const {
  if (IsNull(column)) return Uuid();
  const std::string_view raw = Blob(column);
  if (raw.size() != Uuid::kSize) {
    throw Error(ErrorCode::kCorrupt, "stored UUID of " + std::to_string(raw.size()) +
                                         " bytes (in: " + sqlite3_sql(stmt_) + ")");
  }
  return Uuid::FromBytes(raw);
}

void Statement::Check(int rc) {
  if (rc != SQLITE_OK) ThrowSqlite(db_, rc, std::string("bind: ") + sqlite3_sql(stmt_));
}

}  // namespace fleetmap::internal
