// The sync state's id sets as tables of map.db (id_tables.h).
#include "id_tables.h"

#include <sqlite3.h>

#include <algorithm>
#include <optional>
#include <utility>

#include "fleetmap/core/error.h"
#include "install_rules.h"

namespace fleetmap::agent_internal {

namespace {

// WITHOUT ROWID: the key is the row, so a set reads back in id order from the index alone.
constexpr const char* kSchema =
    "CREATE TABLE IF NOT EXISTS agent_ids ("
    " generation TEXT NOT NULL, role INTEGER NOT NULL, kind INTEGER NOT NULL, id BLOB NOT NULL,"
    " PRIMARY KEY (generation, role, kind, id)) WITHOUT ROWID;"
    "CREATE TABLE IF NOT EXISTS agent_submission_ids ("
    " submission BLOB NOT NULL, kind INTEGER NOT NULL, id BLOB NOT NULL,"
    " PRIMARY KEY (submission, kind, id)) WITHOUT ROWID;"
    "CREATE TABLE IF NOT EXISTS agent_verified ("
    " generation TEXT PRIMARY KEY NOT NULL, nodes INTEGER NOT NULL, edges INTEGER NOT NULL,"
    " paths INTEGER NOT NULL, landmark_bytes INTEGER NOT NULL);";

class Statement {
 public:
  Statement(sqlite3* db, const char* sql, const std::string& path) : db_(db), path_(path) {
    if (sqlite3_prepare_v2(db, sql, -1, &s_, nullptr) != SQLITE_OK) Fail("prepare");
  }
  ~Statement() { sqlite3_finalize(s_); }
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;

  void Text(int i, const std::string& text) {
    sqlite3_bind_text(s_, i, text.data(), static_cast<int>(text.size()), SQLITE_TRANSIENT);
  }
  void Int(int i, int value) { sqlite3_bind_int(s_, i, value); }
  void Id(int i, const Uuid& id) {
    sqlite3_bind_blob(s_, i, id.data(), static_cast<int>(Uuid::kSize), SQLITE_TRANSIENT);
  }
  // Whether a row came; throws on an error.
  bool Step() {
    const int rc = sqlite3_step(s_);
    if (rc == SQLITE_ROW) return true;
    if (rc != SQLITE_DONE) Fail("step");
    return false;
  }
  void Reset() {
    sqlite3_reset(s_);
    sqlite3_clear_bindings(s_);
  }
  Uuid ColumnId(int i) {
    const void* blob = sqlite3_column_blob(s_, i);
    const int size = sqlite3_column_bytes(s_, i);
    return Uuid::FromBytes(std::string_view(static_cast<const char*>(blob), size));
  }
  int ColumnInt(int i) { return sqlite3_column_int(s_, i); }
  std::int64_t ColumnInt64(int i) { return sqlite3_column_int64(s_, i); }
  void Int64(int i, std::int64_t value) { sqlite3_bind_int64(s_, i, value); }
  std::string ColumnText(int i) {
    const unsigned char* text = sqlite3_column_text(s_, i);
    return text ? std::string(reinterpret_cast<const char*>(text)) : std::string();
  }

 private:
  [[noreturn]] void Fail(const char* what) {
    throw Error(ErrorCode::kBackend,
                path_ + ": sync state ids: " + what + ": " + sqlite3_errmsg(db_));
  }
  sqlite3* db_;
  const std::string& path_;
  sqlite3_stmt* s_ = nullptr;
};

void ReadIds(Statement& s, ElementIds& out) {
  while (s.Step()) {
    const int kind = s.ColumnInt(0);
    if (kind < 0 || kind > 2) continue;
    IdSet& ids = OfKind(out, kind);
    ids.insert(ids.end(), s.ColumnId(1));  // in id order: each goes in at the end
  }
}

}  // namespace

IdTables IdTables::Open(const std::filesystem::path& db, bool scratch, bool read_only) {
  sqlite3* handle = nullptr;
  const int rc = sqlite3_open_v2(
      db.c_str(), &handle,
      (read_only ? SQLITE_OPEN_READONLY : SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE) |
          SQLITE_OPEN_NOMUTEX,
      nullptr);
  IdTables tables(handle, db.string());
  if (rc != SQLITE_OK) {
    throw Error(ErrorCode::kBackend, "cannot open " + db.string() + ": " +
                                         (handle ? sqlite3_errmsg(handle) : "out of memory"));
  }
  sqlite3_busy_timeout(handle, 10'000);
  if (read_only) {
    Statement s(handle,
                "SELECT COUNT(*) FROM sqlite_master WHERE name IN ('agent_ids', "
                "'agent_submission_ids')",
                tables.path_);
    tables.has_tables_ = s.Step() && s.ColumnInt(0) == 2;
    tables.read_only_ = true;
    return tables;
  }
  if (scratch) {
    tables.Exec("PRAGMA journal_mode=MEMORY; PRAGMA synchronous=OFF");
  } else {
    tables.Exec("PRAGMA synchronous=FULL");
  }
  tables.Exec(kSchema);
  return tables;
}

IdTables::~IdTables() {
  if (db_ == nullptr) return;
  if (read_only_) {
    sqlite3_close(db_);
    return;
  }
  if (in_transaction_) sqlite3_exec(db_, "ROLLBACK", nullptr, nullptr, nullptr);
  // map.db's write-ahead log emptied, so a live log still means another process (HasLiveLog).
  sqlite3_exec(db_, "PRAGMA wal_checkpoint(TRUNCATE)", nullptr, nullptr, nullptr);
  sqlite3_close(db_);
}

IdTables::IdTables(IdTables&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)),
      path_(std::move(other.path_)),
      in_transaction_(std::exchange(other.in_transaction_, false)),
      has_tables_(other.has_tables_),
      read_only_(other.read_only_) {}

void IdTables::Exec(const char* sql) {
  char* message = nullptr;
  if (sqlite3_exec(db_, sql, nullptr, nullptr, &message) != SQLITE_OK) {
    const std::string text = message ? message : sqlite3_errmsg(db_);
    sqlite3_free(message);
    throw Error(ErrorCode::kBackend, path_ + ": sync state ids: " + text);
  }
}

void IdTables::Begin() {
  Exec("BEGIN IMMEDIATE");
  in_transaction_ = true;
}

void IdTables::Commit() {
  Exec("COMMIT");
  in_transaction_ = false;
  sqlite3_exec(db_, "PRAGMA wal_checkpoint(TRUNCATE)", nullptr, nullptr, nullptr);
}

void IdTables::Insert(const char* sql, const std::string* generation, const Uuid* submission,
                      int role, const ElementIds& ids) {
  Statement s(db_, sql, path_);
  for (int kind = 0; kind < 3; ++kind) {
    for (const Uuid& id : OfKind(ids, kind)) {
      if (generation) {
        s.Text(1, *generation);
        s.Int(2, role);
        s.Int(3, kind);
        s.Id(4, id);
      } else {
        s.Id(1, *submission);
        s.Int(2, kind);
        s.Id(3, id);
      }
      s.Step();
      s.Reset();
    }
  }
}

void IdTables::WriteSet(const std::string& generation, IdRole role, const ElementIds& ids) {
  Statement clear(db_, "DELETE FROM agent_ids WHERE generation = ?1 AND role = ?2", path_);
  clear.Text(1, generation);
  clear.Int(2, static_cast<int>(role));
  clear.Step();
  AddToSet(generation, role, ids);
}

void IdTables::AddToSet(const std::string& generation, IdRole role, const ElementIds& ids) {
  Insert("INSERT OR IGNORE INTO agent_ids (generation, role, kind, id) VALUES (?1, ?2, ?3, ?4)",
         &generation, nullptr, static_cast<int>(role), ids);
}

ElementIds IdTables::ReadSet(const std::string& generation, IdRole role) {
  if (!has_tables_) return {};
  Statement s(db_,
              "SELECT kind, id FROM agent_ids WHERE generation = ?1 AND role = ?2 "
              "ORDER BY kind, id",
              path_);
  s.Text(1, generation);
  s.Int(2, static_cast<int>(role));
  ElementIds ids;
  ReadIds(s, ids);
  return ids;
}

void IdTables::WriteSubmission(const Uuid& submission, const ElementIds& ids) {
  Statement clear(db_, "DELETE FROM agent_submission_ids WHERE submission = ?1", path_);
  clear.Id(1, submission);
  clear.Step();
  Insert("INSERT OR IGNORE INTO agent_submission_ids (submission, kind, id) VALUES (?1, ?2, ?3)",
         nullptr, &submission, 0, ids);
}

ElementIds IdTables::ReadSubmission(const Uuid& submission) {
  if (!has_tables_) return {};
  Statement s(db_,
              "SELECT kind, id FROM agent_submission_ids WHERE submission = ?1 ORDER BY kind, id",
              path_);
  s.Id(1, submission);
  ElementIds ids;
  ReadIds(s, ids);
  return ids;
}

bool IdTables::HasTable(const char* name) {
  Statement s(db_, "SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?1", path_);
  s.Text(1, name);
  return s.Step();
}

std::optional<HeldCount> IdTables::HeldOf(const std::string& generation, IdRole role) {
  if (!has_tables_ || !HasTable("nodes") || !HasTable("edges") || !HasTable("paths")) {
    return std::nullopt;
  }
  // One pass per kind along the set's keys, each id looked up in its table's unique index.
  Statement nodes(db_,
                  "SELECT COUNT(*), TOTAL(length(n.landmarks)) FROM agent_ids a JOIN nodes n "
                  "ON n.id = a.id WHERE a.generation = ?1 AND a.role = ?2 AND a.kind = 0",
                  path_);
  Statement edges(db_,
                  "SELECT COUNT(*) FROM agent_ids a JOIN edges e ON e.id = a.id "
                  "WHERE a.generation = ?1 AND a.role = ?2 AND a.kind = 1",
                  path_);
  Statement paths(db_,
                  "SELECT COUNT(*) FROM agent_ids a JOIN paths p ON p.id = a.id "
                  "WHERE a.generation = ?1 AND a.role = ?2 AND a.kind = 2",
                  path_);
  HeldCount held;
  for (Statement* s : {&nodes, &edges, &paths}) {
    s->Text(1, generation);
    s->Int(2, static_cast<int>(role));
  }
  if (nodes.Step()) {
    held.nodes = nodes.ColumnInt64(0);
    held.landmark_bytes = nodes.ColumnInt64(1);
  }
  if (edges.Step()) held.edges = edges.ColumnInt64(0);
  if (paths.Step()) held.paths = paths.ColumnInt64(0);
  return held;
}

std::optional<HeldCount> IdTables::ReadVerified(const std::string& generation) {
  if (!HasTable("agent_verified")) return std::nullopt;
  Statement s(db_,
              "SELECT nodes, edges, paths, landmark_bytes FROM agent_verified "
              "WHERE generation = ?1",
              path_);
  s.Text(1, generation);
  if (!s.Step()) return std::nullopt;
  return HeldCount{s.ColumnInt64(0), s.ColumnInt64(1), s.ColumnInt64(2), s.ColumnInt64(3)};
}

void IdTables::WriteVerified(const std::string& generation, const HeldCount& held) {
  Statement s(db_,
              "INSERT OR REPLACE INTO agent_verified (generation, nodes, edges, paths, "
              "landmark_bytes) VALUES (?1, ?2, ?3, ?4, ?5)",
              path_);
  s.Text(1, generation);
  s.Int64(2, held.nodes);
  s.Int64(3, held.edges);
  s.Int64(4, held.paths);
  s.Int64(5, held.landmark_bytes);
  s.Step();
}

void IdTables::Prune(const std::string& generation, const std::vector<Uuid>& submissions) {
  {
    Statement drop_verified(db_, "DELETE FROM agent_verified WHERE generation <> ?1", path_);
    drop_verified.Text(1, generation);
    drop_verified.Step();
  }
  // Generations and submissions are found by stepping along the keys' first column: a few
  // index lookups each, not a scan of millions of rows.
  std::vector<std::string> old_generations;
  {
    Statement next(db_,
                   "SELECT generation FROM agent_ids WHERE generation > ?1 "
                   "ORDER BY generation LIMIT 1",
                   path_);
    std::string after;
    for (;;) {
      next.Text(1, after);
      if (!next.Step()) break;
      after = next.ColumnText(0);
      next.Reset();
      if (after != generation) old_generations.push_back(after);
    }
  }
  std::vector<Uuid> old_submissions;
  {
    Statement first(db_, "SELECT submission FROM agent_submission_ids ORDER BY submission LIMIT 1",
                    path_);
    Statement next(db_,
                   "SELECT submission FROM agent_submission_ids WHERE submission > ?1 "
                   "ORDER BY submission LIMIT 1",
                   path_);
    std::optional<Uuid> at;
    if (first.Step()) at = first.ColumnId(0);
    while (at) {
      if (std::find(submissions.begin(), submissions.end(), *at) == submissions.end()) {
        old_submissions.push_back(*at);
      }
      next.Id(1, *at);
      at.reset();
      if (next.Step()) at = next.ColumnId(0);
      next.Reset();
    }
  }
  if (old_generations.empty() && old_submissions.empty()) return;
  Begin();
  Statement drop_generation(db_, "DELETE FROM agent_ids WHERE generation = ?1", path_);
  for (const std::string& old : old_generations) {
    drop_generation.Text(1, old);
    drop_generation.Step();
    drop_generation.Reset();
  }
  Statement drop_submission(db_, "DELETE FROM agent_submission_ids WHERE submission = ?1", path_);
  for (const Uuid& old : old_submissions) {
    drop_submission.Id(1, old);
    drop_submission.Step();
    drop_submission.Reset();
  }
  Commit();
}

std::string NewIdsGeneration() {
  return Uuid::Generate().ToString();
}

std::vector<Uuid> SubmissionsOf(const SyncState& state) {
  std::vector<Uuid> ids;
  if (state.submission) ids.push_back(state.submission->id);
  for (const UnmergedSubmission& unmerged : state.unmerged) ids.push_back(unmerged.id);
  return ids;
}

void WriteStateIds(IdTables& tables, const SyncState& state, bool submissions) {
  tables.WriteSet(state.ids_generation, IdRole::kInstalled, state.installed);
  ElementIds pushed;
  for (int kind = 0; kind < 3; ++kind) {
    IdSet& out = OfKind(pushed, kind);
    for (const Uuid& id : OfKind(state.pushed, kind)) {
      const bool carried = std::any_of(
          state.unmerged.begin(), state.unmerged.end(),
          [&](const UnmergedSubmission& u) { return OfKind(u.content, kind).contains(id); });
      if (!carried) out.insert(out.end(), id);
    }
  }
  tables.WriteSet(state.ids_generation, IdRole::kPushed, pushed);
  if (!submissions) return;
  if (state.submission) tables.WriteSubmission(state.submission->id, state.submission->content);
  for (const UnmergedSubmission& unmerged : state.unmerged) {
    tables.WriteSubmission(unmerged.id, unmerged.content);
  }
}

std::vector<Uuid> ReadStateIds(IdTables& tables, SyncState& state, const SyncStateCounts& counts) {
  std::vector<Uuid> lost;
  state.installed = tables.ReadSet(state.ids_generation, IdRole::kInstalled);
  state.pushed = tables.ReadSet(state.ids_generation, IdRole::kPushed);
  if (state.submission) {
    state.submission->content = tables.ReadSubmission(state.submission->id);
    if (!(CountOf(state.submission->content) == counts.submission)) {
      lost.push_back(state.submission->id);
      state.submission.reset();
    }
  }
  for (std::size_t i = 0; i < state.unmerged.size(); ++i) {
    UnmergedSubmission& unmerged = state.unmerged[i];
    unmerged.content = tables.ReadSubmission(unmerged.id);
    if (i >= counts.unmerged.size() || !(CountOf(unmerged.content) == counts.unmerged[i])) {
      lost.push_back(unmerged.id);
    }
    // Pushed, as MarkPushed recorded in memory (WriteStateIds left it out).
    for (int kind = 0; kind < 3; ++kind) {
      for (const Uuid& id : OfKind(unmerged.content, kind)) {
        if (!OfKind(state.installed, kind).contains(id)) OfKind(state.pushed, kind).insert(id);
      }
    }
  }
  return lost;
}

}  // namespace fleetmap::agent_internal
