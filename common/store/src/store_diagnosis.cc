#include "fleetmap/store/store_diagnosis.h"

#include <chrono>
#include <set>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "fleetmap/store/store_health.h"
#include "fleetmap/store/version_store.h"

namespace fleetmap {

namespace {

std::string Ids(const std::vector<Uuid>& ids) {
  std::string text;
  for (const Uuid& id : ids) text += (text.empty() ? "" : ", ") + id.ToString();
  return text;
}

std::string Hours(std::chrono::minutes age) {
  return std::to_string(age.count() / 60) + " h " + std::to_string(age.count() % 60) + " min";
}

void CheckEngine(GraphStore& store, std::vector<StoreProblem>& problems) {
  for (const std::string& line : store.health().EngineProblems()) {
    problems.push_back({"engine", line,
                        "the store's files are damaged: stop the services that write it, copy "
                        "it aside, and restore the last backup (for SQLite, `sqlite3 FILE "
                        ".recover` salvages what it can into a new file)"});
  }
}

void CheckReferences(GraphStore& store, const DiagnosisOptions& options,
                     std::vector<StoreProblem>& problems) {
  const IdSample dangling = store.health().DanglingEdges(options.examples);
  if (dangling.count > 0) {
    problems.push_back(
        {"dangling edges",
         std::to_string(dangling.count) +
             " stored edges name a node or path that is not stored (first: " +
             Ids(dangling.examples) + ")",
         "written around the store's checks (by hand, or by a tool with foreign keys off): "
         "restore a backup, or push again the robot maps that hold those nodes"});
  }
  const IdSample orphans = store.health().OrphanVersions(options.examples);
  if (orphans.count > 0) {
    problems.push_back(
        {"orphan versions",
         std::to_string(orphans.count) +
             " version records name an element that is not stored or a revision after the head "
             "(first: " +
             Ids(orphans.examples) + ")",
         "the history and the map disagree, so checkouts of some revisions are not what was "
         "merged: restore a backup; do not merge into this store until then"});
  }
}

void CheckHead(GraphStore& store, const DiagnosisOptions& options,
               std::vector<StoreProblem>& problems) {
  VersionStore& versions = store.versions();
  const RevisionNumber head = versions.HeadRevision();
  std::unordered_set<Uuid> nodes;
  for (const Node& node : versions.NodesAt(head, false)) nodes.insert(node.id);
  std::unordered_set<Uuid> paths;
  for (const Path& path : versions.PathsAt(head)) paths.insert(path.id);
  std::int64_t count = 0;
  std::vector<Uuid> examples;
  for (const Edge& edge : versions.EdgesAt(head)) {
    const bool ends = nodes.contains(edge.from) && nodes.contains(edge.to);
    const bool path = edge.path.IsNil() || paths.contains(edge.path);
    if (ends && path) continue;
    if (examples.size() < options.examples) examples.push_back(edge.id);
    ++count;
  }
  if (count > 0) {
    problems.push_back(
        {"head",
         std::to_string(count) + " edges visible at revision " + std::to_string(head) +
             " end in a node or path that is hidden there (first: " + Ids(examples) + ")",
         "a revision hid nodes without their edges: `fleetmap log` shows which; revert it "
         "(`fleetmap revert`) and merge its submission again"});
  }
}

// Pieces of the head's map a hide cut off: a metric component other than the
// largest with a stored metric edge into a node the head hides. A robot localising in the main
// piece never reaches it, and nothing else says so.
void CheckHiddenCuts(GraphStore& store, const DiagnosisOptions& options,
                     std::vector<StoreProblem>& problems) {
  VersionStore& versions = store.versions();
  const RevisionNumber head = versions.HeadRevision();
  std::unordered_map<Uuid, Uuid> parent;
  for (const Node& node : versions.NodesAt(head, false)) parent.emplace(node.id, node.id);
  const auto root = [&](Uuid id) {
    while (parent.at(id) != id) id = parent.at(id) = parent.at(parent.at(id));
    return id;
  };
  for (const Edge& edge : versions.EdgesAt(head)) {
    if (edge.kind != EdgeKind::kMetric || !parent.contains(edge.from) ||
        !parent.contains(edge.to)) {
      continue;
    }
    parent.at(root(edge.from)) = root(edge.to);
  }
  std::unordered_map<Uuid, std::vector<Uuid>> pieces;
  for (const auto& [node, up] : parent) pieces[root(node)].push_back(node);
  if (pieces.size() < 2) return;
  const Uuid* largest = nullptr;
  for (const auto& [id, nodes] : pieces) {
    if (!largest || nodes.size() > pieces.at(*largest).size()) largest = &id;
  }
  std::int64_t cut_nodes = 0;
  std::vector<Uuid> examples;
  std::set<RevisionNumber> hid_by;
  for (const auto& [id, nodes] : pieces) {
    if (id == *largest) continue;
    for (const Edge& edge : store.EdgesTouching(nodes)) {
      if (edge.kind != EdgeKind::kMetric) continue;
      const Uuid& other = parent.contains(edge.from) ? edge.to : edge.from;
      if (parent.contains(other)) continue;
      const std::optional<ElementVersion> version = versions.VersionOf(other);
      if (!version || !version->hidden || *version->hidden > head) continue;
      cut_nodes += static_cast<std::int64_t>(nodes.size());
      if (examples.size() < options.examples) examples.push_back(nodes.front());
      hid_by.insert(*version->hidden);
      break;
    }
  }
  if (cut_nodes == 0) return;
  std::string revisions;
  for (const RevisionNumber r : hid_by) {
    revisions += (revisions.empty() ? "" : ", ") + std::to_string(r);
  }
  problems.push_back(
      {"cut off",
       std::to_string(cut_nodes) + " nodes at revision " + std::to_string(head) +
           " are cut off from the rest of the map: the nodes that joined them were hidden by "
           "revision " +
           revisions + " (first: " + Ids(examples) + ")",
       "robots localising in the rest of the map do not reach them; a push that re-drives the "
       "gap joins them again, or check out the revision before the hide (`fleetmap log`, "
       "`fleetmap diff`) to see what was there"});
}

void CheckHistory(GraphStore& store, const std::vector<Submission>& submissions,
                  std::vector<StoreProblem>& problems) {
  VersionStore& versions = store.versions();
  const std::vector<Revision> revisions = versions.ListRevisions();
  const RevisionNumber head = versions.HeadRevision();
  const auto problem = [&](const std::string& what) {
    problems.push_back({"history", what,
                        "the revision tables were changed outside fleetmap: restore a backup; "
                        "do not merge into this store until then"});
  };
  for (std::size_t i = 0; i < revisions.size(); ++i) {
    const RevisionNumber expected = static_cast<RevisionNumber>(i) + 1;
    if (revisions[i].number != expected) {
      problem("revision " + std::to_string(expected) + " is missing: the history jumps to " +
              std::to_string(revisions[i].number));
      break;
    }
  }
  std::unordered_map<Uuid, const Submission*> by_id;
  for (const Submission& submission : submissions) by_id.emplace(submission.id, &submission);
  for (const Revision& revision : revisions) {
    if (revision.kind != RevisionKind::kMerge) continue;
    const auto found = by_id.find(revision.submission);
    const Submission* submission = found == by_id.end() ? nullptr : found->second;
    if (submission == nullptr) {
      problem("revision " + std::to_string(revision.number) + " merged submission " +
              revision.submission.ToString() + ", which is not stored");
    } else if (submission->state != SubmissionState::kMerged ||
               submission->revision != revision.number) {
      problem("revision " + std::to_string(revision.number) + " merged submission " +
              revision.submission.ToString() + ", which says it is " +
              std::string(SubmissionStateName(submission->state)) +
              (submission->state == SubmissionState::kMerged
                   ? " into revision " + std::to_string(submission->revision)
                   : ""));
    }
  }
  for (const Submission& submission : submissions) {
    if (submission.state != SubmissionState::kMerged) continue;
    if (submission.revision < 1 || submission.revision > head) {
      problem("submission " + submission.id.ToString() + " says it became revision " +
              std::to_string(submission.revision) + ", which does not exist (head " +
              std::to_string(head) + ")");
    }
  }
}

void CheckSubmissions(GraphStore& store, const std::vector<Submission>& submissions,
                      const DiagnosisOptions& options, std::vector<StoreProblem>& problems) {
  VersionStore& versions = store.versions();
  const auto age = [&](const Submission& s) {
    return std::chrono::duration_cast<std::chrono::minutes>(
        std::chrono::nanoseconds(options.now_ns - s.received_ns));
  };
  for (const Submission& submission : submissions) {
    const std::string name = "submission " + submission.id.ToString() + " from robot " +
                             submission.robot.ToString() + " (" + submission.author + ")";
    if (submission.state == SubmissionState::kReceiving &&
        age(submission) >= options.receiving_stuck_after) {
      problems.push_back(
          {"submissions",
           name + " has been receiving for " + Hours(age(submission)) + ", stopped after " +
               std::to_string(submission.chunk_count) + " chunks (" +
               std::to_string(submission.bytes) + " bytes)",
           "its robot's agent resumes the push at its next sync (the map stays on the robot "
           "until then); nothing is deleted, so a robot that never returns leaves it as a "
           "record of what it sent"});
    }
    if (submission.state == SubmissionState::kQueued &&
        age(submission) >= options.queued_stuck_after) {
      const std::optional<SubmissionClaim> claim = versions.FindClaim(submission.id);
      if (claim && claim->lease_until_ns > options.now_ns) continue;  // being merged
      problems.push_back(
          {"submissions",
           name + " has waited to be merged for " + Hours(age(submission)) +
               (claim ? ", last claimed by " + claim->instance : ", never claimed") +
               (submission.error.empty() ? "" : "; last attempt: " + submission.error),
           "no fleetmapd merges this store: start `fleetmapd --store " + store.uri() +
               "` (it merges what is queued), or merge it by hand with `fleetmap merge --store " +
               store.uri() + " " + submission.id.ToString() + "`"});
    }
  }
}

}  // namespace

std::vector<StoreProblem> DiagnoseStore(GraphStore& store, const DiagnosisOptions& options) {
  std::vector<StoreProblem> problems;
  CheckEngine(store, problems);
  CheckReferences(store, options, problems);
  CheckHead(store, options, problems);
  CheckHiddenCuts(store, options, problems);
  // Read once for both checks: a submission lookup per revision would be a round trip each
  // on PostgreSQL, thousands for a long history.
  const std::vector<Submission> submissions = store.versions().ListSubmissions();
  CheckHistory(store, submissions, problems);
  CheckSubmissions(store, submissions, options, problems);
  return problems;
}

}  // namespace fleetmap
