// SQLite VersionStore (version_store.h; schema in migrations/0002_versions.sql).
//
// - It runs on its GraphStore's connection, so a call made inside an open Transaction lands
//   or rolls back with it.
// - A write of more than one statement runs under a savepoint inside a Transaction, else in
//   a BEGIN IMMEDIATE transaction of its own: it holds the write lock from its checks to its
//   commit, so no other writer can slip in between (SQLite serialises writers).
// - Statements are prepared once. Additions are checked and versioned kChunk elements to a
//   statement (see AppendRevision).
#include "sqlite/sqlite_version_store.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <string>
#include <type_traits>
#include <vector>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "sqlite/element_rows.h"
#include "sqlite/statement.h"
#include "version_rules.h"

namespace fleetmap::internal {

namespace {

// Elements per statement in AppendRevision: SQLite sets up a statement (a cursor on every
// index it touches) each time it runs, and 32 elements pay that once instead of 32 times
// (as the graph store's batch inserts do); AppendRevision of 10^5 elements takes about as
// long as their Put.
constexpr int kChunk = 32;

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

constexpr const char* kVisibleNodes =
    " FROM nodes n LEFT JOIN element_versions v ON v.id = n.id WHERE coalesce(v.added_rev, 0)"
    " <= ?1 AND (v.hidden_rev IS NULL OR v.hidden_rev > ?1)";

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

class SqliteVersionStore final : public VersionStore {
 public:
  explicit SqliteVersionStore(sqlite3* db) : db_(db), s_(db) {}

  // ---- Submissions ----

  Submission BeginSubmission(const Submission& header) override {
    if (header.id.IsNil()) {
      throw Error(ErrorCode::kInvalidArgument, "a submission needs a non-nil id");
    }
    const Submission stored = Atomically([&] {
      {
        StatementUse s(s_.begin_submission);
        s->Bind(1, header.id);
        s->Bind(2, header.robot);
        s->BindText(3, header.author);
        s->Bind(4, header.received_ns);
        s->Run();
      }
      return *Find(header.id);
    });
    RequireSameRobot(stored, header);
    return stored;
  }

  void PutSubmissionChunk(const Uuid& id, std::int64_t seq, std::string_view data) override {
    Atomically([&] {
      const Submission stored = Require(id);
      if (ChunkIsStored(stored, seq)) {
        StatementUse s(s_.chunk_equals);
        s->Bind(1, id);
        s->Bind(2, seq);
        s->BindBlob(3, data);
        if (!s->Step() || s->Int64(0) != 1) throw ChunkConflict(id, seq);
        return;
      }
      {
        StatementUse s(s_.insert_chunk);
        s->Bind(1, id);
        s->Bind(2, seq);
        s->BindBlob(3, data);
        s->Run();
      }
      StatementUse s(s_.count_chunk);
      s->Bind(1, id);
      s->Bind(2, static_cast<std::int64_t>(data.size()));
      s->Run();
    });
  }

  void CompleteSubmission(const Uuid& id, std::uint64_t digest) override {
    Atomically([&] {
      if (CompleteAlready(Require(id), digest)) return;
      StatementUse s(s_.complete_submission);
      s->Bind(1, id);
      s->Bind(2, std::bit_cast<std::int64_t>(digest));
      s->Run();
    });
  }

  void SetSubmissionState(const Uuid& id, SubmissionState state, RevisionNumber revision,
                          const std::string& error) override {
    Atomically([&] {
      const Submission next = WithState(Require(id), state, revision, error);
      StatementUse s(s_.set_submission_state);
      s->Bind(1, id);
      s->Bind(2, static_cast<std::int64_t>(next.state));
      s->Bind(3, next.revision);
      s->BindText(4, next.error);
      s->Run();
    });
  }

  std::optional<Submission> FindSubmission(const Uuid& id) override { return Find(id); }

  std::vector<Submission> ListSubmissions() override {
    StatementUse s(s_.list_submissions);
    std::vector<Submission> submissions;
    while (s->Step()) submissions.push_back(ReadSubmission(*s));
    return submissions;
  }

  std::string SubmissionChunk(const Uuid& id, std::int64_t seq) override {
    {
      StatementUse s(s_.chunk);
      s->Bind(1, id);
      s->Bind(2, seq);
      if (s->Step()) return std::string(s->Blob(0));
    }
    Require(id);
    throw Error(ErrorCode::kNotFound,
                "no chunk " + std::to_string(seq) + " of submission " + id.ToString());
  }

  // ---- Claims ----

  std::optional<Submission> ClaimQueuedSubmission(const std::string& instance,
                                                  std::chrono::milliseconds lease,
                                                  const std::vector<Uuid>& skip) override {
    // BEGIN IMMEDIATE: the write lock is taken before the read, so two connections cannot
    // both pick the same submission.
    const std::int64_t lease_ns = ClaimLeaseNs(instance, lease);
    return Atomically([&]() -> std::optional<Submission> {
      const std::int64_t now = NowNs();
      std::optional<Uuid> id;
      {
        StatementUse s(s_.first_claimable);
        s->BindText(1, instance);
        s->Bind(2, now);
        while (!id && s->Step()) {
          const Uuid candidate = s->UuidAt(0);
          if (std::find(skip.begin(), skip.end(), candidate) == skip.end()) id = candidate;
        }
        if (!id) return std::nullopt;
      }
      StatementUse s(s_.set_claim);
      s->Bind(1, *id);
      s->BindText(2, instance);
      s->Bind(3, now + lease_ns);
      s->Run();
      return Find(*id);
    });
  }

  bool RenewClaim(const Uuid& id, const std::string& instance,
                  std::chrono::milliseconds lease) override {
    const std::int64_t lease_ns = ClaimLeaseNs(instance, lease);
    return Atomically([&] {
      const std::int64_t now = NowNs();
      StatementUse s(s_.renew_claim);
      s->Bind(1, id);
      s->BindText(2, instance);
      s->Bind(3, now + lease_ns);
      s->Run();
      return sqlite3_changes(db_) == 1;
    });
  }

  void ReleaseClaim(const Uuid& id, const std::string& instance) override {
    StatementUse s(s_.release_claim);
    s->Bind(1, id);
    s->BindText(2, instance);
    s->Run();
  }

  std::optional<SubmissionClaim> FindClaim(const Uuid& id) override {
    StatementUse s(s_.find_claim);
    s->Bind(1, id);
    if (!s->Step()) {
      throw NoSubmission(id);
    }
    if (s->Text(0).empty()) return std::nullopt;
    return SubmissionClaim{s->Text(0), s->Int64(1)};
  }

  // ---- Revisions ----

  RevisionNumber HeadRevision() override { return Head(); }

  std::optional<Revision> FindRevision(RevisionNumber number) override {
    StatementUse s(s_.find_revision);
    s->Bind(1, number);
    if (!s->Step()) return std::nullopt;
    return ReadRevision(*s);
  }

  std::vector<Revision> ListRevisions() override {
    StatementUse s(s_.list_revisions);
    std::vector<Revision> revisions;
    while (s->Step()) revisions.push_back(ReadRevision(*s));
    return revisions;
  }

  Revision AppendRevision(const Revision& revision, const GraphBatch& additions) override {
    RequireMergeInTransaction(revision, !sqlite3_get_autocommit(db_));
    Revision recorded = revision;
    recorded.reverted = 0;
    recorded.nodes_hidden = recorded.edges_hidden = recorded.paths_hidden = 0;
    const std::vector<VersionedElement> elements = VersionedElementsOf(additions, recorded);
    Atomically([&] {
      RequireNextRevision(revision.number, Head());
      RequireNoneStored(elements, revision.number);
      InsertRevision(recorded);
      AddElements(revision.number, elements);
    });
    return recorded;
  }

  Revision AppendPromotion(const Revision& revision, const GraphBatch& additions,
                           const std::vector<Uuid>& hide_nodes) override {
    Revision recorded =
        PromotionAsRecorded(revision, additions, hide_nodes, !sqlite3_get_autocommit(db_));
    const std::vector<VersionedElement> elements = VersionedElementsOf(additions, recorded);
    Atomically([&] {
      RequireNextRevision(revision.number, Head());
      RequireNoneStored(elements, revision.number);
      InsertRevision(recorded);
      AddElements(revision.number, elements);
      for (const Uuid& node : hide_nodes) {
        StatementUse s(s_.hide_node);
        s->Bind(1, revision.number);
        s->Bind(2, node);
        s->Run();
      }
      HideTouchingAndCount(recorded);
    });
    return recorded;
  }

  Revision AppendRevert(const Revision& revision) override {
    const RevisionNumber number = revision.number;
    Revision recorded = RevertAsRecorded(revision);
    Atomically([&] {
      RequireNextRevision(number, Head());
      std::optional<RevisionNumber> reverted_by;
      {
        StatementUse s(s_.reverted_by);
        s->Bind(1, revision.reverted);
        if (s->Step()) reverted_by = s->Int64(0);
      }
      RequireRevertable(revision.reverted, FindRevision(revision.reverted), reverted_by);
      InsertRevision(recorded);
      {
        StatementUse s(s_.hide_added);
        s->Bind(1, number);
        s->Bind(2, revision.reverted);
        s->Run();
      }
      HideTouchingAndCount(recorded);
    });
    return recorded;
  }

  // ---- The map at a revision ----

  std::vector<Node> NodesAt(RevisionNumber r, bool with_landmarks) override {
    RequireInHistory(r, Head());
    StatementUse s(with_landmarks ? s_.nodes_at : s_.nodes_at_bare);
    s->Bind(1, r);
    std::vector<Node> nodes;
    while (s->Step()) nodes.push_back(ReadNode(*s, with_landmarks));
    OrderNodesAt(nodes);
    return nodes;
  }

  std::vector<Edge> EdgesAt(RevisionNumber r) override {
    RequireInHistory(r, Head());
    StatementUse s(s_.edges_at);
    s->Bind(1, r);
    std::vector<Edge> edges;
    while (s->Step()) edges.push_back(ReadEdge(*s, 0));
    return edges;
  }

  std::vector<Path> PathsAt(RevisionNumber r) override {
    RequireInHistory(r, Head());
    StatementUse s(s_.paths_at);
    s->Bind(1, r);
    std::vector<Path> paths;
    while (s->Step()) paths.push_back(ReadPath(*s));
    return paths;
  }

  StoreStats StatsAt(RevisionNumber r) override {
    RequireInHistory(r, Head());
    StatementUse s(s_.stats_at);
    s->Bind(1, r);
    s->Step();
    StoreStats stats;
    stats.nodes = s->Int64(0);
    stats.landmark_bytes = s->Int64(1);
    stats.edges = s->Int64(2);
    stats.paths = s->Int64(3);
    return stats;
  }

  RevisionChanges Changes(RevisionNumber from, RevisionNumber to) override {
    const RevisionNumber head = Head();
    RequireInHistory(from, head);
    RequireInHistory(to, head);
    StatementUse s(s_.changed_between);
    s->Bind(1, std::min(from, to));
    s->Bind(2, std::max(from, to));
    std::vector<ElementVersionRow> rows;
    while (s->Step()) {
      const Uuid id = s->UuidAt(0);
      std::optional<RevisionNumber> hidden;
      if (!s->IsNull(3)) hidden = s->Int64(3);
      rows.push_back({id, StoredVersionedKind(s->Int64(1), id), s->Int64(2), hidden});
    }
    return ChangesFromRows(from, to, rows);
  }

  std::optional<ElementVersion> VersionOf(const Uuid& id) override {
    StatementUse s(s_.version_of);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    ElementVersion v;
    v.added = s->Int64(0);
    if (!s->IsNull(1)) v.hidden = s->Int64(1);
    return v;
  }

  // ---- What the server has seen of each node ----

  void PutSubmissionNodes(const Uuid& id, const std::vector<Uuid>& nodes) override {
    Atomically([&] {
      Require(id);
      for (const Uuid& node : nodes) {
        StatementUse s(s_.put_submission_node);
        s->Bind(1, node);
        s->Bind(2, id);
        s->Run();
      }
    });
  }

  std::vector<Submission> SubmissionsWithNode(const Uuid& node) override {
    StatementUse s(s_.submissions_with_node);
    s->Bind(1, node);
    std::vector<Submission> submissions;
    while (s->Step()) submissions.push_back(ReadSubmission(*s));
    return submissions;
  }

  void PutStandIns(const std::vector<NodeStandIn>& stand_ins) override {
    Atomically([&] {
      for (const NodeStandIn& stand_in : stand_ins) {
        StatementUse s(s_.put_stand_in);
        s->Bind(1, stand_in.node);
        s->Bind(2, stand_in.stand_in);
        const Eigen::Vector3d t = stand_in.stand_in_T_node.translation();
        const Eigen::Quaterniond q = RotationQuaternion(stand_in.stand_in_T_node);
        const double values[] = {t.x(), t.y(), t.z(), q.w(), q.x(), q.y(), q.z()};
        for (int i = 0; i < 7; ++i) s->Bind(3 + i, values[i]);
        s->Bind(10, stand_in.revision);
        s->Run();
      }
    });
  }

  std::optional<NodeStandIn> FindStandIn(const Uuid& node) override {
    StatementUse s(s_.find_stand_in);
    s->Bind(1, node);
    if (!s->Step()) return std::nullopt;
    NodeStandIn found;
    found.node = node;
    found.stand_in = s->UuidAt(0);
    found.stand_in_T_node = Se3FromTranslationQuaternion(
        Eigen::Vector3d(s->Double(1), s->Double(2), s->Double(3)),
        Eigen::Quaterniond(s->Double(4), s->Double(5), s->Double(6), s->Double(7)));
    found.revision = s->Int64(8);
    return found;
  }

  // ---- Settings ----

  std::optional<std::string> FindSetting(std::string_view key) override {
    StatementUse s(s_.find_setting);
    s->BindText(1, key);
    if (!s->Step()) return std::nullopt;
    return std::string(s->Blob(0));
  }

  void PutSetting(std::string_view key, std::string_view value) override {
    StatementUse s(s_.put_setting);
    s->BindText(1, key);
    s->BindBlob(2, value);
    s->Run();
  }

  bool ReplaceSetting(std::string_view key, const std::optional<std::string>& expected,
                      std::string_view value) override {
    // One statement: atomic by itself, and SQLite has one writer at a time.
    if (!expected) {
      StatementUse s(s_.insert_setting_if_absent);
      s->BindText(1, key);
      s->BindBlob(2, value);
      return s->Run() == 1;
    }
    StatementUse s(s_.replace_setting);
    s->BindText(1, key);
    s->BindBlob(2, *expected);
    s->BindBlob(3, value);
    return s->Run() == 1;
  }

  std::vector<std::pair<std::string, std::string>> ListSettings(std::string_view prefix) override {
    StatementUse s(s_.list_settings);
    s->BindBlob(1, prefix);
    std::vector<std::pair<std::string, std::string>> settings;
    while (s->Step()) settings.emplace_back(s->Text(0), std::string(s->Blob(1)));
    return settings;
  }

 private:
  struct Statements {
    explicit Statements(sqlite3* db)
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
          head(db, "SELECT coalesce(max(number), 0) FROM revisions"),
          find_revision(
              db, Sql({"SELECT ", kRevisionColumns, " FROM revisions WHERE number = ?1"}).c_str()),
          list_revisions(
              db, Sql({"SELECT ", kRevisionColumns, " FROM revisions ORDER BY number"}).c_str()),
          reverted_by(db, "SELECT number FROM revisions WHERE reverted = ?1"),
          insert_revision(db,
                          "INSERT INTO revisions (number, created_ns, author, kind, submission,"
                          " reverted, nodes_added, edges_added, paths_added, nodes_hidden,"
                          " edges_hidden, paths_hidden, report) VALUES (?1, ?2, ?3, ?4, ?5,"
                          " NULLIF(?6, 0), ?7, ?8, ?9, ?10, ?11, ?12, ?13)"),
          set_hidden_counts(db,
                            "UPDATE revisions SET nodes_hidden = ?2, edges_hidden = ?3,"
                            " paths_hidden = ?4 WHERE number = ?1"),
          stored_among(db, StoredAmongSql(kChunk).c_str()),
          add_elements(db, AddElementsSql(kChunk).c_str()),
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
                        " GROUP BY kind"),
          nodes_at(db,
                   Sql({"SELECT n.id, n.stamp_ns, n.robot, n.outing, n.landmarks", kVisibleNodes})
                       .c_str()),
          nodes_at_bare(
              db, Sql({"SELECT n.id, n.stamp_ns, n.robot, n.outing, NULL", kVisibleNodes}).c_str()),
          edges_at(db, Sql({"SELECT ", kEdgeColumnsOfE,
                            " FROM edges e LEFT JOIN element_versions v ON v.id = e.id WHERE ",
                            kVisibleAtParam1, " ORDER BY e.id"})
                           .c_str()),
          paths_at(db, Sql({"SELECT p.id, p.robot, p.outing, p.start_ns, p.end_ns FROM paths p"
                            " LEFT JOIN element_versions v ON v.id = p.id WHERE ",
                            kVisibleAtParam1, " ORDER BY p.start_ns, p.id"})
                           .c_str()),
          stats_at(db, Sql({"SELECT count(*), coalesce(sum(length(n.landmarks)), 0),"
                            " (SELECT count(*) FROM edges e LEFT JOIN element_versions v"
                            " ON v.id = e.id WHERE ",
                            kVisibleAtParam1,
                            "), (SELECT count(*) FROM paths p LEFT JOIN element_versions v"
                            " ON v.id = p.id WHERE ",
                            kVisibleAtParam1, ")", kVisibleNodes})
                           .c_str()),
          // Only elements some revision in (?1, ?2] added or hid can differ between them.
          changed_between(db, Sql({"SELECT v.id, v.kind, v.added_rev, v.hidden_rev"
                                   " FROM element_versions v WHERE ((v.added_rev > ?1"
                                   " AND v.added_rev <= ?2) OR (v.hidden_rev > ?1"
                                   " AND v.hidden_rev <= ?2)) AND ",
                                   kElementStored, " ORDER BY v.id"})
                                  .c_str()),
          version_of(db,
                     "SELECT coalesce(v.added_rev, 0), v.hidden_rev FROM (SELECT id FROM nodes"
                     " WHERE id = ?1 UNION ALL SELECT id FROM edges WHERE id = ?1 UNION ALL"
                     " SELECT id FROM paths WHERE id = ?1) s LEFT JOIN element_versions v"
                     " ON v.id = s.id LIMIT 1"),
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
          first_claimable(db,
                          "SELECT id FROM submissions WHERE state = 1 AND (claimed_by = ''"
                          " OR claimed_by = ?1 OR lease_until_ns <= ?2)"
                          " ORDER BY received_ns, id"),
          set_claim(db,
                    "UPDATE submissions SET claimed_by = ?2, lease_until_ns = ?3 WHERE id = ?1"),
          renew_claim(db,
                      "UPDATE submissions SET lease_until_ns = ?3 WHERE id = ?1"
                      " AND claimed_by = ?2"),
          release_claim(db,
                        "UPDATE submissions SET claimed_by = '', lease_until_ns = 0 WHERE id = ?1"
                        " AND claimed_by = ?2"),
          find_claim(db, "SELECT claimed_by, lease_until_ns FROM submissions WHERE id = ?1") {}

    Statement begin_submission, find_submission, list_submissions;
    Statement chunk_equals, insert_chunk, count_chunk, chunk;
    Statement complete_submission, set_submission_state;
    Statement head, find_revision, list_revisions, reverted_by, insert_revision;
    Statement set_hidden_counts;
    Statement stored_among, add_elements, add_element;
    Statement hide_added, hide_node, hide_touching_versioned, hide_touching_unversioned,
        hidden_counts;
    Statement nodes_at, nodes_at_bare, edges_at, paths_at, stats_at, changed_between;
    Statement version_of;
    Statement find_setting, put_setting, insert_setting_if_absent, replace_setting, list_settings;
    Statement put_submission_node, submissions_with_node, put_stand_in, find_stand_in;
    Statement first_claimable, set_claim, renew_claim, release_claim, find_claim;
  };

  // SQLite is a local file, so the host's clock is the database's.
  static std::int64_t NowNs() { return WallClockNs(); }

  // Runs fn as one atomic unit: under a savepoint inside an open transaction (so a failure
  // undoes only fn's writes), else in a BEGIN IMMEDIATE transaction of its own.
  template <typename Fn>
  auto Atomically(Fn&& fn) -> decltype(fn()) {
    const bool nested = !sqlite3_get_autocommit(db_);
    ExecSql(db_, nested ? "SAVEPOINT fleetmap_atomic" : "BEGIN IMMEDIATE");
    try {
      if constexpr (std::is_void_v<decltype(fn())>) {
        fn();
        ExecSql(db_, nested ? "RELEASE fleetmap_atomic" : "COMMIT");
      } else {
        auto result = fn();
        ExecSql(db_, nested ? "RELEASE fleetmap_atomic" : "COMMIT");
        return result;
      }
    } catch (...) {
      if (nested) {
        ExecSql(db_, "ROLLBACK TO fleetmap_atomic");
        ExecSql(db_, "RELEASE fleetmap_atomic");
      } else if (!sqlite3_get_autocommit(db_)) {
        ExecSql(db_, "ROLLBACK");
      }
      throw;
    }
  }

  RevisionNumber Head() {
    StatementUse s(s_.head);
    s->Step();
    return s->Int64(0);
  }

  std::optional<Submission> Find(const Uuid& id) {
    StatementUse s(s_.find_submission);
    s->Bind(1, id);
    if (!s->Step()) return std::nullopt;
    return ReadSubmission(*s);
  }

  Submission Require(const Uuid& id) {
    std::optional<Submission> found = Find(id);
    if (!found) throw NoSubmission(id);
    return std::move(*found);
  }

  // Throws AlreadyStored for the first of `elements` that is stored already.
  void RequireNoneStored(const std::vector<VersionedElement>& elements, RevisionNumber number) {
    for (std::size_t i = 0; i < elements.size(); i += kChunk) {
      StatementUse s(s_.stored_among);
      for (std::size_t j = i; j < std::min(i + kChunk, elements.size()); ++j) {
        s->Bind(static_cast<int>(j - i + 1), elements[j].id);
      }
      if (s->Step()) {
        const Uuid stored = s->UuidAt(1);
        throw AlreadyStored(StoredVersionedKind(s->Int64(0), stored), stored, number);
      }
    }
  }

  // Records revision `number` as having added `elements`.
  void AddElements(RevisionNumber number, const std::vector<VersionedElement>& elements) {
    std::size_t i = 0;
    for (; i + kChunk <= elements.size(); i += kChunk) {
      StatementUse s(s_.add_elements);
      s->Bind(1, number);
      for (int j = 0; j < kChunk; ++j) {
        s->Bind(2 + 2 * j, elements[i + j].id);
        s->Bind(3 + 2 * j, static_cast<std::int64_t>(elements[i + j].kind));
      }
      s->Run();
    }
    for (; i < elements.size(); ++i) {
      StatementUse s(s_.add_element);
      s->Bind(1, number);
      s->Bind(2, elements[i].id);
      s->Bind(3, static_cast<std::int64_t>(elements[i].kind));
      s->Run();
    }
  }

  // After revision `recorded` hid nodes or paths: hides every visible edge left touching them
  // and records what the revision hid in all.
  void HideTouchingAndCount(Revision& recorded) {
    const RevisionNumber number = recorded.number;
    for (Statement* statement : {&s_.hide_touching_versioned, &s_.hide_touching_unversioned}) {
      StatementUse s(*statement);
      s->Bind(1, number);
      s->Run();
    }
    {
      StatementUse s(s_.hidden_counts);
      s->Bind(1, number);
      while (s->Step()) {
        SetHiddenCount(recorded, StoredVersionedKind(s->Int64(0), Uuid()), s->Int64(1));
      }
    }
    StatementUse s(s_.set_hidden_counts);
    s->Bind(1, number);
    s->Bind(2, recorded.nodes_hidden);
    s->Bind(3, recorded.edges_hidden);
    s->Bind(4, recorded.paths_hidden);
    s->Run();
  }

  void InsertRevision(const Revision& v) {
    StatementUse s(s_.insert_revision);
    s->Bind(1, v.number);
    s->Bind(2, v.created_ns);
    s->BindText(3, v.author);
    s->Bind(4, static_cast<std::int64_t>(v.kind));
    s->BindNullableUuid(5, v.submission);
    s->Bind(6, v.reverted);
    s->Bind(7, v.nodes_added);
    s->Bind(8, v.edges_added);
    s->Bind(9, v.paths_added);
    s->Bind(10, v.nodes_hidden);
    s->Bind(11, v.edges_hidden);
    s->Bind(12, v.paths_hidden);
    s->BindText(13, v.report);
    s->Run();
  }

  sqlite3* db_;
  Statements s_;
};

}  // namespace

std::unique_ptr<VersionStore> NewSqliteVersionStore(sqlite3* db) {
  return std::make_unique<SqliteVersionStore>(db);
}

}  // namespace fleetmap::internal
