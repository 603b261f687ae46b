#include "fleetmap/ebn/disk_appearance_index.h"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>
#include <fstream>
#include <optional>
#include <sstream>
#include <utility>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Postings looked ahead by Query's prefetches: enough to cover a cache miss at a few
// nanoseconds of work per posting.
constexpr std::size_t kPrefetchAhead = 16;

// One word of a query, weighed (Query's score, in the header).
struct QueryTerm {
  std::uint32_t word = 0;
  double idf = 0.0;
  double share = 0.0;         // n_qi / D_q
  std::uint64_t holders = 0;  // postings of the word over all segments
};

namespace fs = std::filesystem;

// Segment file, native little-endian (the index is a local cache, never shipped):
//   magic[8] | u32 word_count | u32 node_count | u64 posting_count
//   node ids (16 bytes each) | descriptor counts (u32 each)
//   posting offsets (u64, word_count + 1, into the postings)
//   postings (u32 each: node << 8 | min(count, 255))
constexpr std::array<char, 8> kMagic{'F', 'M', 'A', 'P', 'I', 'X', '0', '1'};
constexpr std::size_t kHeaderBytes = 8 + 4 + 4 + 8;
constexpr std::uint32_t kMaxSegmentNodes = 1u << 24;  // the node field of a posting
constexpr const char* kManifest = "MANIFEST";
constexpr const char* kManifestFirstLine = "fleetmap disk appearance index 1";

Error IoError(const fs::path& path, const std::string& what) {
  return Error(ErrorCode::kBackend,
               "appearance index: " + what + " " + path.string() + ": " + std::strerror(errno));
}

// An open file descriptor, closed on destruction.
class FileHandle {
 public:
  FileHandle() = default;
  explicit FileHandle(int fd) : fd_(fd) {}
  FileHandle(FileHandle&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}
  FileHandle& operator=(FileHandle&& other) noexcept {
    if (this != &other) {
      Close();
      fd_ = std::exchange(other.fd_, -1);
    }
    return *this;
  }
  ~FileHandle() { Close(); }
  int get() const { return fd_; }

 private:
  void Close() {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
  }
  int fd_ = -1;
};

void ReadAt(int fd, const fs::path& path, void* out, std::size_t bytes, std::uint64_t offset) {
  auto* p = static_cast<char*>(out);
  while (bytes > 0) {
    const ssize_t n = ::pread(fd, p, bytes, static_cast<off_t>(offset));
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw IoError(path, "cannot read");
    if (n == 0)
      throw Error(ErrorCode::kCorrupt, "appearance index: " + path.string() + " is short");
    p += n;
    bytes -= static_cast<std::size_t>(n);
    offset += static_cast<std::uint64_t>(n);
  }
}

// Buffered sequential writing of a new file, fsynced on Finish.
class FileWriter {
 public:
  explicit FileWriter(const fs::path& path) : path_(path) {
    fd_ = FileHandle(::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644));
    if (fd_.get() < 0) throw IoError(path, "cannot create");
    buffer_.reserve(kBufferBytes);
  }
  void Write(const void* data, std::size_t bytes) {
    const auto* p = static_cast<const char*>(data);
    if (buffer_.size() + bytes > kBufferBytes) Flush();
    if (bytes >= kBufferBytes) {
      WriteAll(p, bytes);
      return;
    }
    buffer_.insert(buffer_.end(), p, p + bytes);
  }
  template <typename T>
  void WritePod(const T& value) {
    Write(&value, sizeof(T));
  }
  void Finish() {
    Flush();
    if (::fsync(fd_.get()) != 0) throw IoError(path_, "cannot sync");
    fd_ = FileHandle();
  }

 private:
  static constexpr std::size_t kBufferBytes = 1 << 20;
  void Flush() {
    WriteAll(buffer_.data(), buffer_.size());
    buffer_.clear();
  }
  void WriteAll(const char* p, std::size_t bytes) {
    while (bytes > 0) {
      const ssize_t n = ::write(fd_.get(), p, bytes);
      if (n < 0 && errno == EINTR) continue;
      if (n < 0) throw IoError(path_, "cannot write");
      p += n;
      bytes -= static_cast<std::size_t>(n);
    }
  }
  fs::path path_;
  FileHandle fd_;
  std::vector<char> buffer_;
};

// Holds an exclusive flock on the directory's LOCK file.
class DirectoryLock {
 public:
  explicit DirectoryLock(const fs::path& directory) {
    const fs::path path = directory / "LOCK";
    fd_ = FileHandle(::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644));
    if (fd_.get() < 0) throw IoError(path, "cannot open");
    while (::flock(fd_.get(), LOCK_EX) != 0) {
      if (errno != EINTR) throw IoError(path, "cannot lock");
    }
  }

 private:
  FileHandle fd_;  // closing it releases the lock
};

std::string SegmentName(std::uint64_t id) {
  return "segment-" + std::to_string(id) + ".fmai";
}

}  // namespace

// One immutable segment file, open; its node table and offsets in memory, postings on disk.
class DiskAppearanceIndex::Segment {
 public:
  static std::unique_ptr<Segment> Open(const fs::path& path, std::uint64_t id) {
    auto segment = std::unique_ptr<Segment>(new Segment());
    segment->path_ = path;
    segment->id_ = id;
    segment->fd_ = FileHandle(::open(path.c_str(), O_RDONLY | O_CLOEXEC));
    if (segment->fd_.get() < 0) throw IoError(path, "cannot open");
    segment->Load();
    return segment;
  }

  // Writes a segment of `nodes` with `bags`.
  static void Write(const fs::path& path, std::span<const Uuid> nodes,
                    std::span<const std::vector<WordCount>> bags) {
    std::uint32_t word_count = 0;
    std::uint64_t posting_count = 0;
    for (const std::vector<WordCount>& bag : bags) {
      posting_count += bag.size();
      if (!bag.empty()) {
        word_count = std::max(word_count, static_cast<std::uint32_t>(bag.back().word) + 1);
      }
    }
    std::vector<std::uint64_t> offsets(word_count + 1, 0);
    for (const std::vector<WordCount>& bag : bags) {
      for (const WordCount& wc : bag) ++offsets[static_cast<std::size_t>(wc.word) + 1];
    }
    for (std::size_t w = 1; w < offsets.size(); ++w) offsets[w] += offsets[w - 1];
    std::vector<std::uint32_t> postings(posting_count);
    std::vector<std::uint64_t> fill(offsets.begin(), offsets.end() - 1);
    for (std::uint32_t n = 0; n < bags.size(); ++n) {
      for (const WordCount& wc : bags[n]) {
        postings[fill[static_cast<std::size_t>(wc.word)]++] =
            (n << 8) | static_cast<std::uint32_t>(std::min(wc.count, 255));
      }
    }
    FileWriter out(path);
    WriteHead(out, word_count, static_cast<std::uint32_t>(nodes.size()), posting_count);
    for (const Uuid& node : nodes) out.Write(node.bytes().data(), 16);
    for (const std::vector<WordCount>& bag : bags) {
      std::uint32_t descriptors = 0;
      for (const WordCount& wc : bag) descriptors += static_cast<std::uint32_t>(wc.count);
      out.WritePod(descriptors);
    }
    out.Write(offsets.data(), offsets.size() * sizeof(std::uint64_t));
    out.Write(postings.data(), postings.size() * sizeof(std::uint32_t));
    out.Finish();
  }

  // Writes the segment holding `older`'s nodes then `newer`'s, word by word, so that memory
  // stays at one word's postings whatever the sizes.
  static void WriteMerged(const fs::path& path, const Segment& older, const Segment& newer) {
    const std::uint32_t word_count = std::max(older.word_count_, newer.word_count_);
    const std::uint32_t node_count = older.node_count() + newer.node_count();
    std::vector<std::uint64_t> offsets(word_count + 1, 0);
    for (std::uint32_t w = 0; w < word_count; ++w) {
      offsets[w + 1] = offsets[w] + older.PostingCount(w) + newer.PostingCount(w);
    }
    FileWriter out(path);
    WriteHead(out, word_count, node_count, offsets.back());
    for (const Segment* s : {&older, &newer}) {
      for (const Uuid& node : s->nodes_) out.Write(node.bytes().data(), 16);
    }
    for (const Segment* s : {&older, &newer}) {
      out.Write(s->descriptors_.data(), s->descriptors_.size() * sizeof(std::uint32_t));
    }
    out.Write(offsets.data(), offsets.size() * sizeof(std::uint64_t));
    std::vector<std::uint32_t> postings;
    for (std::uint32_t w = 0; w < word_count; ++w) {
      older.ReadPostings(w, postings);
      out.Write(postings.data(), postings.size() * sizeof(std::uint32_t));
      newer.ReadPostings(w, postings);
      for (std::uint32_t& p : postings) p += older.node_count() << 8;
      out.Write(postings.data(), postings.size() * sizeof(std::uint32_t));
    }
    out.Finish();
  }

  std::uint64_t id() const { return id_; }
  const fs::path& path() const { return path_; }
  std::uint32_t node_count() const { return static_cast<std::uint32_t>(nodes_.size()); }
  const Uuid& node(std::uint32_t n) const { return nodes_[n]; }
  std::uint32_t descriptors(std::uint32_t n) const { return descriptors_[n]; }
  // Asks the CPU to fetch node n's descriptor count ahead of its use.
  void PrefetchDescriptors(std::uint32_t n) const { __builtin_prefetch(&descriptors_[n]); }
  std::uint64_t PostingCount(std::uint32_t word) const {
    return word < word_count_ ? offsets_[word + 1] - offsets_[word] : 0;
  }
  // The postings of `word` into `out` (replaced).
  void ReadPostings(std::uint32_t word, std::vector<std::uint32_t>& out) const {
    out.resize(PostingCount(word));
    if (out.empty()) return;
    ReadAt(fd_.get(), path_, out.data(), out.size() * sizeof(std::uint32_t),
           postings_at_ + offsets_[word] * sizeof(std::uint32_t));
  }

  // Adds each of `terms`' share of every node's score into `scores` (by node number), and
  // the nodes it first touches to `touched`; `postings` is scratch.
  void AddScores(std::span<const QueryTerm> terms, std::vector<float>& scores,
                 std::vector<std::uint32_t>& touched, std::vector<std::uint32_t>& postings) const;

  // Appends to `best` the segment's best k of the `touched` nodes by `scores`, each score a
  // share of `mass`; `ranked` is scratch.
  void AddBest(const std::vector<float>& scores, const std::vector<std::uint32_t>& touched, int k,
               double mass, std::vector<std::pair<float, std::uint32_t>>& ranked,
               std::vector<AppearanceMatch>& best) const;

 private:
  Segment() = default;

  static void WriteHead(FileWriter& out, std::uint32_t word_count, std::uint32_t node_count,
                        std::uint64_t posting_count) {
    out.Write(kMagic.data(), kMagic.size());
    out.WritePod(word_count);
    out.WritePod(node_count);
    out.WritePod(posting_count);
  }

  void Load() {
    std::array<char, kHeaderBytes> head{};
    ReadAt(fd_.get(), path_, head.data(), head.size(), 0);
    if (std::memcmp(head.data(), kMagic.data(), kMagic.size()) != 0) {
      throw Error(ErrorCode::kCorrupt, "appearance index: " + path_.string() + " is no segment");
    }
    std::uint32_t node_count = 0;
    std::uint64_t posting_count = 0;
    std::memcpy(&word_count_, head.data() + 8, 4);
    std::memcpy(&node_count, head.data() + 12, 4);
    std::memcpy(&posting_count, head.data() + 16, 8);
    struct stat st {};
    if (::fstat(fd_.get(), &st) != 0) throw IoError(path_, "cannot stat");
    const std::uint64_t expected = kHeaderBytes + std::uint64_t{node_count} * 20 +
                                   (std::uint64_t{word_count_} + 1) * 8 + posting_count * 4;
    if (node_count > kMaxSegmentNodes || static_cast<std::uint64_t>(st.st_size) != expected) {
      throw Error(ErrorCode::kCorrupt,
                  "appearance index: " + path_.string() + " has the wrong size for its header");
    }
    std::vector<std::array<std::uint8_t, 16>> ids(node_count);
    ReadAt(fd_.get(), path_, ids.data(), ids.size() * 16, kHeaderBytes);
    nodes_.reserve(node_count);
    for (const auto& bytes : ids) nodes_.push_back(Uuid(bytes));
    descriptors_.resize(node_count);
    ReadAt(fd_.get(), path_, descriptors_.data(), descriptors_.size() * 4,
           kHeaderBytes + std::uint64_t{node_count} * 16);
    offsets_.resize(word_count_ + 1);
    const std::uint64_t offsets_at = kHeaderBytes + std::uint64_t{node_count} * 20;
    ReadAt(fd_.get(), path_, offsets_.data(), offsets_.size() * 8, offsets_at);
    for (std::size_t w = 0; w < word_count_; ++w) {
      if (offsets_[w + 1] < offsets_[w]) {
        throw Error(ErrorCode::kCorrupt,
                    "appearance index: " + path_.string() + " has offsets out of order");
      }
    }
    if (offsets_.front() != 0 || offsets_.back() != posting_count) {
      throw Error(ErrorCode::kCorrupt,
                  "appearance index: " + path_.string() + " has offsets out of range");
    }
    postings_at_ = offsets_at + offsets_.size() * 8;
  }

  fs::path path_;
  std::uint64_t id_ = 0;
  FileHandle fd_;
  std::uint32_t word_count_ = 0;
  std::vector<Uuid> nodes_;
  std::vector<std::uint32_t> descriptors_;
  std::vector<std::uint64_t> offsets_;
  std::uint64_t postings_at_ = 0;
};

namespace {

struct Manifest {
  DiskIndexMark mark;
  std::vector<std::uint64_t> segments;
  std::uint64_t next_id = 1;
};

std::optional<Manifest> ReadManifest(const fs::path& directory) {
  const fs::path path = directory / kManifest;
  std::ifstream in(path);
  if (!in) return std::nullopt;
  Manifest manifest;
  std::string line;
  if (!std::getline(in, line) || line != kManifestFirstLine) {
    throw Error(ErrorCode::kCorrupt, "appearance index: " + path.string() + " is no manifest");
  }
  while (std::getline(in, line)) {
    std::istringstream fields(line);
    std::string key;
    fields >> key;
    if (key == "revision") {
      fields >> manifest.mark.revision >> manifest.mark.revision_stamp_ns;
    } else if (key == "vocabulary") {
      fields >> manifest.mark.vocabulary_fingerprint;
    } else if (key == "next") {
      fields >> manifest.next_id;
    } else if (key == "segment") {
      std::uint64_t id = 0;
      fields >> id;
      manifest.segments.push_back(id);
    }
    if (!fields) {
      throw Error(ErrorCode::kCorrupt,
                  "appearance index: " + path.string() + ": bad line \"" + line + "\"");
    }
  }
  return manifest;
}

}  // namespace

std::unique_ptr<DiskAppearanceIndex> DiskAppearanceIndex::Open(const fs::path& directory) {
  std::error_code ec;
  fs::create_directories(directory, ec);
  if (ec) {
    throw Error(ErrorCode::kBackend,
                "appearance index: cannot make " + directory.string() + ": " + ec.message());
  }
  // Without the lock: a writer in another process may replace the manifest and remove the
  // segments it named between our reading it and opening them; then read it again.
  for (int attempt = 1;; ++attempt) {
    const std::optional<Manifest> manifest = ReadManifest(directory);
    if (!manifest) {
      return std::unique_ptr<DiskAppearanceIndex>(
          new DiskAppearanceIndex(directory, DiskIndexMark{}, {}, 1));
    }
    try {
      std::vector<std::unique_ptr<Segment>> segments;
      for (const std::uint64_t id : manifest->segments) {
        segments.push_back(Segment::Open(directory / SegmentName(id), id));
      }
      return std::unique_ptr<DiskAppearanceIndex>(new DiskAppearanceIndex(
          directory, manifest->mark, std::move(segments), manifest->next_id));
    } catch (const Error& error) {
      const bool vanished = error.code() == ErrorCode::kBackend && errno == ENOENT;
      if (!vanished || attempt == 3) throw;
    }
  }
}

DiskAppearanceIndex::DiskAppearanceIndex(fs::path directory, DiskIndexMark mark,
                                         std::vector<std::unique_ptr<Segment>> segments,
                                         std::uint64_t next_id)
    : directory_(std::move(directory)),
      mark_(mark),
      segments_(std::move(segments)),
      next_id_(next_id) {}

DiskAppearanceIndex::~DiskAppearanceIndex() = default;
DiskAppearanceIndex::DiskAppearanceIndex(DiskAppearanceIndex&&) noexcept = default;
DiskAppearanceIndex& DiskAppearanceIndex::operator=(DiskAppearanceIndex&&) noexcept = default;

std::size_t DiskAppearanceIndex::size() const {
  std::size_t n = 0;
  for (const auto& segment : segments_) n += segment->node_count();
  return n;
}

void DiskAppearanceIndex::WriteManifest() {
  const fs::path path = directory_ / kManifest;
  const fs::path temporary = directory_ / "MANIFEST.tmp";
  std::ostringstream text;
  text << kManifestFirstLine << "\n"
       << "revision " << mark_.revision << " " << mark_.revision_stamp_ns << "\n"
       << "vocabulary " << mark_.vocabulary_fingerprint << "\n"
       << "next " << next_id_ << "\n";
  for (const auto& segment : segments_) text << "segment " << segment->id() << "\n";
  FileWriter out(temporary);
  const std::string bytes = text.str();
  out.Write(bytes.data(), bytes.size());
  out.Finish();
  if (::rename(temporary.c_str(), path.c_str()) != 0) throw IoError(path, "cannot replace");
}

void DiskAppearanceIndex::Append(std::span<const Uuid> nodes,
                                 std::span<const std::vector<WordCount>> bags,
                                 const DiskIndexMark& mark) {
  if (nodes.size() != bags.size() || nodes.size() >= kMaxSegmentNodes) {
    throw Error(ErrorCode::kInvalidArgument, "appearance index: a batch of " +
                                                 std::to_string(nodes.size()) + " nodes and " +
                                                 std::to_string(bags.size()) + " bags");
  }
  DirectoryLock lock(directory_);
  // Another process sharing the directory may have moved it on: start from what is on disk.
  if (const std::optional<Manifest> on_disk = ReadManifest(directory_);
      on_disk && (on_disk->mark != mark_ || on_disk->segments.size() != segments_.size())) {
    *this = std::move(*Open(directory_));
    if (mark_.revision >= mark.revision &&
        mark_.vocabulary_fingerprint == mark.vocabulary_fingerprint) {
      return;  // covered already
    }
  }
  if (!nodes.empty()) {
    const std::uint64_t id = next_id_++;
    const fs::path path = directory_ / SegmentName(id);
    Segment::Write(path, nodes, bags);
    segments_.push_back(Segment::Open(path, id));
  }
  mark_ = mark;
  WriteManifest();
  Compact();
}

void DiskAppearanceIndex::Compact() {
  while (segments_.size() >= 2 &&
         segments_[segments_.size() - 2]->node_count() <= segments_.back()->node_count() &&
         std::uint64_t{segments_[segments_.size() - 2]->node_count()} +
                 segments_.back()->node_count() <
             kMaxSegmentNodes) {
    const std::uint64_t id = next_id_++;
    const fs::path path = directory_ / SegmentName(id);
    Segment::WriteMerged(path, *segments_[segments_.size() - 2], *segments_.back());
    std::vector<fs::path> obsolete{segments_[segments_.size() - 2]->path(),
                                   segments_.back()->path()};
    segments_.pop_back();
    segments_.back() = Segment::Open(path, id);
    WriteManifest();
    // Readers that opened them keep reading; new readers follow the manifest.
    for (const fs::path& old : obsolete) ::unlink(old.c_str());
  }
}

void DiskAppearanceIndex::Reset(const DiskIndexMark& mark) {
  DirectoryLock lock(directory_);
  std::vector<fs::path> obsolete;
  for (const auto& segment : segments_) obsolete.push_back(segment->path());
  segments_.clear();
  mark_ = mark;
  WriteManifest();
  for (const fs::path& old : obsolete) ::unlink(old.c_str());
  // Segment files no manifest names (a crash between writing one and the manifest).
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(directory_, ec)) {
    if (entry.path().extension() == ".fmai") fs::remove(entry.path(), ec);
  }
}

namespace {

// The words of `bag` worth reading, weighed by idf over the `n` nodes indexed (`holders`: each
// word's postings over all segments), and the best score's denominator: sum_i idf_i n_qi / D_q.
// No words when nothing can score.
struct WeighedQuery {
  std::vector<QueryTerm> terms;
  double mass = 0.0;
  std::uint64_t all_postings = 0;
};

WeighedQuery WeighTerms(std::span<const WordCount> bag, std::span<const std::uint64_t> holders,
                        std::size_t n) {
  double descriptors = 0.0;
  for (const WordCount& wc : bag) descriptors += wc.count;
  const double log_n = std::log(static_cast<double>(n));
  WeighedQuery query;
  for (std::size_t i = 0; i < bag.size(); ++i) {
    const WordCount& wc = bag[i];
    const double idf = holders[i] == 0 ? log_n : log_n - std::log(static_cast<double>(holders[i]));
    const double share = wc.count / descriptors;
    query.mass += idf * share;
    if (holders[i] > 0 && idf > 0.0) {
      query.terms.push_back({static_cast<std::uint32_t>(wc.word), idf, share, holders[i]});
      query.all_postings += holders[i];
    }
  }
  return query;
}

// Over either bound, the heaviest words first; then as many as fit both bounds (the first
// always does). Scores are then shares of what the queried words can give, so a node holding
// the whole query still scores 1.
void KeepHeaviestTerms(WeighedQuery& query, int max_query_words, std::uint64_t max_postings) {
  std::vector<QueryTerm>& terms = query.terms;
  if (terms.size() <= static_cast<std::size_t>(max_query_words) &&
      query.all_postings <= max_postings) {
    return;
  }
  std::sort(terms.begin(), terms.end(), [](const QueryTerm& a, const QueryTerm& b) {
    return std::pair(a.idf * a.share, b.word) > std::pair(b.idf * b.share, a.word);
  });
  std::vector<QueryTerm> chosen;
  std::uint64_t postings = 0;
  for (const QueryTerm& term : terms) {
    if (chosen.size() == static_cast<std::size_t>(max_query_words)) break;
    if (!chosen.empty() && postings + term.holders > max_postings) continue;
    chosen.push_back(term);
    postings += term.holders;
  }
  terms = std::move(chosen);
  query.mass = 0.0;
  for (const QueryTerm& term : terms) query.mass += term.idf * term.share;
}

}  // namespace

void DiskAppearanceIndex::Segment::AddScores(std::span<const QueryTerm> terms,
                                             std::vector<float>& scores,
                                             std::vector<std::uint32_t>& touched,
                                             std::vector<std::uint32_t>& postings) const {
  for (const QueryTerm& term : terms) {
    ReadPostings(term.word, postings);
    for (std::size_t p = 0; p < postings.size(); ++p) {
      // A word's postings are spread over the whole segment, so each reaches a cache line of
      // its own in `scores` and in the descriptor counts: fetched a few postings ahead, the
      // waits overlap instead of adding up (half of a query's time at 10^6 nodes).
      if (p + kPrefetchAhead < postings.size()) {
        const std::uint32_t ahead = postings[p + kPrefetchAhead] >> 8;
        if (ahead < node_count()) {
          __builtin_prefetch(&scores[ahead], 1);
          PrefetchDescriptors(ahead);
        }
      }
      const std::uint32_t posting = postings[p];
      const std::uint32_t node = posting >> 8;
      if (node >= node_count()) {
        throw Error(ErrorCode::kCorrupt,
                    "appearance index: " + path().string() + " has a posting out of range");
      }
      const double share =
          static_cast<double>(posting & 0xFF) / std::max<std::uint32_t>(1, descriptors(node));
      if (scores[node] == 0.0f) touched.push_back(node);
      scores[node] += static_cast<float>(term.idf * std::min(term.share, share));
    }
  }
}

void DiskAppearanceIndex::Segment::AddBest(const std::vector<float>& scores,
                                           const std::vector<std::uint32_t>& touched, int k,
                                           double mass,
                                           std::vector<std::pair<float, std::uint32_t>>& ranked,
                                           std::vector<AppearanceMatch>& best) const {
  // Chosen on (score, node number) pairs: a query at a million nodes touches a hundred
  // thousand of them, and only k become matches.
  ranked.clear();
  for (const std::uint32_t node : touched) ranked.emplace_back(scores[node], node);
  const auto better_here = [&](const std::pair<float, std::uint32_t>& a,
                               const std::pair<float, std::uint32_t>& b) {
    return a.first != b.first ? a.first > b.first : this->node(a.second) < this->node(b.second);
  };
  const std::size_t winners = std::min(ranked.size(), static_cast<std::size_t>(k));
  if (winners == 0) return;
  std::nth_element(ranked.begin(), ranked.begin() + static_cast<std::ptrdiff_t>(winners) - 1,
                   ranked.end(), better_here);
  for (std::size_t i = 0; i < winners; ++i) {
    best.push_back({node(ranked[i].second), ranked[i].first / mass});
  }
}

std::vector<AppearanceMatch> DiskAppearanceIndex::Query(std::span<const WordCount> bag, int k,
                                                        int max_query_words,
                                                        std::uint64_t max_postings) const {
  if (k < 0 || max_query_words < 1) {
    throw Error(ErrorCode::kInvalidArgument, "appearance index: k >= 0 and max words >= 1");
  }
  const std::size_t n = size();
  if (n == 0 || k == 0 || bag.empty()) return {};
  std::vector<std::uint64_t> holders(bag.size(), 0);
  for (std::size_t i = 0; i < bag.size(); ++i) {
    for (const auto& segment : segments_) {
      holders[i] += segment->PostingCount(static_cast<std::uint32_t>(bag[i].word));
    }
  }
  WeighedQuery query = WeighTerms(bag, holders, n);
  if (query.terms.empty() || query.mass <= 0.0) return {};
  KeepHeaviestTerms(query, max_query_words, max_postings);

  std::vector<AppearanceMatch> best;
  // Scores by node number in a segment. Kept zero between uses and reset entry by entry after
  // each segment (only those the postings touched), so a query costs its postings, not the
  // segment's size: clearing an array of the map's size per query made merges grow with the
  // map (fleetmap bench scale). One per thread, grown to the largest segment seen.
  thread_local std::vector<float> scores;
  std::vector<std::uint32_t> touched, postings;
  std::vector<std::pair<float, std::uint32_t>> ranked;
  const auto better = [](const AppearanceMatch& a, const AppearanceMatch& b) {
    return a.score != b.score ? a.score > b.score : a.node < b.node;
  };
  for (const auto& segment : segments_) {
    if (scores.size() < segment->node_count()) scores.resize(segment->node_count(), 0.0f);
    touched.clear();
    // Whatever happens below (a corrupt posting, a failed read), the touched scores are
    // zero again when this segment is done.
    struct Rezero {
      std::vector<float>& scores;
      const std::vector<std::uint32_t>& touched;
      ~Rezero() {
        for (const std::uint32_t node : touched) scores[node] = 0.0f;
      }
    } rezero{scores, touched};
    segment->AddScores(query.terms, scores, touched, postings);
    segment->AddBest(scores, touched, k, query.mass, ranked, best);
  }
  const std::size_t keep = std::min(best.size(), static_cast<std::size_t>(k));
  std::partial_sort(best.begin(), best.begin() + static_cast<std::ptrdiff_t>(keep), best.end(),
                    better);
  best.resize(keep);
  return best;
}

}  // namespace fleetmap
