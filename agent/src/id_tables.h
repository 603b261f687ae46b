// The sync state's sets of ids (local_map.h: SyncState's installed, pushed and submissions'
// content) as tables of map.db, beside the map they describe, so that sync.json keeps only
// what is small: a backlog of 10^6 nodes makes millions of ids, which as JSON took seconds and
// GBs each time a command read or wrote the state.
//
//   agent_ids(generation, role, kind, id)   installed (role 0) and pushed (role 1) ids; an
//                                           install writes a new generation, and sync.json
//                                           names the one that goes with it (ids_generation)
//   agent_submission_ids(submission, kind, id)
//                                           what a pending or unmerged submission carries;
//                                           written once, before sync.json names it
//   agent_verified(generation, ...)         what map.db held of a generation's installed set
//                                           when it was last read back whole and matched the
//                                           installed digest (HeldCount)
//
// Rows sync.json does not name (a generation or a submission) are left over from a crash
// between the two writes, or from the last install, and are deleted (Prune); nothing reads them.
// The tables are the agent's own: map.db's GraphStore neither knows nor minds them.
#pragma once

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/core/uuid.h"

struct sqlite3;

namespace fleetmap::agent_internal {

enum class IdRole { kInstalled = 0, kPushed = 1 };

// What map.db holds of a set: how many of its ids name a stored node, edge and path, and the
// landmark bytes of those nodes. Counted from the rows' keys and headers (SQLite's length() of a
// blob reads no overflow page), so it costs the set's size, not its bytes.
struct HeldCount {
  std::int64_t nodes = 0;
  std::int64_t edges = 0;
  std::int64_t paths = 0;
  std::int64_t landmark_bytes = 0;

  friend bool operator==(const HeldCount&, const HeldCount&) = default;
};

class IdTables {
 public:
  // Opens the tables of the SQLite file `db`, creating them when missing. `scratch`: a file
  // that is fsynced whole later (map.db.new), written without a journal on disk. Throws
  // Error(kBackend) naming the file.
  // `read_only`: a reader beside the writer; tables that do not exist read as empty.
  static IdTables Open(const std::filesystem::path& db, bool scratch = false,
                       bool read_only = false);
  ~IdTables();
  IdTables(IdTables&& other) noexcept;
  IdTables& operator=(IdTables&&) = delete;
  IdTables(const IdTables&) = delete;
  IdTables& operator=(const IdTables&) = delete;

  // One transaction around the writes until Commit; rolled back when destroyed before.
  void Begin();
  void Commit();

  void WriteSet(const std::string& generation, IdRole role, const ElementIds& ids);
  // Adds `ids` to a set already written.
  void AddToSet(const std::string& generation, IdRole role, const ElementIds& ids);
  ElementIds ReadSet(const std::string& generation, IdRole role);
  void WriteSubmission(const Uuid& submission, const ElementIds& ids);
  ElementIds ReadSubmission(const Uuid& submission);

  // What map.db holds of a set (HeldCount). Reads the GraphStore's own tables of map.db (nodes,
  // edges and paths by id, the nodes' landmarks): none when map.db has none of them (a file
  // emptied or replaced), as nothing can be counted there.
  std::optional<HeldCount> HeldOf(const std::string& generation, IdRole role);
  // The HeldOf of `generation`'s installed set recorded when its content was last read back
  // whole and matched the installed digest; none when it never was.
  std::optional<HeldCount> ReadVerified(const std::string& generation);
  void WriteVerified(const std::string& generation, const HeldCount& held);

  // Deletes the rows of every generation but `generation` and of every submission not in
  // `submissions`.
  void Prune(const std::string& generation, const std::vector<Uuid>& submissions);

 private:
  explicit IdTables(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}
  void Exec(const char* sql);
  bool HasTable(const char* name);
  void Insert(const char* sql, const std::string* generation, const Uuid* submission, int role,
              const ElementIds& ids);

  sqlite3* db_ = nullptr;
  std::string path_;
  bool in_transaction_ = false;
  bool has_tables_ = true;
  bool read_only_ = false;
};

// A name for a new generation of the sets.
std::string NewIdsGeneration();

// The submissions whose content `state` names: the pending one and the unmerged ones.
std::vector<Uuid> SubmissionsOf(const SyncState& state);

// Writes `state`'s installed and pushed sets as generation state.ids_generation, and with
// `submissions` the content of its pending and unmerged submissions too. Of `pushed`, what an
// unmerged submission carries is not written: ReadStateIds adds it back (so a push accepted,
// MarkPushed, changes sync.json alone).
void WriteStateIds(IdTables& tables, const SyncState& state, bool submissions);

// Fills `state`'s sets (empty as sync.json gives them) from the tables. Returns the
// submissions whose content the tables no longer hold as `counts` says (a map.db lost or
// replaced since): the pending one among them is dropped from `state` (its content went with
// the map), the unmerged ones are kept with what was found.
std::vector<Uuid> ReadStateIds(IdTables& tables, SyncState& state, const SyncStateCounts& counts);

}  // namespace fleetmap::agent_internal
