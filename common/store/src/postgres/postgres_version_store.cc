// PostgreSQL VersionStore (version_store.h; schema in migrations/0002_versions.sql).
//
// - It shares its GraphStore's PgSession: every call runs in the open explicit Transaction if
//   there is one, so it lands or rolls back with it.
// - Writes of more than one statement run through PgSession::Atomically: under a savepoint
//   inside a Transaction, else in a transaction of their own.
// - Concurrent writers are many connections (seed 000 §5.2). The database arbitrates: the
//   primary key on revisions.number makes two writers racing for head + 1 end in one
//   revision and one Error(kConflict), and a submission's row is locked (FOR UPDATE) while one
//   writer decides what a chunk, a completion or a state change does to it.
// - Additions are checked and versioned set-wise (uuid[] parameters), a few statements per
//   revision however large it is.
#include "postgres/postgres_version_store.h"

#include <algorithm>
#include <bit>
#include <chrono>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"
#include "postgres/element_rows.h"
#include "postgres/postgres_version_statements.h"
#include "version_rules.h"

namespace fleetmap::internal {

namespace {

std::string Str(std::int64_t value) {
  return std::to_string(value);
}

std::string RevisionName(RevisionNumber number) {
  return "revision " + std::to_string(number);
}

Submission ReadSubmission(const pqxx::row& r) {
  Submission s;
  s.id = UuidField(r[0]);
  s.robot = UuidField(r[1]);
  s.author = r[2].c_str();
  s.received_ns = r[3].as<std::int64_t>();
  s.chunk_count = r[4].as<std::int64_t>();
  s.bytes = r[5].as<std::int64_t>();
  s.digest = std::bit_cast<std::uint64_t>(r[6].as<std::int64_t>());
  s.state = static_cast<SubmissionState>(r[7].as<int>());
  s.revision = r[8].as<std::int64_t>();
  s.error = r[9].c_str();
  return s;
}

// The stand-in of `node` from a row of (stand_in, tx, ty, tz, qw, qx, qy, qz, revision).
NodeStandIn StandInAt(const pqxx::row& r, const Uuid& node) {
  NodeStandIn found;
  found.node = node;
  found.stand_in = UuidField(r[0]);
  found.stand_in_T_node = Se3FromTranslationQuaternion(
      Eigen::Vector3d(r[1].as<double>(), r[2].as<double>(), r[3].as<double>()),
      Eigen::Quaterniond(r[4].as<double>(), r[5].as<double>(), r[6].as<double>(),
                         r[7].as<double>()));
  found.revision = r[8].as<std::int64_t>();
  return found;
}

Revision ReadRevision(const pqxx::row& r) {
  Revision v;
  v.number = r[0].as<std::int64_t>();
  v.created_ns = r[1].as<std::int64_t>();
  v.author = r[2].c_str();
  v.kind = static_cast<RevisionKind>(r[3].as<int>());
  v.submission = UuidField(r[4]);
  v.reverted = r[5].as<std::int64_t>();
  v.nodes_added = r[6].as<std::int64_t>();
  v.edges_added = r[7].as<std::int64_t>();
  v.paths_added = r[8].as<std::int64_t>();
  v.nodes_hidden = r[9].as<std::int64_t>();
  v.edges_hidden = r[10].as<std::int64_t>();
  v.paths_hidden = r[11].as<std::int64_t>();
  v.report = r[12].c_str();
  return v;
}

class PostgresVersionStore final : public VersionStore {
 public:
  explicit PostgresVersionStore(PgSession& session) : session_(session) {
    session_.AddConnectionSetup("prepare version statements", [this] { Prepare(); });
  }

  // ---- Submissions ----

  Submission BeginSubmission(const Submission& header) override {
    if (header.id.IsNil()) {
      throw Error(ErrorCode::kInvalidArgument, "a submission needs a non-nil id");
    }
    const std::string id = header.id.ToString();
    const Submission stored =
        session_.Atomically("begin submission " + id, [&](pqxx::transaction_base& t) {
          t.exec_prepared("version_begin_submission", id, header.robot.ToString(), header.author,
                          header.received_ns);
          return ReadSubmission(t.exec_prepared1("version_find_submission", id));
        });
    RequireSameRobot(stored, header);
    return stored;
  }

  void PutSubmissionChunk(const Uuid& id, std::int64_t seq, std::string_view data) override {
    const pqxx::binarystring bytes(data.data(), data.size());
    session_.Atomically(
        "chunk " + Str(seq) + " of submission " + id.ToString(), [&](pqxx::transaction_base& t) {
          const Submission stored = LockSubmission(t, id);
          if (ChunkIsStored(stored, seq)) {
            // Compared in the server: a retried chunk does not travel back.
            if (!t.exec_prepared1("version_chunk_equals", id.ToString(), seq, bytes)[0]
                     .as<bool>()) {
              throw ChunkConflict(id, seq);
            }
            return;
          }
          t.exec_prepared("version_insert_chunk", id.ToString(), seq, bytes);
          t.exec_prepared("version_count_chunk", id.ToString(),
                          static_cast<std::int64_t>(data.size()));
        });
  }

  void CompleteSubmission(const Uuid& id, std::uint64_t digest) override {
    session_.Atomically("complete submission " + id.ToString(), [&](pqxx::transaction_base& t) {
      if (CompleteAlready(LockSubmission(t, id), digest)) return;
      t.exec_prepared("version_complete_submission", id.ToString(),
                      std::bit_cast<std::int64_t>(digest));
    });
  }

  void SetSubmissionState(const Uuid& id, SubmissionState state, RevisionNumber revision,
                          const std::string& error) override {
    session_.Atomically("set state of submission " + id.ToString(), [&](pqxx::transaction_base& t) {
      const Submission next = WithState(LockSubmission(t, id), state, revision, error);
      t.exec_prepared("version_set_submission_state", id.ToString(), static_cast<int>(next.state),
                      next.revision, next.error);
    });
  }

  std::optional<Submission> FindSubmission(const Uuid& id) override {
    return session_.Autocommit("find submission " + id.ToString(),
                               [&](pqxx::transaction_base& t) -> std::optional<Submission> {
                                 const pqxx::result r =
                                     t.exec_prepared("version_find_submission", id.ToString());
                                 if (r.empty()) return std::nullopt;
                                 return ReadSubmission(r[0]);
                               });
  }

  std::vector<Submission> ListSubmissions() override {
    return session_.Autocommit("list submissions", [&](pqxx::transaction_base& t) {
      std::vector<Submission> submissions;
      for (const pqxx::row& row : t.exec_prepared("version_list_submissions")) {
        submissions.push_back(ReadSubmission(row));
      }
      return submissions;
    });
  }

  // ---- Claims ----

  std::optional<Submission> ClaimQueuedSubmission(const std::string& instance,
                                                  std::chrono::milliseconds lease,
                                                  const std::vector<Uuid>& skip) override {
    const std::int64_t lease_ns = ClaimLeaseNs(instance, lease);
    const std::string passed_over = UuidArray(skip);
    return session_.Atomically("claim a queued submission for " + instance,
                               [&](pqxx::transaction_base& t) -> std::optional<Submission> {
                                 const pqxx::result r = t.exec_prepared(
                                     "version_claim_submission", instance, lease_ns, passed_over);
                                 if (r.empty()) return std::nullopt;
                                 return ReadSubmission(r[0]);
                               });
  }

  bool RenewClaim(const Uuid& id, const std::string& instance,
                  std::chrono::milliseconds lease) override {
    const std::int64_t lease_ns = ClaimLeaseNs(instance, lease);
    return session_.Atomically(
        "renew the claim on submission " + id.ToString(), [&](pqxx::transaction_base& t) {
          return t.exec_prepared("version_renew_claim", id.ToString(), instance, lease_ns)
                     .affected_rows() == 1;
        });
  }

  void ReleaseClaim(const Uuid& id, const std::string& instance) override {
    session_.Atomically("release the claim on submission " + id.ToString(),
                        [&](pqxx::transaction_base& t) {
                          t.exec_prepared("version_release_claim", id.ToString(), instance);
                        });
  }

  std::optional<SubmissionClaim> FindClaim(const Uuid& id) override {
    return session_.Autocommit("find the claim on submission " + id.ToString(),
                               [&](pqxx::transaction_base& t) -> std::optional<SubmissionClaim> {
                                 const pqxx::result r =
                                     t.exec_prepared("version_find_claim", id.ToString());
                                 if (r.empty()) throw NoSubmission(id);
                                 const std::string instance = r[0][0].c_str();
                                 if (instance.empty()) return std::nullopt;
                                 return SubmissionClaim{instance, r[0][1].as<std::int64_t>()};
                               });
  }

  std::string SubmissionChunk(const Uuid& id, std::int64_t seq) override {
    const std::string name = "chunk " + Str(seq) + " of submission " + id.ToString();
    return session_.Autocommit(name, [&](pqxx::transaction_base& t) {
      const pqxx::result r = t.exec_prepared("version_chunk", id.ToString(), seq);
      if (!r.empty()) return BytesField(r[0][0]);
      if (t.exec_prepared("version_find_submission", id.ToString()).empty()) {
        throw NoSubmission(id);
      }
      throw Error(ErrorCode::kNotFound, "no " + name);
    });
  }

  // ---- Revisions ----

  RevisionNumber HeadRevision() override {
    return session_.Autocommit("head revision", [&](pqxx::transaction_base& t) { return Head(t); });
  }

  std::optional<Revision> FindRevision(RevisionNumber number) override {
    return session_.Autocommit("find " + RevisionName(number),
                               [&](pqxx::transaction_base& t) { return Find(t, number); });
  }

  std::vector<Revision> ListRevisions() override {
    return session_.Autocommit("list revisions", [&](pqxx::transaction_base& t) {
      std::vector<Revision> revisions;
      for (const pqxx::row& row : t.exec_prepared("version_list_revisions")) {
        revisions.push_back(ReadRevision(row));
      }
      return revisions;
    });
  }

  Revision AppendRevision(const Revision& revision, const GraphBatch& additions) override {
    RequireMergeInTransaction(revision, session_.transaction() != nullptr);
    Revision recorded = revision;
    recorded.reverted = 0;
    recorded.nodes_hidden = recorded.edges_hidden = recorded.paths_hidden = 0;
    const std::vector<VersionedElement> elements = VersionedElementsOf(additions, recorded);
    session_.Atomically("append " + RevisionName(revision.number), [&](pqxx::transaction_base& t) {
      RequireNextRevision(revision.number, Head(t));
      // First, so that a writer racing for the same number waits here and then fails.
      InsertRevision(t, recorded);
      AddElements(t, revision.number, elements);
    });
    return recorded;
  }

  Revision AppendPromotion(const Revision& revision, const GraphBatch& additions,
                           const std::vector<Uuid>& hide_nodes) override {
    Revision recorded =
        PromotionAsRecorded(revision, additions, hide_nodes, session_.transaction() != nullptr);
    const std::vector<VersionedElement> elements = VersionedElementsOf(additions, recorded);
    const std::string hidden = UuidArray(hide_nodes);
    session_.Atomically("append promotion " + RevisionName(revision.number),
                        [&](pqxx::transaction_base& t) {
                          RequireNextRevision(revision.number, Head(t));
                          InsertRevision(t, recorded);
                          AddElements(t, revision.number, elements);
                          if (!hide_nodes.empty()) {
                            t.exec_prepared("version_hide_nodes", revision.number, hidden);
                          }
                          HideTouchingAndCount(t, recorded);
                        });
    return recorded;
  }

  Revision AppendRevert(const Revision& revision) override {
    const RevisionNumber number = revision.number;
    Revision recorded = RevertAsRecorded(revision);
    session_.Atomically(
        "append " + RevisionName(number) + " reverting " + RevisionName(revision.reverted),
        [&](pqxx::transaction_base& t) {
          RequireNextRevision(number, Head(t));
          std::optional<RevisionNumber> reverted_by;
          const pqxx::result by = t.exec_prepared("version_reverted_by", revision.reverted);
          if (!by.empty()) reverted_by = by[0][0].as<std::int64_t>();
          const std::optional<Revision> target = Find(t, revision.reverted);
          RequireRevertable(revision.reverted, target, reverted_by);
          InsertRevision(t, recorded);
          if (target->kind == RevisionKind::kRetire) {
            Restore(t, recorded);
            return;
          }
          t.exec_prepared("version_hide_added", number, revision.reverted);
          HideTouchingAndCount(t, recorded);
        });
    return recorded;
  }

  Revision AppendRetirement(const Revision& revision, const std::vector<Uuid>& nodes) override {
    Revision recorded = RetirementAsRecorded(revision);
    const std::string retired = UuidArray(nodes);
    session_.Atomically(
        "append retirement " + RevisionName(revision.number), [&](pqxx::transaction_base& t) {
          RequireNextRevision(revision.number, Head(t));
          InsertRevision(t, recorded);
          t.exec_prepared("version_retire_nodes", revision.number, retired);
          t.exec_prepared("version_retire_touching", revision.number);
          for (const pqxx::row& row : t.exec_prepared("version_retired_counts", revision.number)) {
            SetHiddenCount(recorded, StoredVersionedKind(row[0].as<int>(), Uuid()),
                           row[1].as<std::int64_t>());
          }
          t.exec_prepared("version_set_hidden_counts", revision.number, recorded.nodes_hidden,
                          recorded.edges_hidden, recorded.paths_hidden);
        });
    return recorded;
  }

  // ---- Use ----

  void PutNodeUsage(RevisionNumber revision, const std::vector<NodeUsage>& usage) override {
    for (const NodeUsage& use : usage) RequireValidUsage(use);
    if (usage.empty()) return;
    std::vector<Uuid> nodes;
    std::string sources = "{", frames = "{", last_ns = "{";
    for (const NodeUsage& use : usage) {
      const char* comma = nodes.empty() ? "" : ",";
      nodes.push_back(use.node);
      sources += comma + Str(static_cast<int>(use.source));
      frames += comma + Str(use.frames);
      last_ns += comma + Str(use.last_ns);
    }
    sources += '}';
    frames += '}';
    last_ns += '}';
    session_.Atomically("use measured by " + RevisionName(revision),
                        [&](pqxx::transaction_base& t) {
                          t.exec_prepared("version_put_node_usage", UuidArray(nodes), revision,
                                          sources, frames, last_ns);
                        });
  }

  std::vector<NodeUsage> UsageAt(RevisionNumber r) override {
    return session_.Autocommit("use up to " + RevisionName(r), [&](pqxx::transaction_base& t) {
      RequireInHistory(r, Head(t));
      std::vector<NodeUsage> usage;
      for (const pqxx::row& row : t.exec_prepared("version_usage_at", r)) {
        NodeUsage use;
        use.node = UuidField(row[0]);
        use.frames = row[1].as<std::int64_t>();
        use.last_ns = row[2].as<std::int64_t>();
        usage.push_back(use);
      }
      return usage;
    });
  }

  // ---- The map at a revision ----

  std::vector<Node> NodesAt(RevisionNumber r, bool with_landmarks) override {
    return session_.Autocommit("nodes at " + RevisionName(r), [&](pqxx::transaction_base& t) {
      RequireInHistory(r, Head(t));
      std::vector<Node> nodes;
      const pqxx::result rows =
          t.exec_prepared(with_landmarks ? "version_nodes_at" : "version_nodes_at_bare", r);
      nodes.reserve(rows.size());
      for (const pqxx::row& row : rows) nodes.push_back(ReadNode(row, with_landmarks));
      OrderNodesAt(nodes);
      return nodes;
    });
  }

  std::vector<Edge> EdgesAt(RevisionNumber r) override {
    return session_.Autocommit("edges at " + RevisionName(r), [&](pqxx::transaction_base& t) {
      RequireInHistory(r, Head(t));
      std::vector<Edge> edges;
      const pqxx::result rows = t.exec_prepared("version_edges_at", r);
      edges.reserve(rows.size());
      for (const pqxx::row& row : rows) edges.push_back(ReadEdge(row, 0));
      return edges;
    });
  }

  std::vector<Path> PathsAt(RevisionNumber r) override {
    return session_.Autocommit("paths at " + RevisionName(r), [&](pqxx::transaction_base& t) {
      RequireInHistory(r, Head(t));
      std::vector<Path> paths;
      for (const pqxx::row& row : t.exec_prepared("version_paths_at", r)) {
        paths.push_back(ReadPath(row));
      }
      return paths;
    });
  }

  StoreStats StatsAt(RevisionNumber r) override {
    return session_.Autocommit("stats at " + RevisionName(r), [&](pqxx::transaction_base& t) {
      RequireInHistory(r, Head(t));
      const pqxx::row row = t.exec_prepared1("version_stats_at", r);
      StoreStats stats;
      stats.nodes = row[0].as<std::int64_t>();
      stats.landmark_bytes = row[1].as<std::int64_t>();
      stats.edges = row[2].as<std::int64_t>();
      stats.paths = row[3].as<std::int64_t>();
      return stats;
    });
  }

  RevisionChanges Changes(RevisionNumber from, RevisionNumber to) override {
    return session_.Autocommit(
        "changes from " + RevisionName(from) + " to " + Str(to), [&](pqxx::transaction_base& t) {
          const RevisionNumber head = Head(t);
          RequireInHistory(from, head);
          RequireInHistory(to, head);
          std::vector<ElementVersionRow> rows;
          for (const pqxx::row& row :
               t.exec_prepared("version_changed_between", std::min(from, to), std::max(from, to))) {
            const Uuid id = UuidField(row[0]);
            std::optional<RevisionNumber> hidden;
            if (!row[3].is_null()) hidden = row[3].as<std::int64_t>();
            rows.push_back({id,
                            StoredVersionedKind(row[1].as<int>(), id),
                            row[2].as<std::int64_t>(),
                            hidden,
                            {}});
          }
          if (t.exec_prepared1("version_any_retirement")[0].as<bool>()) {
            AddRetirements(t, std::min(from, to), std::max(from, to), rows);
          }
          return ChangesFromRows(from, to, rows);
        });
  }

  std::optional<ElementVersion> VersionOf(const Uuid& id) override {
    return session_.Autocommit("version of " + id.ToString(),
                               [&](pqxx::transaction_base& t) -> std::optional<ElementVersion> {
                                 const pqxx::result r =
                                     t.exec_prepared("version_of", id.ToString());
                                 if (r.empty()) return std::nullopt;
                                 ElementVersion v;
                                 v.added = r[0][0].as<std::int64_t>();
                                 if (!r[0][1].is_null()) v.hidden = r[0][1].as<std::int64_t>();
                                 if (!r[0][2].is_null()) {
                                   const RevisionNumber retired = r[0][2].as<std::int64_t>();
                                   if (!v.hidden || retired < *v.hidden) v.hidden = retired;
                                 }
                                 return v;
                               });
  }

  // ---- What the server has seen of each node ----

  void PutSubmissionNodes(const Uuid& id, const std::vector<Uuid>& nodes) override {
    session_.Atomically("nodes of submission " + id.ToString(), [&](pqxx::transaction_base& t) {
      LockSubmission(t, id);
      t.exec_prepared("version_put_submission_nodes", UuidArray(nodes), id.ToString());
    });
  }

  std::vector<Submission> SubmissionsWithNode(const Uuid& node) override {
    return session_.Autocommit(
        "submissions with node " + node.ToString(), [&](pqxx::transaction_base& t) {
          std::vector<Submission> submissions;
          for (const auto& row :
               t.exec_prepared("version_submissions_with_node", node.ToString())) {
            submissions.push_back(ReadSubmission(row));
          }
          return submissions;
        });
  }

  void PutStandIns(const std::vector<NodeStandIn>& stand_ins) override {
    session_.Atomically("stand-ins", [&](pqxx::transaction_base& t) {
      for (const NodeStandIn& stand_in : stand_ins) {
        const Eigen::Vector3d p = stand_in.stand_in_T_node.translation();
        const Eigen::Quaterniond q = RotationQuaternion(stand_in.stand_in_T_node);
        t.exec_prepared("version_put_stand_in", stand_in.node.ToString(),
                        stand_in.stand_in.ToString(), p.x(), p.y(), p.z(), q.w(), q.x(), q.y(),
                        q.z(), stand_in.revision);
      }
    });
  }

  std::optional<NodeStandIn> FindStandIn(const Uuid& node) override {
    return session_.Autocommit("stand-in of " + node.ToString(),
                               [&](pqxx::transaction_base& t) -> std::optional<NodeStandIn> {
                                 const pqxx::result r =
                                     t.exec_prepared("version_find_stand_in", node.ToString());
                                 if (r.empty()) return std::nullopt;
                                 return StandInAt(r[0], node);
                               });
  }

  std::vector<NodeStandIn> StandInsOf(RevisionNumber revision) override {
    return session_.Autocommit(
        "stand-ins of revision " + std::to_string(revision), [&](pqxx::transaction_base& t) {
          std::vector<NodeStandIn> stand_ins;
          for (const pqxx::row& row : t.exec_prepared("version_stand_ins_of", revision)) {
            stand_ins.push_back(StandInAt(row, UuidField(row[9])));
          }
          return stand_ins;
        });
  }

  // ---- Settings ----

  std::optional<std::string> FindSetting(std::string_view key) override {
    const std::string k(key);
    return session_.Autocommit("find setting " + k,
                               [&](pqxx::transaction_base& t) -> std::optional<std::string> {
                                 const pqxx::result r = t.exec_prepared("version_find_setting", k);
                                 if (r.empty()) return std::nullopt;
                                 return BytesField(r[0][0]);
                               });
  }

  void PutSetting(std::string_view key, std::string_view value) override {
    const std::string k(key);
    const pqxx::binarystring bytes(value.data(), value.size());
    session_.Autocommit("put setting " + k, [&](pqxx::transaction_base& t) {
      t.exec_prepared("version_put_setting", k, bytes);
    });
  }

  bool ReplaceSetting(std::string_view key, const std::optional<std::string>& expected,
                      std::string_view value) override {
    // One statement each. Under READ COMMITTED an UPDATE that finds the row changed by a writer
    // still open waits for it and then tests the WHERE again on the row as committed; an INSERT
    // that meets a key inserted meanwhile waits, then does nothing. Either way the loser sees 0
    // rows, and the winner holds the row lock until its transaction ends.
    const std::string k(key);
    const pqxx::binarystring bytes(value.data(), value.size());
    return session_.Autocommit("replace setting " + k, [&](pqxx::transaction_base& t) {
      if (!expected) {
        return t.exec_prepared("version_insert_setting_if_absent", k, bytes).affected_rows() == 1;
      }
      const pqxx::binarystring was(expected->data(), expected->size());
      return t.exec_prepared("version_replace_setting", k, was, bytes).affected_rows() == 1;
    });
  }

  std::vector<std::pair<std::string, std::string>> ListSettings(std::string_view prefix) override {
    const std::string p(prefix);
    return session_.Autocommit(
        "list settings " + p,
        [&](pqxx::transaction_base& t) -> std::vector<std::pair<std::string, std::string>> {
          std::vector<std::pair<std::string, std::string>> settings;
          for (const auto& row : t.exec_prepared("version_list_settings", p)) {
            settings.emplace_back(row[0].as<std::string>(), BytesField(row[1]));
          }
          return settings;
        });
  }

 private:
  // Refuses elements already stored, then records revision `number` as having added them.
  void AddElements(pqxx::transaction_base& t, RevisionNumber number,
                   const std::vector<VersionedElement>& elements) {
    if (elements.empty()) return;
    std::vector<Uuid> ids;
    std::string kinds = "{";
    ids.reserve(elements.size());
    for (const VersionedElement& e : elements) {
      ids.push_back(e.id);
      if (kinds.size() > 1) kinds += ',';
      kinds += static_cast<char>('0' + static_cast<int>(e.kind));
    }
    kinds += '}';
    const std::string id_array = UuidArray(ids);
    const pqxx::result stored = t.exec_prepared("version_stored_among", id_array);
    if (!stored.empty()) {
      throw AlreadyStored(StoredVersionedKind(stored[0][0].as<int>(), UuidField(stored[0][1])),
                          UuidField(stored[0][1]), number);
    }
    t.exec_prepared("version_add_elements", id_array, kinds, number);
  }

  // A revert of a retirement: closes what it hid and counts what came back as added.
  static void Restore(pqxx::transaction_base& t, Revision& recorded) {
    t.exec_prepared("version_restore_retired", recorded.number, recorded.reverted);
    for (const pqxx::row& row : t.exec_prepared("version_restored_counts", recorded.number)) {
      SetRestoredCount(recorded, StoredVersionedKind(row[0].as<int>(), Uuid()),
                       row[1].as<std::int64_t>());
    }
    t.exec_prepared("version_set_added_counts", recorded.number, recorded.nodes_added,
                    recorded.edges_added, recorded.paths_added);
  }

  // Changes' rows, completed with the elements a revision in (lo, hi] retired or restored and
  // every retirement of each row's element.
  static void AddRetirements(pqxx::transaction_base& t, RevisionNumber lo, RevisionNumber hi,
                             std::vector<ElementVersionRow>& rows) {
    for (const pqxx::row& row : t.exec_prepared("version_retired_between", lo, hi)) {
      const Uuid id = UuidField(row[0]);
      std::optional<RevisionNumber> hidden;
      if (!row[3].is_null()) hidden = row[3].as<std::int64_t>();
      rows.push_back(
          {id, StoredVersionedKind(row[1].as<int>(), id), row[2].as<std::int64_t>(), hidden, {}});
    }
    std::sort(rows.begin(), rows.end(),
              [](const ElementVersionRow& a, const ElementVersionRow& b) { return a.id < b.id; });
    rows.erase(std::unique(rows.begin(), rows.end(),
                           [](const ElementVersionRow& a, const ElementVersionRow& b) {
                             return a.id == b.id;
                           }),
               rows.end());
    std::vector<Uuid> ids;
    ids.reserve(rows.size());
    for (const ElementVersionRow& row : rows) ids.push_back(row.id);
    for (const pqxx::row& span : t.exec_prepared("version_retirements_of", UuidArray(ids))) {
      const Uuid id = UuidField(span[0]);
      const auto at = std::lower_bound(
          rows.begin(), rows.end(), id,
          [](const ElementVersionRow& row, const Uuid& key) { return row.id < key; });
      if (at == rows.end() || at->id != id) continue;
      RetirementSpan retirement{span[1].as<std::int64_t>(), std::nullopt};
      if (!span[2].is_null()) retirement.restored = span[2].as<std::int64_t>();
      at->retirements.push_back(retirement);
    }
  }

  // After revision `recorded` hid nodes or paths: hides every visible edge left touching them
  // and records what the revision hid in all.
  void HideTouchingAndCount(pqxx::transaction_base& t, Revision& recorded) {
    const RevisionNumber number = recorded.number;
    t.exec_prepared("version_hide_touching_versioned", number);
    t.exec_prepared("version_hide_touching_unversioned", number);
    for (const pqxx::row& row : t.exec_prepared("version_hidden_counts", number)) {
      SetHiddenCount(recorded, StoredVersionedKind(row[0].as<int>(), Uuid()),
                     row[1].as<std::int64_t>());
    }
    t.exec_prepared("version_set_hidden_counts", number, recorded.nodes_hidden,
                    recorded.edges_hidden, recorded.paths_hidden);
  }

  static RevisionNumber Head(pqxx::transaction_base& t) {
    return t.exec_prepared1("version_head")[0].as<std::int64_t>();
  }

  static std::optional<Revision> Find(pqxx::transaction_base& t, RevisionNumber number) {
    const pqxx::result r = t.exec_prepared("version_find_revision", number);
    if (r.empty()) return std::nullopt;
    return ReadRevision(r[0]);
  }

  // The stored submission, its row locked until the (sub)transaction ends.
  static Submission LockSubmission(pqxx::transaction_base& t, const Uuid& id) {
    const pqxx::result r = t.exec_prepared("version_lock_submission", id.ToString());
    if (r.empty()) throw NoSubmission(id);
    return ReadSubmission(r[0]);
  }

  // Inserts the revision row. A writer that took the same number first makes this a
  // conflict (the primary key), as does one that reverted the same revision (the unique
  // index on reverted).
  static void InsertRevision(pqxx::transaction_base& t, const Revision& v) {
    try {
      t.exec_prepared(
          "version_insert_revision", v.number, v.created_ns, v.author, static_cast<int>(v.kind),
          v.submission.IsNil() ? std::string() : v.submission.ToString(), v.reverted, v.nodes_added,
          v.edges_added, v.paths_added, v.nodes_hidden, v.edges_hidden, v.paths_hidden, v.report);
    } catch (const pqxx::unique_violation& e) {
      if (std::string(e.what()).find("revisions_by_reverted") != std::string::npos) {
        throw Error(ErrorCode::kConflict,
                    RevisionName(v.reverted) + " was reverted by another writer first");
      }
      throw Error(ErrorCode::kConflict,
                  RevisionName(v.number) + " was appended by another writer first");
    }
  }

  void Prepare() { PrepareVersionStatements(session_.connection()); }

  PgSession& session_;
};

}  // namespace

std::unique_ptr<VersionStore> NewPostgresVersionStore(PgSession& session) {
  return std::make_unique<PostgresVersionStore>(session);
}

}  // namespace fleetmap::internal
