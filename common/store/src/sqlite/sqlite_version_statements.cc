// The SQL of the SQLite VersionStore's statements (sqlite_version_statements.h), built once
// from the column lists and visibility rules they share.
#include "sqlite/sqlite_version_statements.h"

#include <bit>
#include <string>

#include "sqlite/element_rows.h"

namespace fleetmap::internal {

namespace {

// "(?first, ?first+1, ..., ?first+n-1)".
std::string ParameterList(int first, int n) {
  std::string list = "(";
  for (int i = 0; i < n; ++i) list += (i ? ", ?" : "?") + std::to_string(first + i);
  return list + ")";
}

// The kind and id of one of the ?1 ... ?n that is stored already, as any kind of element.
// Unbound parameters are NULL and match nothing, so a short last chunk reuses the statement.
std::string StoredAmongSql(int n) {
  const std::string in = ParameterList(1, n);
  return "SELECT 1, id FROM nodes WHERE id IN " + in + " UNION ALL SELECT 2, id FROM edges" +
         " WHERE id IN " + in + " UNION ALL SELECT 3, id FROM paths WHERE id IN " + in + " LIMIT 1";
}

// Versions n elements as added by revision ?1: id and kind are ?2, ?3, then ?4, ?5, ... A row
// left by a revision whose elements were never Put (they are not stored: AppendRevision
// checks that first) is replaced.
std::string AddElementsSql(int n) {
  std::string sql = "INSERT INTO element_versions (id, kind, added_rev) VALUES ";
  for (int i = 0; i < n; ++i) {
    sql += (i ? ", (?" : "(?") + std::to_string(2 + 2 * i) + ", ?" + std::to_string(3 + 2 * i) +
           ", ?1)";
  }
  return sql +
         " ON CONFLICT (id) DO UPDATE SET kind = excluded.kind, added_rev = excluded.added_rev,"
         " hidden_rev = NULL";
}

constexpr const char* kSubmissionColumns =
    "id, robot, author, received_ns, chunk_count, bytes, digest, state, revision, error";
constexpr const char* kRevisionColumns =
    "number, created_ns, author, kind, submission, coalesce(reverted, 0), nodes_added,"
    " edges_added, paths_added, nodes_hidden, edges_hidden, paths_hidden, report";

// The visibility rule of 0002_versions.sql for alias v of a LEFT JOIN on element_versions
// (no row: revision 0, never hidden), at revision ?1.
constexpr const char* kVisibleAtParam1 =
    "coalesce(v.added_rev, 0) <= ?1 AND (v.hidden_rev IS NULL OR v.hidden_rev > ?1)";

// True when the element of element_versions row v is stored (a row whose element the
// caller never Put stays invisible).
constexpr const char* kElementStored =
    "CASE v.kind WHEN 1 THEN EXISTS (SELECT 1 FROM nodes x WHERE x.id = v.id)"
    " WHEN 2 THEN EXISTS (SELECT 1 FROM edges x WHERE x.id = v.id)"
    " ELSE EXISTS (SELECT 1 FROM paths x WHERE x.id = v.id) END";

// Edges with an end among the nodes, or on a path, that revision ?1 hid.
constexpr const char* kEdgesTouchingHiddenAt1 =
    "WITH hidden AS (SELECT id, kind FROM element_versions WHERE hidden_rev = ?1 AND kind <> 2),"
    " touching AS (SELECT e.id FROM hidden h JOIN edges e ON e.from_id = h.id WHERE h.kind = 1"
    " UNION SELECT e.id FROM hidden h JOIN edges e ON e.to_id = h.id WHERE h.kind = 1"
    " UNION SELECT e.id FROM hidden h JOIN edges e ON e.path_id = h.id WHERE h.kind = 3) ";

// 0009_retirement.sql: no retirement of element `alias` is open at revision ?1.
std::string NotRetiredAtParam1(const char* alias) {
  return std::string(" AND NOT EXISTS (SELECT 1 FROM retirements t WHERE t.id = ") + alias +
         ".id AND t.retired_rev <= ?1 AND (t.restored_rev IS NULL OR t.restored_rev > ?1))";
}

// Element `alias` is not hidden at the head by element_versions nor by an open retirement.
std::string VisibleAtHead(const char* alias) {
  return std::string("NOT EXISTS (SELECT 1 FROM element_versions v WHERE v.id = ") + alias +
         ".id AND v.hidden_rev IS NOT NULL) AND NOT EXISTS (SELECT 1 FROM retirements r"
         " WHERE r.id = " +
         alias + ".id AND r.restored_rev IS NULL)";
}

const std::string kVisibleNodes =
    " FROM nodes n LEFT JOIN element_versions v ON v.id = n.id WHERE coalesce(v.added_rev, 0)"
    " <= ?1 AND (v.hidden_rev IS NULL OR v.hidden_rev > ?1)" +
    NotRetiredAtParam1("n");

}  // namespace

Submission ReadSubmission(const Statement& s) {
  Submission v;
  v.id = s.UuidAt(0);
  v.robot = s.UuidAt(1);
  v.author = s.Text(2);
  v.received_ns = s.Int64(3);
  v.chunk_count = s.Int64(4);
  v.bytes = s.Int64(5);
  v.digest = std::bit_cast<std::uint64_t>(s.Int64(6));
  v.state = static_cast<SubmissionState>(s.Int64(7));
  v.revision = s.Int64(8);
  v.error = s.Text(9);
  return v;
}

Revision ReadRevision(const Statement& s) {
  Revision v;
  v.number = s.Int64(0);
  v.created_ns = s.Int64(1);
  v.author = s.Text(2);
  v.kind = static_cast<RevisionKind>(s.Int64(3));
  v.submission = s.UuidAt(4);
  v.reverted = s.Int64(5);
  v.nodes_added = s.Int64(6);
  v.edges_added = s.Int64(7);
  v.paths_added = s.Int64(8);
  v.nodes_hidden = s.Int64(9);
  v.edges_hidden = s.Int64(10);
  v.paths_hidden = s.Int64(11);
  v.report = s.Text(12);
  return v;
}

SubmissionStatements::SubmissionStatements(sqlite3* db)
    : begin_submission(db,
                       "INSERT INTO submissions (id, robot, author, received_ns)"
                       " VALUES (?1, ?2, ?3, ?4) ON CONFLICT (id) DO NOTHING"),
      find_submission(
          db, Sql({"SELECT ", kSubmissionColumns, " FROM submissions WHERE id = ?1"}).c_str()),
      list_submissions(
          db, Sql({"SELECT ", kSubmissionColumns, " FROM submissions ORDER BY received_ns, id"})
                  .c_str()),
      chunk_equals(db,
                   "SELECT data = ?3 FROM submission_chunks WHERE submission = ?1"
                   " AND seq = ?2"),
      insert_chunk(db,
                   "INSERT INTO submission_chunks (submission, seq, data)"
                   " VALUES (?1, ?2, ?3)"),
      count_chunk(db,
                  "UPDATE submissions SET chunk_count = chunk_count + 1,"
                  " bytes = bytes + ?2 WHERE id = ?1"),
      chunk(db, "SELECT data FROM submission_chunks WHERE submission = ?1 AND seq = ?2"),
      complete_submission(db, "UPDATE submissions SET state = 1, digest = ?2 WHERE id = ?1"),
      set_submission_state(db,
                           "UPDATE submissions SET state = ?2, revision = ?3, error = ?4"
                           " WHERE id = ?1"),
      first_claimable(db,
                      "SELECT id FROM submissions WHERE state = 1 AND (claimed_by = ''"
                      " OR claimed_by = ?1 OR lease_until_ns <= ?2)"
                      " ORDER BY received_ns, id"),
      set_claim(db, "UPDATE submissions SET claimed_by = ?2, lease_until_ns = ?3 WHERE id = ?1"),
      renew_claim(db,
                  "UPDATE submissions SET lease_until_ns = ?3 WHERE id = ?1"
                  " AND claimed_by = ?2"),
      release_claim(db,
                    "UPDATE submissions SET claimed_by = '', lease_until_ns = 0 WHERE id = ?1"
                    " AND claimed_by = ?2"),
      find_claim(db, "SELECT claimed_by, lease_until_ns FROM submissions WHERE id = ?1") {}

RevisionStatements::RevisionStatements(sqlite3* db)
    : head(db, "SELECT coalesce(max(number), 0) FROM revisions"),
      find_revision(
          db, Sql({"SELECT ", kRevisionColumns, " FROM revisions WHERE number = ?1"}).c_str()),
      list_revisions(db,
                     Sql({"SELECT ", kRevisionColumns, " FROM revisions ORDER BY number"}).c_str()),
      reverted_by(db, "SELECT number FROM revisions WHERE reverted = ?1"),
      insert_revision(db,
                      "INSERT INTO revisions (number, created_ns, author, kind, submission,"
                      " reverted, nodes_added, edges_added, paths_added, nodes_hidden,"
                      " edges_hidden, paths_hidden, report) VALUES (?1, ?2, ?3, ?4, ?5,"
                      " NULLIF(?6, 0), ?7, ?8, ?9, ?10, ?11, ?12, ?13)"),
      set_hidden_counts(db,
                        "UPDATE revisions SET nodes_hidden = ?2, edges_hidden = ?3,"
                        " paths_hidden = ?4 WHERE number = ?1"),
      stored_among(db, StoredAmongSql(kElementsPerStatement).c_str()),
      add_elements(db, AddElementsSql(kElementsPerStatement).c_str()),
      add_element(db, AddElementsSql(1).c_str()),
      hide_added(db, Sql({"UPDATE element_versions AS v SET hidden_rev = ?1"
                          " WHERE v.added_rev = ?2 AND v.hidden_rev IS NULL AND ",
                          kElementStored})
                         .c_str()),
      hide_node(db,
                "UPDATE element_versions SET hidden_rev = ?1"
                " WHERE id = ?2 AND kind = 1 AND hidden_rev IS NULL"),
      hide_touching_versioned(db, Sql({kEdgesTouchingHiddenAt1,
                                       "UPDATE element_versions SET hidden_rev = ?1"
                                       " WHERE hidden_rev IS NULL"
                                       " AND id IN (SELECT id FROM touching)"})
                                      .c_str()),
      // Edges from outside version control (revision 0) get their row when first hidden.
      hide_touching_unversioned(
          db, Sql({kEdgesTouchingHiddenAt1,
                   "INSERT INTO element_versions (id, kind, added_rev, hidden_rev)"
                   " SELECT t.id, 2, 0, ?1 FROM touching t WHERE NOT EXISTS"
                   " (SELECT 1 FROM element_versions v WHERE v.id = t.id)"})
                  .c_str()),
      hidden_counts(db,
                    "SELECT kind, count(*) FROM element_versions WHERE hidden_rev = ?1"
                    " GROUP BY kind") {}

CheckoutStatements::CheckoutStatements(sqlite3* db)
    : nodes_at(
          db,
          Sql({"SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks", kVisibleNodes}).c_str()),
      nodes_at_bare(
          db, Sql({"SELECT n.id, n.stamp_ns, n.robot, n.outing, NULL", kVisibleNodes}).c_str()),
      edges_at(db, Sql({"SELECT ", kEdgeColumnsOfE,
                        " FROM edges e LEFT JOIN element_versions v ON v.id = e.id WHERE ",
                        kVisibleAtParam1, NotRetiredAtParam1("e"), " ORDER BY e.id"})
                       .c_str()),
      paths_at(db, Sql({"SELECT p.id, p.robot, p.outing, p.start_ns, p.end_ns FROM paths p"
                        " LEFT JOIN element_versions v ON v.id = p.id WHERE ",
                        kVisibleAtParam1, NotRetiredAtParam1("p"), " ORDER BY p.start_ns, p.id"})
                       .c_str()),
      stats_at(db, Sql({"SELECT count(*), coalesce(sum(length(n.landmarks)), 0),"
                        " (SELECT count(*) FROM edges e LEFT JOIN element_versions v"
                        " ON v.id = e.id WHERE ",
                        kVisibleAtParam1, NotRetiredAtParam1("e"),
                        "), (SELECT count(*) FROM paths p LEFT JOIN element_versions v"
                        " ON v.id = p.id WHERE ",
                        kVisibleAtParam1, NotRetiredAtParam1("p"), ")", kVisibleNodes})
                       .c_str()),
      // Only elements some revision in (?1, ?2] added or hid can differ between them.
      changed_between(db, Sql({"SELECT v.id, v.kind, v.added_rev, v.hidden_rev"
                               " FROM element_versions v WHERE ((v.added_rev > ?1"
                               " AND v.added_rev <= ?2) OR (v.hidden_rev > ?1"
                               " AND v.hidden_rev <= ?2)) AND ",
                               kElementStored, " ORDER BY v.id"})
                              .c_str()),
      // With the retirement of it open at the head, if any: one probe per call, which MERGE
      // makes for every node and edge it meets.
      version_of(db,
                 "SELECT coalesce(v.added_rev, 0), v.hidden_rev, (SELECT retired_rev FROM"
                 " retirements WHERE id = ?1 AND restored_rev IS NULL) FROM (SELECT id FROM nodes"
                 " WHERE id = ?1 UNION ALL SELECT id FROM edges WHERE id = ?1 UNION ALL"
                 " SELECT id FROM paths WHERE id = ?1) s LEFT JOIN element_versions v"
                 " ON v.id = s.id LIMIT 1") {}

RetirementStatements::RetirementStatements(sqlite3* db)
    : any_retirement(db, "SELECT EXISTS (SELECT 1 FROM retirements)"),
      // A stored node visible at the head, retired by revision ?1.
      retire_node(db, Sql({"INSERT INTO retirements (id, kind, retired_rev) SELECT n.id, 1, ?1"
                           " FROM nodes n WHERE n.id = ?2 AND ",
                           VisibleAtHead("n")})
                          .c_str()),
      // Every edge visible at the head with an end among the nodes revision ?1 retired.
      retire_touching(db, Sql({"WITH gone AS (SELECT id FROM retirements WHERE retired_rev = ?1"
                               " AND kind = 1), touching AS (SELECT e.id FROM gone g JOIN edges e"
                               " ON e.from_id = g.id UNION SELECT e.id FROM gone g JOIN edges e"
                               " ON e.to_id = g.id) INSERT INTO retirements (id, kind,"
                               " retired_rev) SELECT touching.id, 2, ?1 FROM touching WHERE ",
                               VisibleAtHead("touching")})
                              .c_str()),
      retired_counts(db,
                     "SELECT kind, count(*) FROM retirements WHERE retired_rev = ?1"
                     " GROUP BY kind"),
      restore_retired(db,
                      "UPDATE retirements SET restored_rev = ?1 WHERE retired_rev = ?2"
                      " AND restored_rev IS NULL"),
      // What revision ?1 brought back: restored, and not hidden since by element_versions.
      restored_counts(db,
                      "SELECT r.kind, count(*) FROM retirements r WHERE r.restored_rev = ?1"
                      " AND NOT EXISTS (SELECT 1 FROM element_versions v WHERE v.id = r.id"
                      " AND v.hidden_rev IS NOT NULL) GROUP BY r.kind"),
      set_added_counts(db,
                       "UPDATE revisions SET nodes_added = ?2, edges_added = ?3,"
                       " paths_added = ?4 WHERE number = ?1"),
      // Elements some revision in (?1, ?2] retired or restored, with their element_versions.
      retired_between(db,
                      "SELECT t.id, t.kind, coalesce(v.added_rev, 0), v.hidden_rev FROM"
                      " (SELECT DISTINCT id, kind FROM retirements WHERE (retired_rev > ?1"
                      " AND retired_rev <= ?2) OR (restored_rev > ?1 AND restored_rev <= ?2))"
                      " t LEFT JOIN element_versions v ON v.id = t.id ORDER BY t.id"),
      retirements_of(db, "SELECT retired_rev, restored_rev FROM retirements WHERE id = ?1") {}

RecordStatements::RecordStatements(sqlite3* db)
    : put_node_usage(db,
                     "INSERT INTO node_usage (node, revision, source, frames, last_ns)"
                     " VALUES (?1, ?2, ?3, ?4, ?5) ON CONFLICT (node, revision, source)"
                     " DO UPDATE SET frames = excluded.frames, last_ns = excluded.last_ns"),
      usage_at(db,
               "SELECT node, sum(frames), max(last_ns) FROM node_usage WHERE revision <= ?1"
               " GROUP BY node ORDER BY node"),
      find_setting(db, "SELECT value FROM settings WHERE key = ?1"),
      put_setting(db,
                  "INSERT INTO settings (key, value) VALUES (?1, ?2)"
                  " ON CONFLICT (key) DO UPDATE SET value = excluded.value"),
      insert_setting_if_absent(db,
                               "INSERT INTO settings (key, value) VALUES (?1, ?2)"
                               " ON CONFLICT (key) DO NOTHING"),
      replace_setting(db, "UPDATE settings SET value = ?3 WHERE key = ?1 AND value = ?2"),
      // Compared as bytes (not LIKE, whose '%' and '_' a prefix may hold) and ordered as
      // bytes, like PostgreSQL's COLLATE "C" below.
      list_settings(db,
                    "SELECT key, value FROM settings WHERE substr(CAST(key AS BLOB), 1,"
                    " length(?1)) = ?1 ORDER BY CAST(key AS BLOB)"),
      put_submission_node(db,
                          "INSERT INTO submission_nodes (node, submission) VALUES (?1, ?2)"
                          " ON CONFLICT DO NOTHING"),
      submissions_with_node(
          db, Sql({"SELECT ", kSubmissionColumns,
                   " FROM submissions WHERE id IN (SELECT submission FROM submission_nodes"
                   " WHERE node = ?1) ORDER BY received_ns, id"})
                  .c_str()),
      put_stand_in(db,
                   "INSERT INTO stand_ins (node, stand_in, tx, ty, tz, qw, qx, qy, qz,"
                   " revision) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10)"
                   " ON CONFLICT (node) DO NOTHING"),
      find_stand_in(db,
                    "SELECT stand_in, tx, ty, tz, qw, qx, qy, qz, revision FROM stand_ins"
                    " WHERE node = ?1"),
      stand_ins_of(db,
                   "SELECT stand_in, tx, ty, tz, qw, qx, qy, qz, revision, node FROM stand_ins"
                   " WHERE revision = ?1 ORDER BY node") {}

SqliteVersionStatements::SqliteVersionStatements(sqlite3* db)
    : SubmissionStatements(db),
      RevisionStatements(db),
      CheckoutStatements(db),
      RetirementStatements(db),
      RecordStatements(db) {}

}  // namespace fleetmap::internal
