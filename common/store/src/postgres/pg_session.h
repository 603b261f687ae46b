// One PostgreSQL connection as the backend uses it (libpqxx 6): the connection, the explicit
// GraphStore::Transaction open on it (if any), and the one place where libpqxx exceptions
// become fleetmap::Error. The GraphStore and its VersionStore share one session, which is how
// a VersionStore call made inside a Transaction lands or rolls back with it.
//
// A connection the server ended while it sat idle (a PostgreSQL restart, an administrator's
// pg_terminate_backend) is replaced before its next use rather than failing that use:
// a fresh connection, with every AddConnectionSetup step run on it again.
//
// Threading: as the owning GraphStore (one thread at a time).
#pragma once

#include <cstdio>
#include <functional>
#include <memory>
#include <pqxx/pqxx>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

// A double as text with 17 significant digits, as it travels to the server: an exact round
// trip, whatever the library's own formatting does.
inline std::string Text(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.17g", value);
  return buffer;
}

class PgSession {
 public:
  // Connects to `uri`. Throws Error(kBackend) naming the store (password removed).
  explicit PgSession(const std::string& uri);
  ~PgSession();  // aborts an open transaction
  PgSession(const PgSession&) = delete;
  PgSession& operator=(const PgSession&) = delete;

  // The URI, password removed: for messages.
  const std::string& uri() const { return uri_; }
  // The connection, replaced first if the server ended it (outside a Transaction).
  pqxx::connection& connection() {
    ReviveIfEnded();
    return *conn_;
  }

  // Runs `setup` now (Translate'd as `what`), and again on every connection that replaces this
  // one: session variables, prepared statements, session-local tables. In the order added.
  void AddConnectionSetup(const std::string& what, std::function<void()> setup);
  // The open explicit Transaction, or nullptr (autocommit).
  pqxx::work* transaction() { return txn_.get(); }

  // The GraphStore::Transaction primitives.
  void Begin();
  void Commit();
  void Rollback();

  // Runs fn and turns every libpqxx / standard exception into fleetmap::Error; `what` says
  // which operation failed. A fleetmap::Error thrown by fn passes unchanged.
  template <typename Fn>
  auto Translate(const std::string& what, Fn&& fn) -> decltype(fn());

  // Runs fn(t) in the open explicit transaction, or else in autocommit: one statement is
  // atomic by itself and costs one round trip.
  template <typename Fn>
  auto Autocommit(const std::string& what, Fn&& fn)
      -> std::invoke_result_t<Fn, pqxx::transaction_base&>;

  // Runs fn(t) as one atomic unit: under a savepoint inside the open explicit transaction (so
  // a failure undoes only fn's writes), else in a transaction of its own.
  template <typename Fn>
  auto Atomically(const std::string& what, Fn&& fn)
      -> std::invoke_result_t<Fn, pqxx::transaction_base&>;

  // A server message on one line, without the trailing newline.
  static std::string FirstLines(const std::string& message);

 private:
  // Outside an explicit Transaction: when the server ended the connection (or a replacement
  // was not set up whole), connects again and runs the setup steps. Throws as Translate.
  void ReviveIfEnded();
  // The server ended the connection (or libpqxx replaced it): see the .cc.
  bool Ended();

  std::string connect_uri_;  // as given (libpq keeps the password too)
  std::string uri_;
  std::unique_ptr<pqxx::connection> conn_;
  std::vector<std::pair<std::string, std::function<void()>>> setups_;
  bool set_up_ = true;               // every setup step ran on conn_
  int set_up_backend_ = 0;           // the server process of the connection set up
  bool reviving_ = false;            // inside ReviveIfEnded: the setup steps use connection() too
  std::unique_ptr<pqxx::work> txn_;  // the open explicit Transaction, if any
};

template <typename Fn>
auto PgSession::Translate(const std::string& what, Fn&& fn) -> decltype(fn()) {
  try {
    return fn();
  } catch (const Error&) {
    throw;
  } catch (const pqxx::foreign_key_violation& e) {
    throw Error(ErrorCode::kIntegrity, what + ": " + FirstLines(e.what()));
  } catch (const pqxx::check_violation& e) {
    throw Error(ErrorCode::kIntegrity, what + ": " + FirstLines(e.what()));
  } catch (const pqxx::broken_connection& e) {
    throw Error(ErrorCode::kBackend,
                what + ": lost connection to " + uri_ + ": " + FirstLines(e.what()));
  } catch (const pqxx::sql_error& e) {
    throw Error(ErrorCode::kBackend,
                what + " on " + uri_ + ": " + FirstLines(e.what()) + " (in: " + e.query() + ")");
  } catch (const std::exception& e) {
    throw Error(ErrorCode::kBackend, what + " on " + uri_ + ": " + FirstLines(e.what()));
  }
}

template <typename Fn>
auto PgSession::Autocommit(const std::string& what, Fn&& fn)
    -> std::invoke_result_t<Fn, pqxx::transaction_base&> {
  return Translate(what, [&] {
    if (txn_) return fn(static_cast<pqxx::transaction_base&>(*txn_));
    ReviveIfEnded();
    pqxx::nontransaction t(*conn_);
    return fn(static_cast<pqxx::transaction_base&>(t));
  });
}

template <typename Fn>
auto PgSession::Atomically(const std::string& what, Fn&& fn)
    -> std::invoke_result_t<Fn, pqxx::transaction_base&> {
  using Result = std::invoke_result_t<Fn, pqxx::transaction_base&>;
  // Commits t after fn, passing fn's result through (also when it is void).
  auto run = [&](auto& t) -> Result {
    if constexpr (std::is_void_v<Result>) {
      fn(static_cast<pqxx::transaction_base&>(t));
      t.commit();
    } else {
      Result result = fn(static_cast<pqxx::transaction_base&>(t));
      t.commit();
      return result;
    }
  };
  return Translate(what, [&]() -> Result {
    if (txn_) {
      pqxx::subtransaction sub(*txn_, "fleetmap_atomic");
      return run(sub);
    }
    ReviveIfEnded();
    pqxx::work work(*conn_);
    return run(work);
  });
}

}  // namespace fleetmap::internal
