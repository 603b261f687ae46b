// Appearance-based place recognition: the FAB-MAP stand-in used for relocalisation (seed 004
// §III-B). When a robot is lost, the experience-map builder asks the index for the nodes whose
// appearance best matches the live frame, then runs the Localiser (localiser.h) on the first few.
//
// Method: a bag of binary words in the style of DBoW2 (Gálvez-López and Tardós, "Bags of
// Binary Words for Fast Place Recognition in Image Sequences", T-RO 2012):
// - AppearanceVocabulary quantises a 256-bit descriptor to a word: the leaf of a vocabulary tree
//   built by hierarchical k-majority (the paper's k-medians: the median of binary descriptors is
//   their bitwise majority), seeded by k-means++, and descended by Hamming distance (hamming.h).
// - AppearanceIndex keeps one tf-idf bag of words per node in an inverted file and scores a
//   query by DBoW2's L1 score s(v, w) = 1 - |v - w|_1 / 2 of L1-normalised vectors (paper
//   Eq. 2), which for non-negative weights equals the sum over shared words of min(v_i, w_i),
//   so only the postings of the query's words are read.
//
// Conventions: a word is an int in [0, word_count()). idf_i = ln(N / n_i), where N is the number
// of indexed nodes and n_i the number of them holding word i; it is exact after every Add (see
// AppearanceIndex). Scores lie in [0, 1], 1 for identical bags. Everything is deterministic:
// training depends only on the sample and the options, and ranking ties go to the lower Uuid.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

struct VocabularyOptions {
  int branching = 10;            // children per tree node (k of k-majority), >= 2
  int depth = 3;                 // levels below the root, >= 1; at most branching^depth words
  int kmajority_iterations = 8;  // centre updates per clustering step, >= 0 (0: seeds only)
  std::uint32_t seed = 1;        // k-means++ seeding; same seed and sample, same vocabulary
};

// A hierarchical k-majority vocabulary tree over 256-bit descriptors: words are its leaves.
// Immutable once trained, so one vocabulary may be shared by any number of threads and indexes.
class AppearanceVocabulary {
 public:
  // Trains from a descriptor sample (DBoW2 §IV: k-means++ seeds, then k-majority, level by
  // level). A cluster becomes a word when it reaches `depth` or holds a single distinct
  // descriptor, so small or repetitive samples give fewer words than branching^depth.
  // Deterministic: the same sample in the same order and the same options give the same tree
  // on every platform and Hamming kernel.
  // Throws Error(kInvalidArgument) for an empty sample, a sample of 2^31 or more descriptors,
  // or options outside the ranges above.
  static AppearanceVocabulary Train(std::span<const Descriptor256> sample,
                                    const VocabularyOptions& options = {});

  // The vocabulary as bytes (fleetmap.v1.AppearanceVocabulary), so a repository keeps the
  // words its map was indexed with; Decode gives back an equal vocabulary (same words for
  // every descriptor). Decode throws Error(kCorrupt) for bytes that do not parse or do not
  // form a well-formed tree (children out of range or out of order, words missing or out of
  // range, centres of the wrong size).
  std::string Encode() const;
  static AppearanceVocabulary Decode(std::string_view bytes);

  int word_count() const { return word_count_; }
  const VocabularyOptions& options() const { return options_; }

  // The word of `d`: descends from the root to the nearest child centre at each level (ties to
  // the first child), so it costs at most branching x depth Hamming distances.
  int WordOf(const Descriptor256& d) const;

  // WordOf of each descriptor, descending level by level so that each tree node's descriptors
  // meet its children in one FindHammingNeighbours call (the SIMD kernel): the same words,
  // about twice as fast for a frame's worth of descriptors.
  std::vector<int> WordsOf(std::span<const Descriptor256> descriptors) const;

 private:
  struct TreeNode {
    int first_child = 0;  // children are the contiguous nodes [first_child, +child_count)
    int child_count = 0;  // 0 for a leaf
    int word = -1;        // leaves only
  };

  AppearanceVocabulary() = default;
  // The child of inner node `node` nearest to `d`.
  std::uint32_t Descend(std::uint32_t node, const Descriptor256& d) const;

  VocabularyOptions options_;
  std::vector<TreeNode> nodes_;         // nodes_[0] is the root
  std::vector<Descriptor256> centres_;  // centres_[i] of nodes_[i]; the root's is unused
  int word_count_ = 0;
};

// A bag of words: (word, count) by ascending word, counts > 0.
struct WordCount {
  int word = 0;
  int count = 0;
};
// The bag of `descriptors` in `vocabulary`'s words.
std::vector<WordCount> BagOfWords(const AppearanceVocabulary& vocabulary,
                                  std::span<const Descriptor256> descriptors);

struct AppearanceMatch {
  Uuid node;
  double score = 0.0;  // L1 score in [0, 1], higher = more similar

  friend bool operator==(const AppearanceMatch&, const AppearanceMatch&) = default;
};

// The nodes' bags of words with an inverted file (word -> postings of (node, count)).
//
// idf stays exact after every Add without rescanning the index: the tf-idf vector of node d is
// w_i = n_di idf_i / Z_d with Z_d = sum_i n_di idf_i = D_d ln N - S_d, where n_di counts d's
// descriptors quantised to word i, D_d = sum_i n_di and S_d = sum_i n_di ln n_i. The index stores
// the raw counts n_di, applies idf at query time, and keeps S_d current by adding
// n_di (ln(n_i + 1) - ln n_i) to every node already posted under a word that a new node brings;
// so Add costs the postings of its words, as a Query does. S_d is a running floating-point sum,
// hence scores can differ in the last bits between indexes that reached the same content
// through different sequences of Add (never between runs of the same sequence).
//
// With fewer than two nodes, or for a word every node holds, idf is 0: such words say nothing
// about which node matches and weigh nothing. A query word no node holds gets the idf of the
// rarest indexed word, ln N (n_i taken as 1): it cannot be shared, but it dilutes the shared
// ones, so a frame of mostly unseen words scores low. A bag in which nothing weighs (empty, or
// of such words only) scores 0 against everything.
//
// Thread-safety: const methods may run concurrently; Add must not run concurrently with anything.
class AppearanceIndex {
 public:
  // REQUIRES: vocabulary != nullptr, else throws Error(kInvalidArgument).
  explicit AppearanceIndex(std::shared_ptr<const AppearanceVocabulary> vocabulary);

  // Indexes `node` with the descriptors of its landmarks. Adding an id that is already indexed
  // replaces its previous bag of words (the node's landmarks were re-estimated); the index never
  // holds two bags for one id. A node without descriptors is indexed (it counts in N) but
  // matches nothing.
  // REQUIRES: fewer than 2^31 nodes and descriptors per node, else throws Error(kInvalidArgument).
  void Add(const Uuid& node, std::span<const Descriptor256> descriptors);

  // The best min(k, size()) nodes for a frame with `descriptors`, by descending score, equal
  // scores by ascending Uuid. Excludes nothing: nodes sharing no weighted word with the query
  // (and all nodes, for an empty query) score 0 and fill the tail in Uuid order. Empty when the
  // index is empty or k == 0.
  // REQUIRES: k >= 0, else throws Error(kInvalidArgument).
  std::vector<AppearanceMatch> Query(std::span<const Descriptor256> descriptors, int k) const;

  std::size_t size() const { return documents_.size(); }
  const AppearanceVocabulary& vocabulary() const { return *vocabulary_; }

 private:
  struct Posting {
    std::uint32_t document = 0;
    std::uint32_t count = 0;  // n_di
  };
  struct Document {
    Uuid node;
    std::vector<WordCount> words;  // by ascending word, counts > 0
    int descriptors = 0;           // D_d
  };
  // ln(n) for n <= size(), from a table grown by Add (the hot loops call no std::log).
  double Log(std::size_t n) const { return log_table_[n]; }
  void GrowLogTable(std::size_t n);
  void Post(std::uint32_t document);
  void Unpost(std::uint32_t document);

  std::shared_ptr<const AppearanceVocabulary> vocabulary_;
  std::vector<Document> documents_;
  // S_d = sum_i n_di ln n_i by document, kept current by Add. Apart from Document and dense
  // (8 bytes a node, so it stays in cache): Add updates it for every posting of its words.
  std::vector<double> count_log_sums_;
  std::map<Uuid, std::uint32_t> document_of_;   // ordered: fills zero-score tails by Uuid
  std::vector<std::vector<Posting>> postings_;  // by word
  std::vector<double> log_table_{0.0, 0.0};     // log_table_[n] = ln n; [0] unused
};

}  // namespace fleetmap
