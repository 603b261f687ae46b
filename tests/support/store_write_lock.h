// Another writer holding a store's write lock, for the tests of a server that must ride it out:
// on SQLite a connection in BEGIN IMMEDIATE (readers go on, in WAL mode; writers wait for
// the busy timeout, then fail); on PostgreSQL a transaction holding SHARE ROW EXCLUSIVE on
// the versioning tables (reads go on; inserts and updates wait for lock_timeout, then fail).
// Held from construction until Release() or destruction.
#pragma once

#include <sqlite3.h>

#include <memory>
#include <pqxx/pqxx>
#include <stdexcept>
#include <string>

namespace fleetmap::testing {

class StoreWriteLock {
 public:
  explicit StoreWriteLock(const std::string& uri) {
    if (uri.rfind("sqlite:", 0) == 0) {
      if (sqlite3_open(uri.substr(7).c_str(), &sqlite_) != SQLITE_OK) {
        throw std::runtime_error("cannot open " + uri);
      }
      sqlite3_busy_timeout(sqlite_, 30'000);
      char* error = nullptr;
      if (sqlite3_exec(sqlite_, "BEGIN IMMEDIATE", nullptr, nullptr, &error) != SQLITE_OK) {
        const std::string message = error ? error : "?";
        sqlite3_free(error);
        throw std::runtime_error("BEGIN IMMEDIATE on " + uri + ": " + message);
      }
    } else {
      postgres_ = std::make_unique<pqxx::connection>(uri);
      transaction_ = std::make_unique<pqxx::work>(*postgres_);
      transaction_->exec(
          "LOCK TABLE revisions, submissions, submission_chunks IN SHARE ROW EXCLUSIVE MODE");
    }
  }
  ~StoreWriteLock() { Release(); }
  StoreWriteLock(const StoreWriteLock&) = delete;
  StoreWriteLock& operator=(const StoreWriteLock&) = delete;

  void Release() {
    if (sqlite_ != nullptr) {
      sqlite3_exec(sqlite_, "ROLLBACK", nullptr, nullptr, nullptr);
      sqlite3_close(sqlite_);
      sqlite_ = nullptr;
    }
    if (transaction_) {
      transaction_->abort();
      transaction_.reset();
      postgres_.reset();
    }
  }

 private:
  sqlite3* sqlite_ = nullptr;
  std::unique_ptr<pqxx::connection> postgres_;
  std::unique_ptr<pqxx::work> transaction_;
};

}  // namespace fleetmap::testing
