#include "fleetmap/repository/repository.h"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <unordered_map>
#include <unordered_set>

#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/map_chunks.h"
#include "hidden_anchor.h"
#include "merge_region.h"
#include "merge_report_json.h"
#include "node_collisions.h"

namespace fleetmap {
namespace {

constexpr const char* kVocabularySetting = "appearance.vocabulary";
// The finer words of the map's appearance index on disk (Repository::IndexVocabulary).
constexpr const char* kIndexVocabularySetting = "appearance.index_vocabulary";

// A head with more landmark bytes than this trains the vocabulary from a sample of its first
// revisions instead of reading every node (a fleet map of 10^6 nodes holds about 9 GB).
constexpr std::int64_t kWholeHeadSampleBytes = 512LL << 20;
constexpr std::size_t kMaxVocabularySample = 200'000;
// Nodes the appearance index takes per segment while it catches up.
constexpr std::size_t kIndexBatchNodes = 20'000;

// Descriptors for a vocabulary trained from a submission: every node's, thinned to about
// 200k so training stays a fraction of a second; the same submission gives the same sample.
std::vector<Descriptor256> VocabularySample(const GraphBatch& map) {
  std::vector<Descriptor256> all;
  for (const Node& node : map.nodes) {
    const Landmarks landmarks = DecodeLandmarks(node.landmarks_blob);
    all.insert(all.end(), landmarks.descriptors.begin(), landmarks.descriptors.end());
  }
  constexpr std::size_t kMaxSample = kMaxVocabularySample;
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

// 64-bit FNV-1a: names a vocabulary or a store URI (not a security boundary).
std::uint64_t Fnv1a(std::string_view bytes) {
  std::uint64_t hash = 0xcbf29ce484222325ULL;
  for (const char c : bytes) hash = (hash ^ static_cast<unsigned char>(c)) * 0x100000001b3ULL;
  return hash;
}

// The store a repository is made on; a repository needs one.
GraphStore& StoreOf(const std::unique_ptr<GraphStore>& store) {
  if (!store) throw Error(ErrorCode::kInvalidArgument, "repository: no store");
  return *store;
}

MergeRegionOptions RegionOptions(const MergeOptions& merge) {
  // What the replaying localiser can reach (experience_builder.h): between two frames queried
  // by appearance it runs on for at most relocalise_after_m before it would relocalise, and
  // from wherever it is it searches search_radius_m for candidates within candidate_radius_m.
  const BuilderOptions& localiser = merge.localiser;
  MergeRegionOptions region;
  region.sample_every_m = localiser.relocalise_after_m;
  region.radius_m =
      localiser.relocalise_after_m + localiser.search_radius_m + localiser.candidate_radius_m;
  region.matches_per_frame = localiser.relocalisation_candidates;
  return region;
}

}  // namespace

// The index vocabulary: 10^5 words where MERGE's has 10^3. A query reads the postings of its
// words, about n D / W for n nodes of D descriptors over W words: at 10^6 nodes of 200
// descriptors, 2000 per word instead of 200,000. Finer words match fewer noisy descriptors,
// but a place seen again still shares far more of them than chance (seed 004 §III-B needs the
// place, not a ranking; the region's own index ranks with MERGE's words).
VocabularyOptions IndexVocabularyOptions() {
  VocabularyOptions options;
  options.branching = 10;
  options.depth = 5;
  return options;
}

std::unique_ptr<Repository> Repository::Open(std::string_view uri, RepositoryOptions options) {
  std::unique_ptr<GraphStore> store = GraphStore::Open(uri, options.store);
  return std::make_unique<Repository>(std::move(store), std::move(options));
}

Repository::Repository(std::unique_ptr<GraphStore> store, RepositoryOptions options)
    : store_(std::move(store)),
      inspection_(StoreOf(store_)),
      options_(std::move(options)),
      vocabulary_(options_.vocabulary) {}

Repository::~Repository() {
  appearance_.reset();
  if (!temporary_appearance_dir_.empty()) {
    std::error_code ignored;
    std::filesystem::remove_all(temporary_appearance_dir_, ignored);
  }
}

std::int64_t Repository::Now() const {
  if (options_.now_ns) return options_.now_ns();
  return WallClockNs();
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

std::vector<Descriptor256> Repository::SampleForVocabulary(const GraphBatch* first_submission) {
  // The map at the head, or else the submission. A head too large to hold is sampled from its
  // first revisions' nodes, read one revision at a time, until the sample is full.
  const RevisionNumber head_revision = versions().HeadRevision();
  GraphBatch head;
  if (versions().StatsAt(head_revision).landmark_bytes <= kWholeHeadSampleBytes) {
    head.nodes = versions().NodesAt(head_revision);
  } else {
    std::size_t descriptors = 0;
    for (RevisionNumber r = 1; r <= head_revision && descriptors < kMaxVocabularySample; ++r) {
      const RevisionChanges added = versions().Changes(r - 1, r);
      for (Node& node : store_->GetNodes(added.nodes_added)) {
        descriptors += DecodeLandmarks(node.landmarks_blob).size();
        head.nodes.push_back(std::move(node));
      }
    }
  }
  std::vector<Descriptor256> sample = VocabularySample(head);
  if (sample.empty() && first_submission) sample = VocabularySample(*first_submission);
  return sample;
}

std::shared_ptr<const AppearanceVocabulary> Repository::Vocabulary(
    const GraphBatch* first_submission) {
  if (StoredVocabulary()) return vocabulary_;
  const std::vector<Descriptor256> sample = SampleForVocabulary(first_submission);
  if (sample.empty()) return nullptr;  // nothing to learn words from, nothing to index either
  auto trained = std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample));
  versions().PutSetting(kVocabularySetting, trained->Encode());
  vocabulary_ = std::move(trained);
  return vocabulary_;
}

std::shared_ptr<const AppearanceVocabulary> Repository::IndexVocabulary(
    const GraphBatch* first_submission) {
  if (index_vocabulary_) return index_vocabulary_;
  if (options_.index_vocabulary) {
    index_vocabulary_ = options_.index_vocabulary;
    return index_vocabulary_;
  }
  if (const std::optional<std::string> stored = versions().FindSetting(kIndexVocabularySetting)) {
    index_vocabulary_ =
        std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Decode(*stored));
    return index_vocabulary_;
  }
  const std::vector<Descriptor256> sample = SampleForVocabulary(first_submission);
  if (sample.empty()) return nullptr;
  auto trained = std::make_shared<const AppearanceVocabulary>(
      AppearanceVocabulary::Train(sample, IndexVocabularyOptions()));
  versions().PutSetting(kIndexVocabularySetting, trained->Encode());
  index_vocabulary_ = std::move(trained);
  return index_vocabulary_;
}

std::filesystem::path Repository::AppearanceDirectory() {
  if (!options_.appearance_dir.empty()) return options_.appearance_dir;
  const std::string uri = store_->uri();
  if (uri.starts_with("sqlite:")) {
    std::string path = uri.substr(std::string_view("sqlite:").size());
    if (path.starts_with("//")) path = path.substr(2);
    if (path != ":memory:" && !path.empty()) return path + ".appearance";
  } else {
    std::filesystem::path cache;
    if (const char* dir = std::getenv("FLEETMAP_CACHE_DIR"); dir && *dir) {
      cache = dir;
    } else if (const char* xdg = std::getenv("XDG_CACHE_HOME"); xdg && *xdg) {
      cache = std::filesystem::path(xdg) / "fleetmap";
    } else if (const char* home = std::getenv("HOME"); home && *home) {
      cache = std::filesystem::path(home) / ".cache" / "fleetmap";
    }
    if (!cache.empty()) {
      char name[32];
      std::snprintf(name, sizeof(name), "appearance-%016llx",
                    static_cast<unsigned long long>(Fnv1a(uri)));
      return cache / name;
    }
  }
  // No directory to put it beside: a temporary one, removed with the repository.
  if (temporary_appearance_dir_.empty()) {
    std::string pattern =
        (std::filesystem::temp_directory_path() / "fleetmap-appearance-XXXXXX").string();
    if (::mkdtemp(pattern.data()) == nullptr) {
      throw Error(ErrorCode::kBackend, "cannot make a temporary appearance index directory");
    }
    temporary_appearance_dir_ = pattern;
  }
  return temporary_appearance_dir_;
}

void Repository::UpdateAppearanceIndex() {
  const std::shared_ptr<const AppearanceVocabulary> vocabulary = IndexVocabulary(nullptr);
  const RevisionNumber head = versions().HeadRevision();
  if (!vocabulary) return;  // an empty map: nothing to index
  if (!appearance_) {
    try {
      appearance_ = DiskAppearanceIndex::Open(AppearanceDirectory());
    } catch (const Error& error) {
      if (error.code() != ErrorCode::kCorrupt) throw;
      // Derived data: start it again rather than refuse to merge.
      std::filesystem::remove_all(AppearanceDirectory());
      appearance_ = DiskAppearanceIndex::Open(AppearanceDirectory());
    }
  }
  if (vocabulary_fingerprint_ == 0) vocabulary_fingerprint_ = Fnv1a(vocabulary->Encode());
  const DiskIndexMark& mark = appearance_->mark();
  // An index of another vocabulary, or of a history this store does not have (a store
  // recreated under the same name), starts again.
  bool same_history =
      mark.vocabulary_fingerprint == vocabulary_fingerprint_ && mark.revision <= head;
  if (same_history && mark.revision > 0) {
    const std::optional<Revision> covered = versions().FindRevision(mark.revision);
    same_history = covered && covered->created_ns == mark.revision_stamp_ns;
  }
  if (!same_history) appearance_->Reset(DiskIndexMark{0, 0, vocabulary_fingerprint_});
  std::vector<Uuid> nodes;
  std::vector<std::vector<WordCount>> bags;
  const auto flush = [&](RevisionNumber r) {
    const std::optional<Revision> revision = versions().FindRevision(r);
    appearance_->Append(
        nodes, bags,
        DiskIndexMark{r, revision ? revision->created_ns : 0, vocabulary_fingerprint_});
    nodes.clear();
    bags.clear();
  };
  for (RevisionNumber r = appearance_->mark().revision + 1; r <= head; ++r) {
    // The nodes a revert of a retirement brings back are indexed already: the index keeps the
    // nodes the head hides (a region only takes the visible ones), so they are not added twice.
    const std::optional<Revision> revision = versions().FindRevision(r);
    if (revision && revision->kind == RevisionKind::kRevert && revision->nodes_added > 0) {
      if (r == head) flush(r);
      continue;
    }
    const RevisionChanges added = versions().Changes(r - 1, r);
    constexpr std::size_t kReadBatch = 1024;
    for (std::size_t i = 0; i < added.nodes_added.size(); i += kReadBatch) {
      const std::span<const Uuid> batch(added.nodes_added.data() + i,
                                        std::min(kReadBatch, added.nodes_added.size() - i));
      for (const Node& node : store_->GetNodes(batch)) {
        nodes.push_back(node.id);
        bags.push_back(BagOfWords(*vocabulary, DecodeLandmarks(node.landmarks_blob).descriptors));
      }
    }
    // Segments of a few tens of thousands of nodes: memory stays at one batch of bags.
    if (nodes.size() >= kIndexBatchNodes || r == head) flush(r);
  }
}

namespace {

// What the ends of a submission's edges outside it are, when the map does not show them.
struct EdgeEnds {
  std::unordered_map<Uuid, NodeStandIn> stand_ins;  // where an end is stood in for
  std::unordered_set<Uuid> seen_elsewhere;          // only in other submissions
  std::unordered_set<Uuid> hidden_ends;             // hidden, with nothing visible near
  std::optional<Uuid> waits_for;                    // a queued submission to merge first
};

// Edge ends outside the submission that the map does not hold: omitted by an earlier merge
// (a stand-in), hidden since, or only in other submissions. One still queued merges first.
// Each end is looked up once; MERGE asks again only through these answers. An end the head
// hides, or whose stand-in it hides (a revert or a promotion since the robot's download),
// hangs from the nearest visible node instead (hidden_anchor.h).
EdgeEnds LookUpEdgeEnds(GraphStore& store, VersionStore& versions, RevisionNumber head,
                        const Uuid& id, const GraphBatch& content) {
  std::unordered_set<Uuid> looked_up;
  for (const Node& node : content.nodes) looked_up.insert(node.id);
  EdgeEnds ends;
  std::unordered_map<Uuid, NodeStandIn>& stand_ins = ends.stand_ins;
  const auto visible = [&](const Uuid& node) {
    const std::optional<ElementVersion> version = versions.VersionOf(node);
    return version && version->added <= head && (!version->hidden || *version->hidden > head);
  };
  for (const Edge& edge : content.edges) {
    for (const Uuid& end : {edge.from, edge.to}) {
      if (!looked_up.insert(end).second) continue;
      if (versions.VersionOf(end)) {
        if (visible(end)) continue;
        if (std::optional<NodeStandIn> anchor = AnchorThroughHidden(store, head, end)) {
          stand_ins.emplace(end, std::move(*anchor));
        } else {
          ends.hidden_ends.insert(end);
        }
        continue;
      }
      if (std::optional<NodeStandIn> stand_in = versions.FindStandIn(end)) {
        if (!visible(stand_in->stand_in)) {
          const std::optional<NodeStandIn> anchor =
              AnchorThroughHidden(store, head, stand_in->stand_in);
          if (!anchor) {
            ends.hidden_ends.insert(end);
            continue;
          }
          stand_in->stand_in = anchor->stand_in;
          stand_in->stand_in_T_node = anchor->stand_in_T_node * stand_in->stand_in_T_node;
        }
        stand_ins.emplace(end, std::move(*stand_in));
        continue;
      }
      for (const Submission& other : versions.SubmissionsWithNode(end)) {
        if (other.id != id && other.state == SubmissionState::kQueued) {
          ends.waits_for = other.id;
          return ends;
        }
      }
      ends.seen_elsewhere.insert(end);
    }
  }
  return ends;
}

// The stored nodes the submission names beyond its own: its edges' ends and their stand-ins.
std::unordered_set<Uuid> NamedNodes(const GraphBatch& content, const EdgeEnds& ends) {
  std::unordered_set<Uuid> named;
  for (const Edge& edge : content.edges) {
    for (const Uuid& end : {edge.from, edge.to}) named.insert(end);
  }
  for (const auto& [node, stand_in] : ends.stand_ins) named.insert(stand_in.stand_in);
  return named;
}

// What MERGE asks of the server beyond the region: answered from the versions, the region's
// hidden nodes and the edge ends looked up. Holds references to all three.
ServerCatalogue CatalogueFor(VersionStore& versions, const MergeRegion& region,
                             const EdgeEnds& ends) {
  ServerCatalogue catalogue{[&](const Uuid& edge) { return versions.VersionOf(edge).has_value(); },
                            [&](const Uuid& path) { return versions.VersionOf(path).has_value(); },
                            // Stored but hidden at the head, with nothing visible near.
                            [&](const Uuid& node) {
                              return region.hidden.contains(node) ||
                                     ends.hidden_ends.contains(node);
                            }};
  catalogue.stand_in = [&](const Uuid& node) -> std::optional<NodeStandIn> {
    const auto found = ends.stand_ins.find(node);
    if (found == ends.stand_ins.end()) return std::nullopt;
    return found->second;
  };
  catalogue.seen_elsewhere = [&](const Uuid& node) { return ends.seen_elsewhere.contains(node); };
  return catalogue;
}

}  // namespace

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
  // Each phase's time, from the end of the one before.
  auto phase_start = std::chrono::steady_clock::now();
  const auto phase_done = [&](double& seconds) {
    const auto now = std::chrono::steady_clock::now();
    seconds = std::chrono::duration<double>(now - phase_start).count();
    phase_start = now;
  };
  GraphBatch content;
  try {
    content = ReadSubmission(id);
  } catch (const Error& error) {
    if (error.code() == ErrorCode::kCorrupt) fail(error);
    throw;
  }
  phase_done(outcome.phases.read_seconds);
  VersionStore& versions = this->versions();
  const RevisionNumber head = versions.HeadRevision();
  // A UUID is the node: one the server holds with other content is refused, both kept (the
  // submission as failed, the stored node as it is), never merged as a duplicate (else
  // the robot would be sent the other node in place of its own).
  try {
    RefuseCollidingNodes(*store_, content);
  } catch (const Error& error) {
    fail(error);
    throw;
  }
  EdgeEnds ends = LookUpEdgeEnds(*store_, versions, head, id, content);
  if (ends.waits_for) {
    outcome.waits_for = ends.waits_for;
    outcome.seconds = SecondsSince(start);
    return outcome;
  }
  phase_done(outcome.phases.checks_seconds);
  // The region of the head this submission can reach, not the whole map (merge_region.h).
  std::shared_ptr<const AppearanceVocabulary> vocabulary = Vocabulary(&content);
  if (!vocabulary) {
    // An empty map and an empty submission: any vocabulary indexes nothing.
    vocabulary = std::make_shared<const AppearanceVocabulary>(
        AppearanceVocabulary::Train(std::vector<Descriptor256>(1)));
  }
  const std::shared_ptr<const AppearanceVocabulary> index_vocabulary = IndexVocabulary(&content);
  UpdateAppearanceIndex();
  phase_done(outcome.phases.index_seconds);
  MergeRegion region =
      LoadMergeRegion(*store_, head, content, NamedNodes(content, ends), *appearance_,
                      *index_vocabulary, vocabulary, RegionOptions(options_.merge));
  outcome.region_nodes = region.map.size();
  phase_done(outcome.phases.region_seconds);
  const ServerCatalogue catalogue = CatalogueFor(versions, region, ends);
  MergeResult result;
  try {
    result = fleetmap::Merge(region.map, content, catalogue, options_.merge, progress);
  } catch (const Error& error) {
    if (error.code() == ErrorCode::kCorrupt || error.code() == ErrorCode::kIntegrity) fail(error);
    throw;
  }
  phase_done(outcome.phases.merge_seconds);

  {
    GraphStore::Transaction transaction = store_->Begin();
    Revision revision;
    revision.number = head + 1;
    revision.created_ns = Now();
    revision.author = submission->author;
    revision.kind = RevisionKind::kMerge;
    revision.submission = id;
    revision.report = MergeReportJson(result.report);
    outcome.revision = versions.AppendRevision(revision, result.additions);
    store_->Put(result.additions);
    for (NodeStandIn& stand_in : result.stand_ins) stand_in.revision = revision.number;
    versions.PutStandIns(result.stand_ins);
    versions.PutNodeUsage(revision.number, result.usage);
    versions.SetSubmissionState(id, SubmissionState::kMerged, revision.number, "");
    if (options_.before_merge_commit) options_.before_merge_commit(id);
    transaction.Commit();
  }
  phase_done(outcome.phases.write_seconds);
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
  return versions().AppendRevert(revision);
}

Revision Repository::AppendUnmergedRevision(const Revision& revision, const GraphBatch& additions) {
  GraphStore::Transaction transaction = store_->Begin();
  Revision appended = versions().AppendRevision(revision, additions);
  store_->Put(additions);
  transaction.Commit();
  return appended;
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

}  // namespace fleetmap
