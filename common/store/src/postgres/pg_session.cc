#include "postgres/pg_session.h"

#include "backends.h"

namespace fleetmap::internal {

PgSession::PgSession(const std::string& uri) : uri_(RedactPassword(uri)) {
  Translate("connect", [&] { conn_ = std::make_unique<pqxx::connection>(uri); });
}

PgSession::~PgSession() {
  txn_.reset();  // aborts an open transaction before the connection closes
}

void PgSession::Begin() {
  Translate("BEGIN", [&] { txn_ = std::make_unique<pqxx::work>(*conn_); });
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
