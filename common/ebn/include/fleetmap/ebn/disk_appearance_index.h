// The appearance index of a whole fleet map kept on disk (so that merges are bounded by the
// region they touch), so that MERGE finds where a submission relocalises (seed 004 §III-B)
// without loading the map or rebuilding an index over it.
//
// Layout: a directory of immutable segment files and a MANIFEST naming them. A segment is an
// inverted file of bags of words over the repository's AppearanceVocabulary (appearance_index.h)
// for a batch of nodes: its nodes with their descriptor counts, then per word the postings
// (node of the segment, count) of the nodes holding it. New nodes are appended as a new segment;
// the newest segments are merged while the older of the last two is no larger than the newer
// (LevelDB-like, so a node is rewritten about log2(n / batch) times and a query opens about as
// many segments). MANIFEST is replaced atomically (write, fsync, rename) and names the revision
// the index covers, so a crash leaves the old index or the new one, never half of one.
//
// Scoring, for seeding a region rather than ranking within it: over the queried words Q,
// s(d) = sum_{i in Q, d holds i} idf_i min(n_qi / D_q, n_di / D_d) / sum_{i in Q} idf_i n_qi / D_q,
// with
// idf_i = ln(N / n_i) over the whole index. It is DBoW2's L1 score (Gálvez-López and Tardós,
// T-RO 2012, Eq. 2) with each bag normalised by its descriptor count instead of its tf-idf mass,
// which would need every node's whole bag at query time. The region's own AppearanceIndex
// ranks exactly afterwards. A query reads only the postings of its own words: the heaviest by
// n_qi idf_i, at most `max_query_words` of them and, past the first, at most `max_postings`
// postings together (a word that would exceed it is passed over for lighter ones). A word's
// postings grow with the map (about N D / W), so without the second bound a query's cost
// would too; with it, a query costs about the same at 10^5 nodes and at 10^6, where it reads
// fewer, still distinctive words (fleetmap bench scale).
//
// Threading: one thread per object. Several processes may share a directory: writers take an
// exclusive lock on it (flock on LOCK); a reader opens the segments the MANIFEST names when it
// loads, and an open segment stays readable after a writer replaced it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/ebn/appearance_index.h"

namespace fleetmap {

// What the index covers: the store revision it was last brought up to, identified by that
// revision's stamp, and the vocabulary its words come from.
// The postings one query reads at most (past its first word): a cost bound, a few
// milliseconds of scoring. A map's words hold about N D / W postings each (N nodes of D
// descriptors over W words): with D = 200 and W = 10^5, a frame's 200 words hold about 40,000
// postings at 10^5 nodes, under the bound, and 400,000 at 10^6, where the bound keeps the 64
// or so heaviest: as many as a query of 64 words reads, which finds a noisy revisit among the
// best three nine times in ten (DiskAppearanceIndexTest).
inline constexpr std::uint64_t kDefaultMaxQueryPostings = std::uint64_t{1} << 17;

struct DiskIndexMark {
  std::int64_t revision = 0;
  std::int64_t revision_stamp_ns = 0;
  std::uint64_t vocabulary_fingerprint = 0;

  friend bool operator==(const DiskIndexMark&, const DiskIndexMark&) = default;
};

class DiskAppearanceIndex {
 public:
  // Opens the index in `directory`, creating an empty one (mark all zero) if there is none.
  // Throws Error(kBackend) when the directory cannot be made or read, Error(kCorrupt) when a
  // segment is malformed (the caller may Reset and rebuild: the index is derived data).
  static std::unique_ptr<DiskAppearanceIndex> Open(const std::filesystem::path& directory);
  ~DiskAppearanceIndex();
  DiskAppearanceIndex(DiskAppearanceIndex&&) noexcept;
  DiskAppearanceIndex& operator=(DiskAppearanceIndex&&) noexcept;

  const DiskIndexMark& mark() const { return mark_; }
  std::size_t size() const;  // nodes indexed
  std::size_t segment_count() const { return segments_.size(); }

  // Adds `nodes` with their bags as a new segment and records `mark` as covered, in one
  // atomic step (under the directory's lock); then merges segments as described above. A node
  // may be appended twice only if its bag is the same (a retried batch); queries report it once
  // per segment holding it. REQUIRES: nodes.size() == bags.size() < 2^24.
  void Append(std::span<const Uuid> nodes, std::span<const std::vector<WordCount>> bags,
              const DiskIndexMark& mark);
  // Empties the index and records `mark` (e.g. a repository whose history no longer matches).
  void Reset(const DiskIndexMark& mark);

  // The best min(k, size()) nodes for a bag, by descending score (above), equal scores by
  // ascending Uuid; nodes sharing none of the query words are not returned.
  std::vector<AppearanceMatch> Query(std::span<const WordCount> bag, int k,
                                     int max_query_words = 64,
                                     std::uint64_t max_postings = kDefaultMaxQueryPostings) const;

 private:
  class Segment;
  DiskAppearanceIndex(std::filesystem::path directory, DiskIndexMark mark,
                      std::vector<std::unique_ptr<Segment>> segments, std::uint64_t next_id);
  // Writes MANIFEST for the current segments and mark, atomically. REQUIRES: the lock held.
  void WriteManifest();
  // Merges the newest segments while the older of the last two is no larger than the newer.
  void Compact();

  std::filesystem::path directory_;
  DiskIndexMark mark_;
  std::vector<std::unique_ptr<Segment>> segments_;  // oldest first
  std::uint64_t next_id_ = 1;                       // of the next segment file
};

}  // namespace fleetmap
