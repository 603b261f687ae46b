// The SQL of the PostgreSQL VersionStore's prepared statements (postgres_version_statements.h),
// built once from the column lists and visibility rules they share.
#include "postgres/postgres_version_statements.h"

#include <string>

#include "postgres/element_rows.h"

namespace fleetmap::internal {

namespace {

constexpr const char* kSubmissionColumns =
    "id, robot, author, received_ns, chunk_count, bytes, digest, state, revision, error";
// Now as UTC nanoseconds by the server's clock (clock_timestamp: the time of the call, not
// of the transaction's start).
constexpr const char* kNowNs = "(extract(epoch FROM clock_timestamp()) * 1000000000)::bigint";
constexpr const char* kRevisionColumns =
    "number, created_ns, author, kind, submission, coalesce(reverted, 0), nodes_added,"
    " edges_added, paths_added, nodes_hidden, edges_hidden, paths_hidden, report";

// The visibility rule of 0002_versions.sql for alias v of a LEFT JOIN on element_versions
// (no row: revision 0, never hidden), at revision $1.
constexpr const char* kVisibleAtParam1 =
    "coalesce(v.added_rev, 0) <= $1 AND (v.hidden_rev IS NULL OR v.hidden_rev > $1)";

// True when the element of element_versions row v is stored (a row whose element the
// caller never Put stays invisible).
constexpr const char* kElementStored =
    "CASE v.kind WHEN 1 THEN EXISTS (SELECT 1 FROM nodes x WHERE x.id = v.id)"
    " WHEN 2 THEN EXISTS (SELECT 1 FROM edges x WHERE x.id = v.id)"
    " ELSE EXISTS (SELECT 1 FROM paths x WHERE x.id = v.id) END";

// Edges with an end among the nodes, or on a path, that revision $1 hid.
constexpr const char* kEdgesTouchingHiddenAt1 =
    "WITH hidden AS (SELECT id, kind FROM element_versions WHERE hidden_rev = $1 AND kind <> 2),"
    " touching AS (SELECT e.id FROM hidden h JOIN edges e ON e.from_id = h.id WHERE h.kind = 1"
    " UNION SELECT e.id FROM hidden h JOIN edges e ON e.to_id = h.id WHERE h.kind = 1"
    " UNION SELECT e.id FROM hidden h JOIN edges e ON e.path_id = h.id WHERE h.kind = 3) ";

// 0009_retirement.sql: no retirement of element `alias` is open at revision $1.
std::string NotRetiredAtParam1(const char* alias) {
  return std::string(" AND NOT EXISTS (SELECT 1 FROM retirements t WHERE t.id = ") + alias +
         ".id AND t.retired_rev <= $1 AND (t.restored_rev IS NULL OR t.restored_rev > $1))";
}

// Element `alias` is not hidden at the head by element_versions nor by an open retirement.
std::string VisibleAtHead(const char* alias) {
  return std::string("NOT EXISTS (SELECT 1 FROM element_versions v WHERE v.id = ") + alias +
         ".id AND v.hidden_rev IS NOT NULL) AND NOT EXISTS (SELECT 1 FROM retirements r"
         " WHERE r.id = " +
         alias + ".id AND r.restored_rev IS NULL)";
}

// Submissions and their chunks.
void PrepareSubmissions(pqxx::connection& c) {
  c.prepare("version_begin_submission",
            "INSERT INTO submissions (id, robot, author, received_ns) VALUES ($1, $2, $3, $4)"
            " ON CONFLICT (id) DO NOTHING");
  c.prepare("version_find_submission",
            Cat({"SELECT ", kSubmissionColumns, " FROM submissions WHERE id = $1"}));
  c.prepare("version_lock_submission",
            Cat({"SELECT ", kSubmissionColumns, " FROM submissions WHERE id = $1 FOR UPDATE"}));
  c.prepare("version_list_submissions",
            Cat({"SELECT ", kSubmissionColumns, " FROM submissions ORDER BY received_ns, id"}));
  c.prepare("version_chunk_equals",
            "SELECT data = $3 FROM submission_chunks WHERE submission = $1 AND seq = $2");
  c.prepare("version_insert_chunk",
            "INSERT INTO submission_chunks (submission, seq, data) VALUES ($1, $2, $3)");
  c.prepare("version_count_chunk",
            "UPDATE submissions SET chunk_count = chunk_count + 1, bytes = bytes + $2"
            " WHERE id = $1");
  c.prepare("version_chunk",
            "SELECT data FROM submission_chunks WHERE submission = $1 AND seq = $2");
  c.prepare("version_complete_submission",
            "UPDATE submissions SET state = 1, digest = $2 WHERE id = $1");
  c.prepare("version_set_submission_state",
            "UPDATE submissions SET state = $2, revision = $3, error = $4 WHERE id = $1");
}

// Claims on queued submissions.
void PrepareClaims(pqxx::connection& c) {
  // Claims, timed by this server's clock. SKIP LOCKED: instances claiming at once each lock
  // a different submission instead of queueing behind one another for the same row.
  c.prepare("version_claim_submission",
            Cat({"WITH now AS (SELECT ", kNowNs,
                 " AS ns) UPDATE submissions SET claimed_by = $1,"
                 " lease_until_ns = (SELECT ns FROM now) + $2 WHERE id = (SELECT id FROM"
                 " submissions, now WHERE state = 1 AND (claimed_by = '' OR claimed_by = $1"
                 " OR lease_until_ns <= now.ns) AND NOT (id = ANY($3::uuid[]))"
                 " ORDER BY received_ns, id LIMIT 1"
                 " FOR UPDATE OF submissions SKIP LOCKED) RETURNING ",
                 kSubmissionColumns}));
  c.prepare("version_renew_claim",
            Cat({"WITH now AS (SELECT ", kNowNs,
                 " AS ns) UPDATE submissions SET lease_until_ns = (SELECT ns FROM now) + $3"
                 " WHERE id = $1 AND claimed_by = $2"}));
  c.prepare("version_release_claim",
            "UPDATE submissions SET claimed_by = '', lease_until_ns = 0"
            " WHERE id = $1 AND claimed_by = $2");
  c.prepare("version_find_claim",
            "SELECT claimed_by, lease_until_ns FROM submissions WHERE id = $1");
}

// Revisions.
void PrepareRevisions(pqxx::connection& c) {
  c.prepare("version_head", "SELECT coalesce(max(number), 0) FROM revisions");
  c.prepare("version_find_revision",
            Cat({"SELECT ", kRevisionColumns, " FROM revisions WHERE number = $1"}));
  c.prepare("version_list_revisions",
            Cat({"SELECT ", kRevisionColumns, " FROM revisions ORDER BY number"}));
  c.prepare("version_reverted_by", "SELECT number FROM revisions WHERE reverted = $1");
  c.prepare("version_insert_revision",
            "INSERT INTO revisions (number, created_ns, author, kind, submission, reverted,"
            " nodes_added, edges_added, paths_added, nodes_hidden, edges_hidden, paths_hidden,"
            " report) VALUES ($1, $2, $3, $4, NULLIF($5, '')::uuid, NULLIF($6::bigint, 0),"
            " $7, $8, $9, $10, $11, $12, $13)");
  c.prepare("version_set_hidden_counts",
            "UPDATE revisions SET nodes_hidden = $2, edges_hidden = $3, paths_hidden = $4"
            " WHERE number = $1");
}

// Which revision added and hid each element.
void PrepareElementVersions(pqxx::connection& c) {
  // Which of the ids is stored already, as any kind of element (one probe of each table's
  // primary key per id).
  c.prepare("version_stored_among",
            "SELECT 1, id FROM nodes WHERE id = ANY($1::uuid[])"
            " UNION ALL SELECT 2, id FROM edges WHERE id = ANY($1::uuid[])"
            " UNION ALL SELECT 3, id FROM paths WHERE id = ANY($1::uuid[]) LIMIT 1");
  // A row left by a revision whose elements were never Put (they are not stored: checked
  // just before) is replaced.
  c.prepare("version_add_elements",
            "INSERT INTO element_versions (id, kind, added_rev)"
            " SELECT a.id, a.kind, $3 FROM unnest($1::uuid[], $2::smallint[]) AS a (id, kind)"
            " ON CONFLICT (id) DO UPDATE SET kind = excluded.kind, added_rev = excluded.added_rev,"
            " hidden_rev = NULL");
  c.prepare("version_hide_added",
            Cat({"UPDATE element_versions v SET hidden_rev = $1 WHERE v.added_rev = $2"
                 " AND v.hidden_rev IS NULL AND ",
                 kElementStored}));
  c.prepare("version_hide_nodes",
            "UPDATE element_versions SET hidden_rev = $1"
            " WHERE id = ANY($2::uuid[]) AND kind = 1 AND hidden_rev IS NULL");
  c.prepare("version_hide_touching_versioned",
            Cat({kEdgesTouchingHiddenAt1,
                 "UPDATE element_versions SET hidden_rev = $1 WHERE hidden_rev IS NULL"
                 " AND id IN (SELECT id FROM touching)"}));
  // Edges from outside version control (revision 0) get their row when first hidden.
  c.prepare("version_hide_touching_unversioned",
            Cat({kEdgesTouchingHiddenAt1,
                 "INSERT INTO element_versions (id, kind, added_rev, hidden_rev)"
                 " SELECT t.id, 2, 0, $1 FROM touching t WHERE NOT EXISTS"
                 " (SELECT 1 FROM element_versions v WHERE v.id = t.id)"}));
  c.prepare("version_hidden_counts",
            "SELECT kind, count(*) FROM element_versions WHERE hidden_rev = $1 GROUP BY kind");
}

// The map at a revision, and what changed between two.
void PrepareMapAt(pqxx::connection& c) {
  const std::string visible_nodes =
      Cat({" FROM nodes n LEFT JOIN element_versions v ON v.id = n.id WHERE ", kVisibleAtParam1,
           NotRetiredAtParam1("n")});
  c.prepare("version_nodes_at",
            Cat({"SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks", visible_nodes}));
  c.prepare("version_nodes_at_bare",
            Cat({"SELECT n.id, n.stamp_ns, n.robot, n.outing, NULL", visible_nodes}));
  c.prepare("version_edges_at",
            Cat({"SELECT ", kEdgeColumnsOfE,
                 " FROM edges e LEFT JOIN element_versions v ON v.id = e.id WHERE ",
                 kVisibleAtParam1, NotRetiredAtParam1("e"), " ORDER BY e.id"}));
  c.prepare("version_paths_at",
            Cat({"SELECT p.id, p.robot, p.outing, p.start_ns, p.end_ns FROM paths p"
                 " LEFT JOIN element_versions v ON v.id = p.id WHERE ",
                 kVisibleAtParam1, NotRetiredAtParam1("p"), " ORDER BY p.start_ns, p.id"}));
  c.prepare("version_stats_at",
            Cat({"SELECT count(*), coalesce(sum(octet_length(n.landmarks)), 0),"
                 " (SELECT count(*) FROM edges e LEFT JOIN element_versions v ON v.id = e.id"
                 " WHERE ",
                 kVisibleAtParam1, NotRetiredAtParam1("e"),
                 "), (SELECT count(*) FROM paths p LEFT JOIN element_versions v"
                 " ON v.id = p.id WHERE ",
                 kVisibleAtParam1, NotRetiredAtParam1("p"), ")", visible_nodes}));
  // Only elements some revision in ($1, $2] added or hid can differ between $1 and $2.
  c.prepare("version_changed_between",
            Cat({"SELECT v.id, v.kind, v.added_rev, v.hidden_rev FROM element_versions v"
                 " WHERE ((v.added_rev > $1 AND v.added_rev <= $2)"
                 " OR (v.hidden_rev > $1 AND v.hidden_rev <= $2)) AND ",
                 kElementStored, " ORDER BY v.id"}));
  // With the retirement of it open at the head, if any: one round trip per call, which MERGE
  // makes for every node and edge it meets.
  c.prepare("version_of",
            "SELECT coalesce(v.added_rev, 0), v.hidden_rev, (SELECT retired_rev FROM retirements"
            " WHERE id = $1 AND restored_rev IS NULL) FROM (SELECT id FROM nodes"
            " WHERE id = $1 UNION ALL SELECT id FROM edges WHERE id = $1 UNION ALL"
            " SELECT id FROM paths WHERE id = $1) s LEFT JOIN element_versions v"
            " ON v.id = s.id LIMIT 1");
}

// What the server has seen of each node (0005_submission_nodes.sql), and where an omitted node
// stands in.
void PrepareSeenNodes(pqxx::connection& c) {
  c.prepare("version_put_submission_nodes",
            "INSERT INTO submission_nodes (node, submission) SELECT unnest($1::uuid[]), $2"
            " ON CONFLICT DO NOTHING");
  c.prepare("version_submissions_with_node",
            std::string("SELECT ") + kSubmissionColumns +
                " FROM submissions WHERE id IN (SELECT submission FROM submission_nodes"
                " WHERE node = $1) ORDER BY received_ns, id");
  c.prepare("version_put_stand_in",
            "INSERT INTO stand_ins (node, stand_in, tx, ty, tz, qw, qx, qy, qz, revision)"
            " VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10) ON CONFLICT (node) DO NOTHING");
  c.prepare("version_find_stand_in",
            "SELECT stand_in, tx, ty, tz, qw, qx, qy, qz, revision FROM stand_ins"
            " WHERE node = $1");
  c.prepare("version_stand_ins_of",
            "SELECT stand_in, tx, ty, tz, qw, qx, qy, qz, revision, node FROM stand_ins"
            " WHERE revision = $1 ORDER BY node");
}

// Retirement (0009_retirement.sql) and the use it reads.
void PrepareRetirement(pqxx::connection& c) {
  c.prepare("version_any_retirement", "SELECT EXISTS (SELECT 1 FROM retirements)");
  // The stored nodes among $2 visible at the head, retired by revision $1.
  c.prepare("version_retire_nodes",
            Cat({"INSERT INTO retirements (id, kind, retired_rev) SELECT n.id, 1, $1"
                 " FROM nodes n WHERE n.id = ANY($2::uuid[]) AND ",
                 VisibleAtHead("n"), " ON CONFLICT DO NOTHING"}));
  // Every edge visible at the head with an end among the nodes revision $1 retired.
  c.prepare("version_retire_touching",
            Cat({"WITH gone AS (SELECT id FROM retirements WHERE retired_rev = $1"
                 " AND kind = 1), touching AS (SELECT e.id FROM gone g JOIN edges e"
                 " ON e.from_id = g.id UNION SELECT e.id FROM gone g JOIN edges e"
                 " ON e.to_id = g.id) INSERT INTO retirements (id, kind, retired_rev)"
                 " SELECT touching.id, 2, $1 FROM touching WHERE ",
                 VisibleAtHead("touching")}));
  c.prepare("version_retired_counts",
            "SELECT kind, count(*) FROM retirements WHERE retired_rev = $1 GROUP BY kind");
  c.prepare("version_restore_retired",
            "UPDATE retirements SET restored_rev = $1 WHERE retired_rev = $2"
            " AND restored_rev IS NULL");
  // What revision $1 brought back: restored, and not hidden since by element_versions.
  c.prepare("version_restored_counts",
            "SELECT r.kind, count(*) FROM retirements r WHERE r.restored_rev = $1"
            " AND NOT EXISTS (SELECT 1 FROM element_versions v WHERE v.id = r.id"
            " AND v.hidden_rev IS NOT NULL) GROUP BY r.kind");
  c.prepare("version_set_added_counts",
            "UPDATE revisions SET nodes_added = $2, edges_added = $3, paths_added = $4"
            " WHERE number = $1");
  // Elements some revision in ($1, $2] retired or restored, with their element_versions.
  c.prepare("version_retired_between",
            "SELECT t.id, t.kind, coalesce(v.added_rev, 0), v.hidden_rev FROM"
            " (SELECT DISTINCT id, kind FROM retirements WHERE (retired_rev > $1"
            " AND retired_rev <= $2) OR (restored_rev > $1 AND restored_rev <= $2))"
            " t LEFT JOIN element_versions v ON v.id = t.id");
  c.prepare("version_retirements_of",
            "SELECT id, retired_rev, restored_rev FROM retirements WHERE id = ANY($1::uuid[])");
  c.prepare("version_put_node_usage",
            "INSERT INTO node_usage (node, revision, source, frames, last_ns)"
            " SELECT u.node, $2, u.source, u.frames, u.last_ns FROM unnest($1::uuid[],"
            " $3::smallint[], $4::bigint[], $5::bigint[]) AS u (node, source, frames, last_ns)"
            " ON CONFLICT (node, revision, source) DO UPDATE SET frames = excluded.frames,"
            " last_ns = excluded.last_ns");
  c.prepare("version_usage_at",
            "SELECT node, sum(frames)::bigint, max(last_ns) FROM node_usage WHERE revision <= $1"
            " GROUP BY node ORDER BY node");
}

// Settings.
void PrepareSettings(pqxx::connection& c) {
  c.prepare("version_find_setting", "SELECT value FROM settings WHERE key = $1");
  c.prepare("version_put_setting",
            "INSERT INTO settings (key, value) VALUES ($1, $2)"
            " ON CONFLICT (key) DO UPDATE SET value = excluded.value");
  c.prepare("version_insert_setting_if_absent",
            "INSERT INTO settings (key, value) VALUES ($1, $2) ON CONFLICT (key) DO NOTHING");
  c.prepare("version_replace_setting",
            "UPDATE settings SET value = $3 WHERE key = $1 AND value = $2");
  // left() rather than LIKE: a prefix may hold '%' or '_'. COLLATE "C" orders bytewise, as
  // SQLite does.
  c.prepare("version_list_settings",
            "SELECT key, value FROM settings WHERE left(key, length($1)) = $1"
            " ORDER BY key COLLATE \"C\"");
}

}  // namespace

// One named step per family of statements.
void PrepareVersionStatements(pqxx::connection& c) {
  PrepareSubmissions(c);
  PrepareClaims(c);
  PrepareRevisions(c);
  PrepareElementVersions(c);
  PrepareMapAt(c);
  PrepareSeenNodes(c);
  PrepareSettings(c);
  PrepareRetirement(c);
}

}  // namespace fleetmap::internal
