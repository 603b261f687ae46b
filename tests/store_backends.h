// The two GraphStore backends as test fixtures: each hands out a fresh, empty store URI and
// can run raw SQL against it (to damage or inspect a store behind the API's back).
//
// PostgreSQL tests need FLEETMAP_TEST_PG_URI, a URI of a server where the user may CREATE
// DATABASE (scripts/test starts a throwaway cluster and exports it). Without it they skip,
// and scripts/test fails the run when any PostgreSQL test skipped.
#pragma once

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <pqxx/pqxx>
#include <string>

#include "fleetmap/common/uuid.h"

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
