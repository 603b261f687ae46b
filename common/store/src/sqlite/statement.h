// A thin RAII layer over sqlite3 prepared statements. Every SQLite error becomes
// fleetmap::Error carrying the database file and the statement's SQL.
#pragma once

#include <sqlite3.h>

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>

#include "fleetmap/core/error.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap::internal {

// One SQL statement from pieces (column lists shared between statements, say).
inline std::string Sql(std::initializer_list<std::string_view> parts) {
  std::string sql;
  for (std::string_view p : parts) sql += p;
  return sql;
}

// Throws Error(kBackend) (or kIntegrity for constraint failures) with context.
[[noreturn]] void ThrowSqlite(sqlite3* db, int rc, const std::string& context);

// Runs one or more statements without results (DDL, PRAGMA, BEGIN/COMMIT).
void ExecSql(sqlite3* db, const char* sql);

class Statement {
 public:
  Statement(sqlite3* db, const char* sql);
  ~Statement();
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  // Binders take 1-based parameter indexes, as sqlite3_bind_*. Nothing is copied
  // (SQLITE_STATIC) unless said: a bound value must outlive the next Step(), so never bind a
  // temporary.
  void Bind(int index, const Uuid& id) {
    Check(sqlite3_bind_blob(stmt_, index, id.data(), Uuid::kSize, SQLITE_STATIC));
  }
  void BindNullableUuid(int index, const Uuid& id) {
    if (id.IsNil()) {
      Check(sqlite3_bind_null(stmt_, index));
    } else {
      Bind(index, id);
    }
  }
  void Bind(int index, std::int64_t value) { Check(sqlite3_bind_int64(stmt_, index, value)); }
  void Bind(int index, double value) { Check(sqlite3_bind_double(stmt_, index, value)); }
  // The bytes must outlive the next Step(): they are bound without a copy.
  void BindBlob(int index, std::string_view bytes) {
    Check(sqlite3_bind_blob64(stmt_, index, bytes.data(), bytes.size(), SQLITE_STATIC));
  }
  // A copy is bound (SQLITE_TRANSIENT), so `bytes` may be a temporary.
  void BindBlobCopy(int index, std::string_view bytes) {
    Check(sqlite3_bind_blob64(stmt_, index, bytes.data(), bytes.size(), SQLITE_TRANSIENT));
  }
  void BindNull(int index) { Check(sqlite3_bind_null(stmt_, index)); }
  void BindText(int index, std::string_view text) {
    Check(sqlite3_bind_text64(stmt_, index, text.data(), text.size(), SQLITE_STATIC, SQLITE_UTF8));
  }

  // Advances; true while a row is available. Throws on error.
  bool Step();
  // Step() for statements without results; returns the number of rows changed.
  int Run();
  // Clears bindings' effect and rewinds so the statement can run again.
  void Reset() {
    sqlite3_reset(stmt_);
    sqlite3_clear_bindings(stmt_);
  }

  std::int64_t Int64(int column) const { return sqlite3_column_int64(stmt_, column); }
  double Double(int column) const { return sqlite3_column_double(stmt_, column); }
  bool IsNull(int column) const { return sqlite3_column_type(stmt_, column) == SQLITE_NULL; }
  std::string_view Blob(int column) const;
  std::string Text(int column) const;
  // A 16-byte UUID column; NULL reads as nil. A blob of another size is corrupt.
  Uuid UuidAt(int column) const;

  const char* sql() const { return sqlite3_sql(stmt_); }

 private:
  void Check(int rc);

  sqlite3* db_;
  sqlite3_stmt* stmt_ = nullptr;
};

// Resets a statement when leaving scope, so an exception never leaves it mid-step.
class StatementUse {
 public:
  explicit StatementUse(Statement& statement) : statement_(statement) {}
  ~StatementUse() { statement_.Reset(); }
  Statement* operator->() { return &statement_; }
  Statement& operator*() { return statement_; }

 private:
  Statement& statement_;
};

}  // namespace fleetmap::internal
