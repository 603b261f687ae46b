// The two GraphStore backends as test fixtures: each hands out a fresh, empty store URI and
// can run raw SQL against it (to damage or inspect a store behind the API's back).
//
// PostgreSQL tests need FLEETMAP_TEST_PG_URI, a URI of a server where the user may CREATE
// DATABASE (scripts/test starts a throwaway cluster and exports it). Without it they skip,
// and scripts/test fails the run when any PostgreSQL test skipped.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <pqxx/pqxx>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"

namespace fleetmap::testing {

class SqliteBackend {
 public:
  static constexpr const char* kName = "Sqlite";

  SqliteBackend() {
    dir_ = std::filesystem::temp_directory_path() /
           ("fleetmap-test-" + Uuid::GenerateRandom().ToString().substr(0, 13));
    std::filesystem::create_directories(dir_);
  }
  ~SqliteBackend() {
    std::error_code ignored;
    std::filesystem::remove_all(dir_, ignored);
  }
  static std::optional<std::string> Unavailable() { return std::nullopt; }

  std::string Uri() const { return "sqlite:" + (dir_ / "store.sqlite").string(); }

  void ExecRaw(const std::string& sql) const {
    sqlite3* db = nullptr;
    sqlite3_open((dir_ / "store.sqlite").string().c_str(), &db);
    char* error = nullptr;
    const int rc = sqlite3_exec(db, sql.c_str(), nullptr, nullptr, &error);
    std::string message = error ? error : "";
    sqlite3_free(error);
    sqlite3_close(db);
    if (rc != SQLITE_OK) throw std::runtime_error("raw sqlite: " + message);
  }

  // The first column of the first row `sql` returns, as text; empty for no row or NULL.
  std::string QueryText(const std::string& sql) const {
    sqlite3* db = nullptr;
    sqlite3_open((dir_ / "store.sqlite").string().c_str(), &db);
    sqlite3_stmt* statement = nullptr;
    std::string text;
    int rc = sqlite3_prepare_v2(db, sql.c_str(), -1, &statement, nullptr);
    if (rc == SQLITE_OK) {
      rc = sqlite3_step(statement);
      if (rc == SQLITE_ROW) {
        const unsigned char* value = sqlite3_column_text(statement, 0);
        if (value) text = reinterpret_cast<const char*>(value);
        rc = SQLITE_OK;
      } else if (rc == SQLITE_DONE) {
        rc = SQLITE_OK;
      }
    }
    const std::string message = sqlite3_errmsg(db);
    sqlite3_finalize(statement);
    sqlite3_close(db);
    if (rc != SQLITE_OK) throw std::runtime_error("raw sqlite: " + message);
    return text;
  }

  // Whether a writer holds the submissions (here: the database's write lock) at this moment,
  // asked without waiting: a process stopped (SIGSTOP) inside a write keeps everyone else out
  // until it runs again.
  bool SubmissionsHeldByAWriter() const {
    sqlite3* db = nullptr;
    sqlite3_open((dir_ / "store.sqlite").string().c_str(), &db);
    sqlite3_busy_timeout(db, 0);
    const bool held = sqlite3_exec(db, "BEGIN IMMEDIATE", nullptr, nullptr, nullptr) == SQLITE_BUSY;
    if (!held) sqlite3_exec(db, "ROLLBACK", nullptr, nullptr, nullptr);
    sqlite3_close(db);
    return held;
  }

  // Everything the store consists of, to compare before and after a call that must not change
  // it: the name and bytes of every file in its directory (the database, and a -wal or -shm
  // file if there is one).
  std::string StoredState() const {
    std::vector<std::filesystem::path> files;
    for (const auto& entry : std::filesystem::directory_iterator(dir_))
      files.push_back(entry.path());
    std::sort(files.begin(), files.end());
    std::string state;
    for (const std::filesystem::path& file : files) {
      std::ifstream in(file, std::ios::binary);
      const std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
      state += file.filename().string() + " " + std::to_string(bytes.size()) + " bytes:\n" + bytes;
    }
    return state;
  }

 private:
  std::filesystem::path dir_;
};

class PostgresBackend {
 public:
  static constexpr const char* kName = "Postgres";

  static std::optional<std::string> Unavailable() {
    const char* uri = std::getenv("FLEETMAP_TEST_PG_URI");
    if (uri == nullptr || *uri == '\0') {
      return "FLEETMAP_TEST_PG_URI is not set (scripts/test starts a PostgreSQL cluster and sets "
             "it)";
    }
    return std::nullopt;
  }

  PostgresBackend() {
    if (Unavailable()) return;
    admin_uri_ = std::getenv("FLEETMAP_TEST_PG_URI");
    database_ = "fleetmap_test_" + Uuid::GenerateRandom().ToString().substr(0, 8);
    pqxx::connection admin(admin_uri_);
    pqxx::nontransaction txn(admin);
    txn.exec("CREATE DATABASE " + database_);
  }

  ~PostgresBackend() {
    if (database_.empty()) return;
    try {
      pqxx::connection admin(admin_uri_);
      pqxx::nontransaction txn(admin);
      txn.exec("DROP DATABASE IF EXISTS " + database_ + " WITH (FORCE)");
    } catch (...) {
      // A leftover database in a throwaway cluster harms nothing.
    }
  }

  // The admin URI with its database name replaced by ours.
  std::string Uri() const {
    const std::size_t scheme = admin_uri_.find("://");
    const std::size_t slash = admin_uri_.find('/', scheme + 3);
    const std::size_t query = admin_uri_.find('?', scheme + 3);
    std::string base = admin_uri_.substr(0, slash == std::string::npos ? query : slash);
    std::string tail = query == std::string::npos ? "" : admin_uri_.substr(query);
    return base + "/" + database_ + tail;
  }

  void ExecRaw(const std::string& sql) const {
    pqxx::connection c(Uri());
    pqxx::nontransaction txn(c);
    txn.exec(sql);
  }

  // The first column of the first row `sql` returns, as text; empty for no row or NULL.
  std::string QueryText(const std::string& sql) const {
    pqxx::connection c(Uri());
    pqxx::nontransaction txn(c);
    const pqxx::result r = txn.exec(sql);
    return r.empty() || r[0][0].is_null() ? std::string() : r[0][0].as<std::string>();
  }

  // Whether a writer holds a submission's row lock at this moment, asked without waiting.
  bool SubmissionsHeldByAWriter() const {
    pqxx::connection c(Uri());
    pqxx::work txn(c);
    try {
      txn.exec("SELECT id FROM submissions FOR UPDATE NOWAIT");
      return false;
    } catch (const pqxx::sql_error& error) {
      if (error.sqlstate() == "55P03") return true;  // lock_not_available
      throw;
    }
  }

  // Every table of the database (all schemas but the system ones): its name, its columns with
  // their types, and its rows, to compare before and after a call that must not change it.
  std::string StoredState() const {
    pqxx::connection c(Uri());
    pqxx::nontransaction txn(c);
    std::string state;
    const pqxx::result tables = txn.exec(
        "SELECT quote_ident(table_schema) || '.' || quote_ident(table_name) FROM "
        "information_schema.tables WHERE table_schema NOT IN ('pg_catalog', 'information_schema') "
        "AND table_schema NOT LIKE 'pg_temp%' ORDER BY 1");
    for (const pqxx::row& table : tables) {
      const std::string name = table[0].as<std::string>();
      state += "table " + name + "\n";
      for (const pqxx::row& column : txn.exec(
               "SELECT column_name, data_type, is_nullable FROM information_schema.columns WHERE "
               "quote_ident(table_schema) || '.' || quote_ident(table_name) = " +
               txn.quote(name) + " ORDER BY ordinal_position")) {
        state += "  " + column[0].as<std::string>() + " " + column[1].as<std::string>() + " " +
                 column[2].as<std::string>() + "\n";
      }
      state += "  rows " +
               txn.exec(
                      "SELECT count(*) || ' ' || coalesce(md5(string_agg(t::text, E'\\n' ORDER BY "
                      "t::text)), '-') FROM " +
                      name + " t")[0][0]
                   .as<std::string>() +
               "\n";
    }
    return state;
  }

 private:
  std::string admin_uri_;
  std::string database_;
};

// Every backend, for TYPED_TEST_SUITE(Suite, StoreBackends, BackendNames): test names end in
// /Sqlite or /Postgres (scripts/test counts the Postgres ones and refuses any skipped).
using StoreBackends = ::testing::Types<SqliteBackend, PostgresBackend>;
struct BackendNames {
  template <typename T>
  static std::string GetName(int) {
    return T::kName;
  }
};

}  // namespace fleetmap::testing
