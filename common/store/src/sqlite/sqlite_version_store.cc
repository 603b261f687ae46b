// SQLite VersionStore (version_store.h; schema in migrations/0002_versions.sql).
//
// - It runs on its GraphStore's connection, so a call made inside an open Transaction lands
//   or rolls back with it.
// - A write of more than one statement runs under a savepoint inside a Transaction, else in
//   a BEGIN IMMEDIATE transaction of its own: it holds the write lock from its checks to its
//   commit, so no other writer can slip in between (SQLite serialises writers).
// - Statements are prepared once (sqlite_version_statements.cc holds their SQL). Additions
//   are checked and versioned kElementsPerStatement elements to a statement (see
//   AppendRevision).
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
#include "sqlite/sqlite_version_statements.h"
#include "sqlite/statement.h"
#include "version_rules.h"

namespace fleetmap::internal {

namespace {

// The stand-in of `node` from a row of (stand_in, tx, ty, tz, qw, qx, qy, qz, revision).
NodeStandIn StandInAt(Statement& row, const Uuid& node) {
  NodeStandIn found;
  found.node = node;
  found.stand_in = row.UuidAt(0);
  found.stand_in_T_node = Se3FromTranslationQuaternion(
      Eigen::Vector3d(row.Double(1), row.Double(2), row.Double(3)),
      Eigen::Quaterniond(row.Double(4), row.Double(5), row.Double(6), row.Double(7)));
  found.revision = row.Int64(8);
  return found;
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
      const std::optional<Revision> target = FindRevision(revision.reverted);
      RequireRevertable(revision.reverted, target, reverted_by);
      InsertRevision(recorded);
      if (target->kind == RevisionKind::kRetire) {
        Restore(recorded);
        return;
      }
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

  Revision AppendRetirement(const Revision& revision, const std::vector<Uuid>& nodes) override {
    Revision recorded = RetirementAsRecorded(revision);
    Atomically([&] {
      RequireNextRevision(revision.number, Head());
      InsertRevision(recorded);
      for (const Uuid& node : nodes) {
        StatementUse s(s_.retire_node);
        s->Bind(1, revision.number);
        s->Bind(2, node);
        s->Run();
      }
      {
        StatementUse s(s_.retire_touching);
        s->Bind(1, revision.number);
        s->Run();
      }
      {
        StatementUse s(s_.retired_counts);
        s->Bind(1, revision.number);
        while (s->Step()) {
          SetHiddenCount(recorded, StoredVersionedKind(s->Int64(0), Uuid()), s->Int64(1));
        }
      }
      StatementUse s(s_.set_hidden_counts);
      s->Bind(1, recorded.number);
      s->Bind(2, recorded.nodes_hidden);
      s->Bind(3, recorded.edges_hidden);
      s->Bind(4, recorded.paths_hidden);
      s->Run();
    });
    return recorded;
  }

  // ---- Use ----

  void PutNodeUsage(RevisionNumber revision, const std::vector<NodeUsage>& usage) override {
    for (const NodeUsage& use : usage) RequireValidUsage(use);
    Atomically([&] {
      for (const NodeUsage& use : usage) {
        StatementUse s(s_.put_node_usage);
        s->Bind(1, use.node);
        s->Bind(2, revision);
        s->Bind(3, static_cast<std::int64_t>(use.source));
        s->Bind(4, use.frames);
        s->Bind(5, use.last_ns);
        s->Run();
      }
    });
  }

  std::vector<NodeUsage> UsageAt(RevisionNumber r) override {
    RequireInHistory(r, Head());
    StatementUse s(s_.usage_at);
    s->Bind(1, r);
    std::vector<NodeUsage> usage;
    while (s->Step()) {
      NodeUsage use;
      use.node = s->UuidAt(0);
      use.frames = s->Int64(1);
      use.last_ns = s->Int64(2);
      usage.push_back(use);
    }
    return usage;
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
    const auto read_rows = [&rows](Statement& rows_of) {
      while (rows_of.Step()) {
        const Uuid id = rows_of.UuidAt(0);
        std::optional<RevisionNumber> hidden;
        if (!rows_of.IsNull(3)) hidden = rows_of.Int64(3);
        rows.push_back(
            {id, StoredVersionedKind(rows_of.Int64(1), id), rows_of.Int64(2), hidden, {}});
      }
    };
    read_rows(*s);
    if (AnyRetirement()) {
      {
        StatementUse retired(s_.retired_between);
        retired->Bind(1, std::min(from, to));
        retired->Bind(2, std::max(from, to));
        read_rows(*retired);
      }
      std::sort(rows.begin(), rows.end(),
                [](const ElementVersionRow& a, const ElementVersionRow& b) { return a.id < b.id; });
      rows.erase(std::unique(rows.begin(), rows.end(),
                             [](const ElementVersionRow& a, const ElementVersionRow& b) {
                               return a.id == b.id;
                             }),
                 rows.end());
      for (ElementVersionRow& row : rows) {
        StatementUse spans(s_.retirements_of);
        spans->Bind(1, row.id);
        while (spans->Step()) {
          RetirementSpan span{spans->Int64(0), std::nullopt};
          if (!spans->IsNull(1)) span.restored = spans->Int64(1);
          row.retirements.push_back(span);
        }
      }
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
    if (!s->IsNull(2) && (!v.hidden || s->Int64(2) < *v.hidden)) v.hidden = s->Int64(2);
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
    return StandInAt(*s, node);
  }

  std::vector<NodeStandIn> StandInsOf(RevisionNumber revision) override {
    StatementUse s(s_.stand_ins_of);
    s->Bind(1, revision);
    std::vector<NodeStandIn> stand_ins;
    while (s->Step()) stand_ins.push_back(StandInAt(*s, s->UuidAt(9)));
    return stand_ins;
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
    for (std::size_t i = 0; i < elements.size(); i += kElementsPerStatement) {
      StatementUse s(s_.stored_among);
      for (std::size_t j = i; j < std::min(i + kElementsPerStatement, elements.size()); ++j) {
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
    for (; i + kElementsPerStatement <= elements.size(); i += kElementsPerStatement) {
      StatementUse s(s_.add_elements);
      s->Bind(1, number);
      for (int j = 0; j < kElementsPerStatement; ++j) {
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
  bool AnyRetirement() {
    StatementUse s(s_.any_retirement);
    return s->Step() && s->Int64(0) != 0;
  }

  // A revert of a retirement: closes what it hid and counts what came back as added.
  void Restore(Revision& recorded) {
    {
      StatementUse s(s_.restore_retired);
      s->Bind(1, recorded.number);
      s->Bind(2, recorded.reverted);
      s->Run();
    }
    {
      StatementUse s(s_.restored_counts);
      s->Bind(1, recorded.number);
      while (s->Step()) {
        SetRestoredCount(recorded, StoredVersionedKind(s->Int64(0), Uuid()), s->Int64(1));
      }
    }
    StatementUse s(s_.set_added_counts);
    s->Bind(1, recorded.number);
    s->Bind(2, recorded.nodes_added);
    s->Bind(3, recorded.edges_added);
    s->Bind(4, recorded.paths_added);
    s->Run();
  }

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
  SqliteVersionStatements s_;
};

}  // namespace

std::unique_ptr<VersionStore> NewSqliteVersionStore(sqlite3* db) {
  return std::make_unique<SqliteVersionStore>(db);
}

}  // namespace fleetmap::internal
