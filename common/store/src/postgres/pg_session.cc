#include "postgres/pg_session.h"

#include <poll.h>

#include "backends.h"

namespace fleetmap::internal {

PgSession::PgSession(const std::string& uri) : connect_uri_(uri), uri_(RedactPassword(uri)) {
  Translate("connect", [&] { conn_ = std::make_unique<pqxx::connection>(uri); });
  set_up_backend_ = conn_->backendpid();
}

PgSession::~PgSession() {
  txn_.reset();  // aborts an open transaction before the connection closes
}

void PgSession::Begin() {
  Translate("BEGIN", [&] {
    ReviveIfEnded();
    txn_ = std::make_unique<pqxx::work>(*conn_);
  });
}

void PgSession::AddConnectionSetup(const std::string& what, std::function<void()> setup) {
  Translate(what, setup);
  setups_.emplace_back(what, std::move(setup));
}

void PgSession::ReviveIfEnded() {
  if (txn_ || reviving_ || (set_up_ && !Ended())) return;
  reviving_ = true;
  set_up_ = false;
  try {
    Translate("reconnect", [&] { conn_ = std::make_unique<pqxx::connection>(connect_uri_); });
    for (const auto& [what, setup] : setups_) Translate("reconnect: " + what, setup);
    set_up_backend_ = conn_->backendpid();
    set_up_ = true;
  } catch (...) {
    reviving_ = false;  // the next use tries again
    throw;
  }
  reviving_ = false;
}

bool PgSession::Ended() {
  // Another backend: libpqxx connected again by itself after a failure, and that connection
  // lacks the setup (its prepared statements, variables and staging tables).
  if (!conn_->is_open() || conn_->sock() < 0 || conn_->backendpid() != set_up_backend_) {
    return true;
  }
  // An idle connection hears nothing unless the server had its last word (FATAL: terminating
  // connection) and hung up. Asking with a statement would not do: libpqxx may reconnect for
  // it, losing the setup. A notice on an idle connection (rare) costs a needless reconnect.
  pollfd socket{conn_->sock(), POLLIN, 0};
  return ::poll(&socket, 1, 0) > 0;
}

void PgSession::Commit() {
  std::unique_ptr<pqxx::work> txn = std::move(txn_);
  Translate("COMMIT", [&] { txn->commit(); });
}

void PgSession::Rollback() {
  std::unique_ptr<pqxx::work> txn = std::move(txn_);
  if (txn) Translate("ROLLBACK", [&] { txn->abort(); });
}

std::string PgSession::FirstLines(const std::string& message) {
  std::string s = message;
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s) {
    if (c == '\n') c = ' ';
  }
  return s;
}

}  // namespace fleetmap::internal
