#include "fleetmap/server/repository.h"

#include <algorithm>
#include <chrono>
#include <unordered_map>
#include <unordered_set>

#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "merge_report_json.h"

namespace fleetmap {
namespace {

constexpr const char* kVocabularySetting = "appearance.vocabulary";

// Descriptors for a vocabulary trained from a submission: every node's, thinned to about
// 200k so training stays a fraction of a second; the same submission gives the same sample.
std::vector<Descriptor256> VocabularySample(const GraphBatch& map) {
  std::vector<Descriptor256> all;
  for (const Node& node : map.nodes) {
    const Landmarks landmarks = DecodeLandmarks(node.landmarks_blob);
    all.insert(all.end(), landmarks.descriptors.begin(), landmarks.descriptors.end());
  }
  constexpr std::size_t kMaxSample = 200'000;
  if (all.size() <= kMaxSample) return all;
  std::vector<Descriptor256> sample;
  sample.reserve(kMaxSample);
  const std::size_t stride = (all.size() + kMaxSample - 1) / kMaxSample;
  for (std::size_t i = 0; i < all.size(); i += stride) sample.push_back(all[i]);
  return sample;
}

std::vector<Uuid> NodeIdsOf(const GraphBatch& map) {
  std::vector<Uuid> ids;
  ids.reserve(map.nodes.size());
  for (const Node& node : map.nodes) ids.push_back(node.id);
  return ids;
}

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

// The map at one revision as MERGE works on it.
struct Repository::Mirror {
  RevisionNumber revision = 0;
  ExperienceMap map;
};

std::unique_ptr<Repository> Repository::Open(std::string_view uri, RepositoryOptions options) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri, options.store);
  return std::make_unique<Repository>(std::move(store), std::move(options));
}

Repository::Repository(std::unique_ptr<GraphStore> store, RepositoryOptions options)
    : store_(std::move(store)), options_(std::move(options)), vocabulary_(options_.vocabulary) {
  if (!store_) throw Error(ErrorCode::kInvalidArgument, "repository: no store");
}

Repository::~Repository() = default;

std::int64_t Repository::Now() const {
  if (options_.now_ns) return options_.now_ns();
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

Submission Repository::Push(const Uuid& id, const Uuid& robot, const std::string& author,
                            const GraphBatch& map) {
  if (id.IsNil() || robot.IsNil()) {
    throw Error(ErrorCode::kInvalidArgument, "push: the submission and robot ids must be set");
  }
  // Everything wrong with the content is found before anything is stored.
  ValidatePushContent(id, map);

  const std::vector<std::string> chunks = EncodeMapChunks(map);
  const std::uint64_t digest = DigestOfChunks(chunks);
  if (const std::optional<Submission> stored = versions().FindSubmission(id)) {
    if (stored->state != SubmissionState::kReceiving && stored->digest == digest &&
        stored->robot == robot) {
      return *stored;  // the same push again
    }
    if (stored->state != SubmissionState::kReceiving) {
      throw Error(ErrorCode::kConflict,
                  "push " + id.ToString() + ": a different submission is stored under this id");
    }
  }
  GraphStore::Transaction transaction = store_->Begin();
  Submission header;
  header.id = id;
  header.robot = robot;
  header.author = author;
  header.received_ns = Now();
  versions().BeginSubmission(header);
  for (std::size_t seq = 0; seq < chunks.size(); ++seq) {
    versions().PutSubmissionChunk(id, static_cast<std::int64_t>(seq), chunks[seq]);
  }
  versions().CompleteSubmission(id, digest);
  versions().PutSubmissionNodes(id, NodeIdsOf(map));
  transaction.Commit();
  return *versions().FindSubmission(id);
}

void Repository::ValidatePushContent(const Uuid& id, const GraphBatch& map) {
  std::unordered_set<Uuid> nodes;
  for (const Node& node : map.nodes) {
    Validate(node);
    try {
      DecodeLandmarks(node.landmarks_blob);
    } catch (const Error& error) {
      throw Error(ErrorCode::kCorrupt, "push " + id.ToString() + ": node " + node.id.ToString() +
                                           ": " + error.message());
    }
    nodes.insert(node.id);
  }
  for (const Path& path : map.paths) Validate(path);
  std::unordered_set<Uuid> seen;  // ends outside the push found on the server already
  for (const Edge& edge : map.edges) {
    Validate(edge);
    for (const Uuid& end : {edge.from, edge.to}) {
      if (nodes.contains(end) || seen.contains(end)) continue;
      if (!SeenOutside(id, end)) {
        throw Error(ErrorCode::kIntegrity,
                    "push " + id.ToString() + ": edge " + edge.id.ToString() + " ends at node " +
                        end.ToString() +
                        ", which is neither pushed nor stored, omitted by a merge or in an "
                        "earlier submission");
      }
      seen.insert(end);
    }
  }
  for (const Annotation& annotation : map.annotations) Validate(annotation);
}

bool Repository::SeenOutside(const Uuid& submission, const Uuid& node) {
  if (versions().VersionOf(node) || versions().FindStandIn(node)) return true;
  for (const Submission& other : versions().SubmissionsWithNode(node)) {
    if (other.id != submission) return true;
  }
  return false;
}

Submission Repository::BeginChunkedPush(const Uuid& id, const Uuid& robot,
                                        const std::string& author) {
  if (id.IsNil() || robot.IsNil()) {
    throw Error(ErrorCode::kInvalidArgument, "push: the submission and robot ids must be set");
  }
  Submission header;
  header.id = id;
  header.robot = robot;
  header.author = author;
  header.received_ns = Now();
  return versions().BeginSubmission(header);
}

void Repository::PutPushChunk(const Uuid& id, std::int64_t seq, std::string_view data) {
  // The chunk and the submission's count land together: an acknowledged chunk is durable, and
  // chunk_count never counts one that is not stored.
  GraphStore::Transaction transaction = store_->Begin();
  versions().PutSubmissionChunk(id, seq, data);
  transaction.Commit();
}

Submission Repository::CompleteChunkedPush(const Uuid& id, std::uint64_t digest) {
  const std::optional<Submission> stored = versions().FindSubmission(id);
  if (!stored) throw Error(ErrorCode::kNotFound, "push: no submission " + id.ToString());
  if (stored->state != SubmissionState::kReceiving) {
    if (stored->digest != digest) {
      throw Error(ErrorCode::kConflict,
                  "push " + id.ToString() + ": a different submission is stored under this id");
    }
    return *stored;  // completed before: the same push again
  }
  std::vector<std::string> chunks;
  chunks.reserve(static_cast<std::size_t>(stored->chunk_count));
  for (std::int64_t seq = 0; seq < stored->chunk_count; ++seq) {
    chunks.push_back(versions().SubmissionChunk(id, seq));
  }
  const std::uint64_t stored_digest = DigestOfChunks(chunks);
  // Whatever fails, the chunks stay: the submission is completed with the digest of what is
  // stored and marked failed with the reason, atomically.
  const auto fail = [&](const Error& error) {
    GraphStore::Transaction transaction = store_->Begin();
    versions().CompleteSubmission(id, stored_digest);
    versions().SetSubmissionState(id, SubmissionState::kFailed, 0, error.what());
    transaction.Commit();
    throw error;
  };
  if (stored_digest != digest) {
    fail(Error(ErrorCode::kCorrupt,
               "push " + id.ToString() + ": the " + std::to_string(chunks.size()) +
                   " chunks received do not match the digest the robot sent (chunks missing or "
                   "damaged)"));
  }
  GraphBatch map;
  try {
    map = DecodeMapChunks(chunks);
  } catch (const Error& error) {
    fail(Error(ErrorCode::kCorrupt, "push " + id.ToString() + ": " + error.message()));
  }
  chunks = {};  // a large push: do not hold it twice while checking
  try {
    ValidatePushContent(id, map);
  } catch (const Error& error) {
    if (error.code() == ErrorCode::kBackend) throw;  // the store failed, not the content
    fail(error);
  }
  GraphStore::Transaction transaction = store_->Begin();
  versions().CompleteSubmission(id, digest);
  versions().PutSubmissionNodes(id, NodeIdsOf(map));
  transaction.Commit();
  return *versions().FindSubmission(id);
}

GraphBatch Repository::ReadSubmission(const Uuid& id) {
  const std::optional<Submission> submission = versions().FindSubmission(id);
  if (!submission) throw Error(ErrorCode::kNotFound, "no submission " + id.ToString());
  std::vector<std::string> chunks;
  chunks.reserve(static_cast<std::size_t>(submission->chunk_count));
  for (std::int64_t seq = 0; seq < submission->chunk_count; ++seq) {
    chunks.push_back(versions().SubmissionChunk(id, seq));
  }
  if (submission->state != SubmissionState::kReceiving &&
      DigestOfChunks(chunks) != submission->digest) {
    throw Error(ErrorCode::kCorrupt, "submission " + id.ToString() +
                                         ": the stored chunks do not match the digest recorded "
                                         "when it was received");
  }
  try {
    return DecodeMapChunks(chunks);
  } catch (const Error& error) {
    throw Error(ErrorCode::kCorrupt, "submission " + id.ToString() + ": " + error.message());
  }
}

std::vector<Submission> Repository::Submissions() {
  return versions().ListSubmissions();
}

std::shared_ptr<const AppearanceVocabulary> Repository::StoredVocabulary() {
  if (vocabulary_) return vocabulary_;
  if (const std::optional<std::string> stored = versions().FindSetting(kVocabularySetting)) {
    vocabulary_ =
        std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Decode(*stored));
  }
  return vocabulary_;
}

std::shared_ptr<const AppearanceVocabulary> Repository::Vocabulary(
    const GraphBatch* first_submission) {
  if (StoredVocabulary()) return vocabulary_;
  // No vocabulary yet: train one from the map at the head, or else from the submission.
  GraphBatch head;
  head.nodes = versions().NodesAt(versions().HeadRevision());
  std::vector<Descriptor256> sample = VocabularySample(head);
  if (sample.empty() && first_submission) sample = VocabularySample(*first_submission);
  if (sample.empty()) return nullptr;  // nothing to learn words from, nothing to index either
  auto trained = std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
  versions().PutSetting(kVocabularySetting, trained->Encode());
  vocabulary_ = std::move(trained);
  return vocabulary_;
}

Repository::Mirror& Repository::HeadMirror(const GraphBatch* first_submission) {
  const RevisionNumber head = versions().HeadRevision();
  if (mirror_ && mirror_->revision == head) return *mirror_;
  mirror_.reset();
  std::shared_ptr<const AppearanceVocabulary> vocabulary = Vocabulary(first_submission);
  if (!vocabulary) {
    // An empty map and an empty submission: any vocabulary indexes nothing.
    vocabulary = std::make_shared<const AppearanceVocabulary>(
        AppearanceVocabulary::Train(std::vector<Descriptor256>(1)));
  }
  const std::vector<Node> nodes = versions().NodesAt(head);
  const std::vector<Edge> edges = versions().EdgesAt(head);
  mirror_ =
      std::make_unique<Mirror>(Mirror{head, ExperienceMap::FromGraph(nodes, edges, vocabulary)});
  return *mirror_;
}

MergeOutcome Repository::Merge(const Uuid& id, const MergeProgress& progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::optional<Submission> submission = versions().FindSubmission(id);
  if (!submission) throw Error(ErrorCode::kNotFound, "no submission " + id.ToString());
  if (submission->state == SubmissionState::kReceiving) {
    throw Error(ErrorCode::kInvalidArgument,
                "submission " + id.ToString() + " is still being received; it cannot be merged");
  }
  MergeOutcome outcome;
  if (submission->state == SubmissionState::kMerged) {
    outcome.revision = *versions().FindRevision(submission->revision);
    outcome.already_merged = true;
    outcome.seconds = SecondsSince(start);
    return outcome;
  }

  const auto fail = [&](const Error& error) {
    versions().SetSubmissionState(id, SubmissionState::kFailed, 0, error.what());
  };
  GraphBatch content;
  try {
    content = ReadSubmission(id);
  } catch (const Error& error) {
    if (error.code() == ErrorCode::kCorrupt) fail(error);
    throw;
  }
  VersionStore& versions = this->versions();
  // Edge ends outside the submission that the map does not hold: omitted by an earlier merge
  // (a stand-in), or only in other submissions. One still queued merges first. Each end is
  // looked up once; MERGE asks again only through these answers.
  std::unordered_set<Uuid> looked_up;
  for (const Node& node : content.nodes) looked_up.insert(node.id);
  std::unordered_map<Uuid, NodeStandIn> stand_ins;
  std::unordered_set<Uuid> seen_elsewhere;
  for (const Edge& edge : content.edges) {
    for (const Uuid& end : {edge.from, edge.to}) {
      if (!looked_up.insert(end).second || versions.VersionOf(end)) continue;
      if (std::optional<NodeStandIn> stand_in = versions.FindStandIn(end)) {
        stand_ins.emplace(end, std::move(*stand_in));
        continue;
      }
      for (const Submission& other : versions.SubmissionsWithNode(end)) {
        if (other.id != id && other.state == SubmissionState::kQueued) {
          outcome.waits_for = other.id;
          outcome.seconds = SecondsSince(start);
          return outcome;
        }
      }
      seen_elsewhere.insert(end);
    }
  }
  Mirror& mirror = HeadMirror(&content);
  ServerCatalogue catalogue{[&](const Uuid& edge) { return versions.VersionOf(edge).has_value(); },
                            [&](const Uuid& path) { return versions.VersionOf(path).has_value(); },
                            // Not in the mirror but stored: hidden by a revert.
                            [&](const Uuid& node) { return versions.VersionOf(node).has_value(); }};
  catalogue.stand_in = [&](const Uuid& node) -> std::optional<NodeStandIn> {
    const auto found = stand_ins.find(node);
    if (found == stand_ins.end()) return std::nullopt;
    return found->second;
  };
  catalogue.seen_elsewhere = [&](const Uuid& node) { return seen_elsewhere.contains(node); };
  MergeResult result;
  try {
    result = fleetmap::Merge(mirror.map, content, catalogue, options_.merge, progress);
  } catch (const Error& error) {
    mirror_.reset();  // MERGE may have changed it before failing
    if (error.code() == ErrorCode::kCorrupt || error.code() == ErrorCode::kIntegrity) fail(error);
    throw;
  }

  try {
    GraphStore::Transaction transaction = store_->Begin();
    Revision revision;
    revision.number = mirror.revision + 1;
    revision.created_ns = Now();
    revision.author = submission->author;
    revision.kind = RevisionKind::kMerge;
    revision.submission = id;
    revision.report = MergeReportJson(result.report);
    outcome.revision = versions.AppendRevision(revision, result.additions);
    store_->Put(result.additions);
    for (NodeStandIn& stand_in : result.stand_ins) stand_in.revision = revision.number;
    versions.PutStandIns(result.stand_ins);
    versions.SetSubmissionState(id, SubmissionState::kMerged, revision.number, "");
    if (options_.before_merge_commit) options_.before_merge_commit(id);
    transaction.Commit();
  } catch (...) {
    mirror_.reset();  // holds additions that did not land
    throw;
  }
  mirror.revision = outcome.revision.number;
  outcome.report = result.report;
  outcome.seconds = SecondsSince(start);
  return outcome;
}

RevisionNumber Repository::Head() {
  return versions().HeadRevision();
}

std::vector<Revision> Repository::History() {
  return versions().ListRevisions();
}

Revision Repository::Revert(RevisionNumber r, const std::string& author) {
  Revision revision;
  revision.number = versions().HeadRevision() + 1;
  revision.created_ns = Now();
  revision.author = author;
  revision.kind = RevisionKind::kRevert;
  revision.reverted = r;
  revision.report = "revert of revision " + std::to_string(r);
  mirror_.reset();
  return versions().AppendRevert(revision);
}

RevisionNumber Repository::Resolve(std::optional<RevisionNumber> r) {
  return r ? *r : versions().HeadRevision();
}

GraphBatch Repository::Checkout(std::optional<RevisionNumber> r) {
  const RevisionNumber revision = Resolve(r);
  GraphBatch map;
  map.nodes = versions().NodesAt(revision);
  map.edges = versions().EdgesAt(revision);
  map.paths = versions().PathsAt(revision);
  return map;
}

RevisionChanges Repository::Diff(RevisionNumber from, RevisionNumber to) {
  return versions().Changes(from, to);
}

Download Repository::SelectForDownload(const DownloadPolicy& policy,
                                       std::optional<RevisionNumber> r) {
  ValidateDownloadPolicy(policy);
  Download download;
  download.revision = Resolve(r);
  // Landmarks are read only for what is sent, unless a budget has to weigh every node.
  const bool weigh = policy.budget_bytes.has_value();
  std::vector<Node> nodes = versions().NodesAt(download.revision, weigh);
  const std::vector<Edge> edges = versions().EdgesAt(download.revision);
  const std::vector<Path> paths = versions().PathsAt(download.revision);
  const DownloadSelection selection = SelectDownload(nodes, edges, paths, policy);
  download.report = selection.report;

  const std::unordered_set<Uuid> keep(selection.nodes.begin(), selection.nodes.end());
  const auto take_selected = [&](std::vector<Node>& from) {
    for (Node& node : from) {
      if (keep.contains(node.id)) download.map.nodes.push_back(std::move(node));
    }
  };
  if (weigh) {
    take_selected(nodes);
  } else if (selection.nodes.size() * 2 >= nodes.size()) {
    // Most of the map goes (a copy): one scan of the revision's nodes reads their landmarks
    // about twice as fast as looking each one up by id (60,000 nodes of 9 KB: 0.9 s vs 1.8 s).
    std::vector<Node> all = versions().NodesAt(download.revision, true);
    take_selected(all);
  } else {
    // The selection was made on bare nodes: read the landmarks of what is sent.
    download.map.nodes = store_->GetNodes(selection.nodes);
    std::sort(download.map.nodes.begin(), download.map.nodes.end(),
              [](const Node& a, const Node& b) {
                return std::pair(a.stamp_ns, a.id) < std::pair(b.stamp_ns, b.id);
              });
  }
  if (!weigh) {
    download.report.bytes = 0;
    for (const Node& node : download.map.nodes) {
      download.report.bytes += static_cast<std::int64_t>(node.landmarks_blob.size());
    }
    download.report.map_bytes = versions().StatsAt(download.revision).landmark_bytes;
  }
  const std::unordered_set<Uuid> keep_edges(selection.edges.begin(), selection.edges.end());
  for (const Edge& edge : edges) {
    if (keep_edges.contains(edge.id)) download.map.edges.push_back(edge);
  }
  const std::unordered_set<Uuid> keep_paths(selection.paths.begin(), selection.paths.end());
  for (const Path& path : paths) {
    if (keep_paths.contains(path.id)) download.map.paths.push_back(path);
  }
  return download;
}

}  // namespace fleetmap
