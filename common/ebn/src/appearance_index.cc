#include "fleetmap/ebn/appearance_index.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <deque>
#include <limits>
#include <numeric>
#include <random>
#include <string>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/hamming.h"

namespace fleetmap {
namespace {

// FindHammingNeighbours takes sizes below 2^31; so do the indexes here.
constexpr std::size_t kMaxCount = std::numeric_limits<int>::max();

// Uniform draw from [0, n) by rejection, as in localiser.cc: the standard distributions are not
// specified exactly, so they could give another vocabulary on another standard library.
std::uint64_t DrawBelow(std::mt19937_64& rng, std::uint64_t n) {
  constexpr std::uint64_t kMax = std::numeric_limits<std::uint64_t>::max();
  const std::uint64_t limit = kMax - kMax % n;
  std::uint64_t r = 0;
  do {
    r = rng();
  } while (r >= limit);
  return r % n;
}

// Index of each member's nearest centre, ties to the lower index: the rule WordOf descends by,
// so the training partition is the one the tree later reproduces.
std::vector<int> Assign(const std::vector<Descriptor256>& members,
                        const std::vector<Descriptor256>& centres) {
  const HammingNeighbours neighbours = FindHammingNeighbours(members, centres);
  std::vector<int> assignment(members.size());
  for (std::size_t i = 0; i < members.size(); ++i) {
    assignment[i] = neighbours.per_query[i].best.index;
  }
  return assignment;
}

// The bitwise majority of each cluster: the median of binary descriptors. A bit set in exactly
// half of a cluster stays 0, as the DBoW2 paper truncates non-binary medians. Clusters without
// members are dropped.
std::vector<Descriptor256> MajorityCentres(const std::vector<Descriptor256>& members,
                                           const std::vector<int>& assignment, std::size_t k) {
  std::vector<std::array<int, 256>> ones(k, std::array<int, 256>{});
  std::vector<int> sizes(k, 0);
  for (std::size_t i = 0; i < members.size(); ++i) {
    const auto c = static_cast<std::size_t>(assignment[i]);
    ++sizes[c];
    for (std::size_t byte = 0; byte < 32; ++byte) {
      for (std::size_t bit = 0; bit < 8; ++bit) {
        ones[c][byte * 8 + bit] += (members[i][byte] >> bit) & 1;
      }
    }
  }
  std::vector<Descriptor256> centres;
  for (std::size_t c = 0; c < k; ++c) {
    if (sizes[c] == 0) continue;
    Descriptor256 centre{};
    for (std::size_t byte = 0; byte < 32; ++byte) {
      for (std::size_t bit = 0; bit < 8; ++bit) {
        if (2 * ones[c][byte * 8 + bit] > sizes[c]) {
          centre[byte] = static_cast<std::uint8_t>(centre[byte] | (1u << bit));
        }
      }
    }
    centres.push_back(centre);
  }
  return centres;
}

// k-means++ seeds (Arthur and Vassilvitskii; DBoW2 seeds the same way): each next seed is drawn
// with probability proportional to its squared distance to the nearest seed so far. Seeds are
// distinct members, so fewer than k come back when the members hold fewer distinct values.
std::vector<Descriptor256> SeedCentres(const std::vector<Descriptor256>& members, int k,
                                       std::mt19937_64& rng) {
  std::vector<Descriptor256> centres{members[DrawBelow(rng, members.size())]};
  std::vector<std::uint64_t> squared(members.size());
  for (std::size_t i = 0; i < members.size(); ++i) {
    const auto d = static_cast<std::uint64_t>(HammingDistance(members[i], centres[0]));
    squared[i] = d * d;
  }
  while (static_cast<int>(centres.size()) < k) {
    std::uint64_t total = 0;  // < 2^31 * 256^2, no overflow
    for (std::uint64_t s : squared) total += s;
    if (total == 0) break;  // every member equals a seed
    std::uint64_t r = DrawBelow(rng, total);
    std::size_t chosen = 0;
    while (r >= squared[chosen]) r -= squared[chosen++];
    centres.push_back(members[chosen]);
    for (std::size_t i = 0; i < members.size(); ++i) {
      const auto d = static_cast<std::uint64_t>(HammingDistance(members[i], centres.back()));
      squared[i] = std::min(squared[i], d * d);
    }
  }
  return centres;
}

struct Cluster {
  Descriptor256 centre;
  std::vector<Descriptor256> members;
};

// One clustering step of the tree: k-majority over `members` (DBoW2 paper §IV). Every returned
// cluster has members.
std::vector<Cluster> KMajority(const std::vector<Descriptor256>& members,
                               const VocabularyOptions& options, std::mt19937_64& rng) {
  std::vector<Descriptor256> centres = SeedCentres(members, options.branching, rng);
  std::vector<int> assignment = Assign(members, centres);
  for (int iteration = 0; iteration < options.kmajority_iterations; ++iteration) {
    centres = MajorityCentres(members, assignment, centres.size());
    std::vector<int> next = Assign(members, centres);
    const bool settled = next == assignment;
    assignment = std::move(next);
    if (settled) break;
  }

  std::vector<Cluster> clusters(centres.size());
  for (std::size_t c = 0; c < centres.size(); ++c) clusters[c].centre = centres[c];
  for (std::size_t i = 0; i < members.size(); ++i) {
    clusters[static_cast<std::size_t>(assignment[i])].members.push_back(members[i]);
  }
  // A centre no member chose was nobody's nearest, so dropping it changes no assignment.
  std::erase_if(clusters, [](const Cluster& c) { return c.members.empty(); });
  return clusters;
}

}  // namespace

AppearanceVocabulary AppearanceVocabulary::Train(std::span<const Descriptor256> sample,
                                                 const VocabularyOptions& options) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "appearance vocabulary: " + what);
  };
  if (options.branching < 2) fail("branching must be >= 2");
  if (options.depth < 1) fail("depth must be >= 1");
  if (options.kmajority_iterations < 0) fail("kmajority_iterations must be >= 0");
  if (sample.empty()) fail("the training sample is empty");
  if (sample.size() > kMaxCount) fail("the training sample has 2^31 or more descriptors");

  AppearanceVocabulary vocabulary;
  vocabulary.options_ = options;
  vocabulary.nodes_.emplace_back();
  vocabulary.centres_.emplace_back();

  // Breadth first, with one generator drawn in a fixed order, so the tree is a function of the
  // sample and the options alone; children of a node are stored contiguously.
  struct Pending {
    int node;
    int level;
    std::vector<Descriptor256> members;
  };
  std::deque<Pending> pending;
  pending.push_back({0, 0, std::vector<Descriptor256>(sample.begin(), sample.end())});
  std::mt19937_64 rng(options.seed);
  while (!pending.empty()) {
    Pending cell = std::move(pending.front());
    pending.pop_front();
    std::vector<Cluster> clusters;
    if (cell.level < options.depth) clusters = KMajority(cell.members, options, rng);
    if (clusters.size() <= 1) {  // at full depth, or a single distinct descriptor
      vocabulary.nodes_[static_cast<std::size_t>(cell.node)].word = vocabulary.word_count_++;
      continue;
    }
    const auto first_child = static_cast<int>(vocabulary.nodes_.size());
    vocabulary.nodes_[static_cast<std::size_t>(cell.node)].first_child = first_child;
    vocabulary.nodes_[static_cast<std::size_t>(cell.node)].child_count =
        static_cast<int>(clusters.size());
    for (std::size_t c = 0; c < clusters.size(); ++c) {
      vocabulary.nodes_.emplace_back();
      vocabulary.centres_.push_back(clusters[c].centre);
      pending.push_back(
          {first_child + static_cast<int>(c), cell.level + 1, std::move(clusters[c].members)});
    }
  }
  return vocabulary;
}

std::uint32_t AppearanceVocabulary::Descend(std::uint32_t node, const Descriptor256& d) const {
  const auto first = static_cast<std::size_t>(nodes_[node].first_child);
  const std::size_t end = first + static_cast<std::size_t>(nodes_[node].child_count);
  std::size_t best = first;
  int best_distance = HammingDistance(d, centres_[first]);
  for (std::size_t child = first + 1; child < end; ++child) {
    const int distance = HammingDistance(d, centres_[child]);
    if (distance < best_distance) {  // strict: ties to the first child, as in training
      best_distance = distance;
      best = child;
    }
  }
  return static_cast<std::uint32_t>(best);
}

int AppearanceVocabulary::WordOf(const Descriptor256& d) const {
  std::uint32_t node = 0;
  while (nodes_[node].child_count > 0) node = Descend(node, d);
  return nodes_[node].word;
}

std::vector<int> AppearanceVocabulary::WordsOf(std::span<const Descriptor256> descriptors) const {
  // Below this many descriptors at one tree node, a call of FindHammingNeighbours costs more
  // than the scalar distances (it allocates its results and splits the children for SIMD).
  constexpr std::size_t kMinBatch = 3;

  // The descriptors at one tree node: positions [begin, end) of `order`. Each level splits a
  // group by nearest child with a counting sort, so grouping costs O(n) a level.
  struct Group {
    std::uint32_t node;
    std::size_t begin;
    std::size_t end;
  };
  std::vector<std::uint32_t> order(descriptors.size());
  std::iota(order.begin(), order.end(), 0);
  std::vector<std::uint32_t> child(descriptors.size());  // by position in `order`
  std::vector<std::uint32_t> scratch(descriptors.size());
  std::vector<std::size_t> child_start;
  std::vector<Descriptor256> batch;
  std::vector<Group> groups;
  if (!descriptors.empty()) groups.push_back({0, 0, descriptors.size()});
  std::vector<Group> next;
  std::vector<int> words(descriptors.size());
  while (!groups.empty()) {
    next.clear();
    for (const Group& g : groups) {
      const TreeNode& parent = nodes_[g.node];
      if (parent.child_count == 0) {
        for (std::size_t k = g.begin; k < g.end; ++k) words[order[k]] = parent.word;
        continue;
      }
      const auto first = static_cast<std::uint32_t>(parent.first_child);
      const auto count = static_cast<std::size_t>(parent.child_count);
      if (g.end - g.begin < kMinBatch) {
        for (std::size_t k = g.begin; k < g.end; ++k) {
          child[k] = Descend(g.node, descriptors[order[k]]) - first;
        }
      } else {
        batch.clear();
        for (std::size_t k = g.begin; k < g.end; ++k) batch.push_back(descriptors[order[k]]);
        const HammingNeighbours nearest =
            FindHammingNeighbours(batch, std::span(centres_).subspan(first, count));
        for (std::size_t k = g.begin; k < g.end; ++k) {
          child[k] = static_cast<std::uint32_t>(nearest.per_query[k - g.begin].best.index);
        }
      }
      child_start.assign(count + 1, 0);
      for (std::size_t k = g.begin; k < g.end; ++k) ++child_start[child[k] + 1];
      for (std::size_t c = 0; c < count; ++c) child_start[c + 1] += child_start[c];
      for (std::size_t c = 0; c < count; ++c) {
        if (child_start[c + 1] > child_start[c]) {
          next.push_back({first + static_cast<std::uint32_t>(c), g.begin + child_start[c],
                          g.begin + child_start[c + 1]});
        }
      }
      for (std::size_t k = g.begin; k < g.end; ++k) {
        scratch[g.begin + child_start[child[k]]++] = order[k];
      }
      std::copy(scratch.begin() + static_cast<std::ptrdiff_t>(g.begin),
                scratch.begin() + static_cast<std::ptrdiff_t>(g.end),
                order.begin() + static_cast<std::ptrdiff_t>(g.begin));
    }
    std::swap(groups, next);
  }
  return words;
}

AppearanceIndex::AppearanceIndex(std::shared_ptr<const AppearanceVocabulary> vocabulary)
    : vocabulary_(std::move(vocabulary)) {
  if (vocabulary_ == nullptr) {
    throw Error(ErrorCode::kInvalidArgument, "appearance index: the vocabulary is null");
  }
  postings_.resize(static_cast<std::size_t>(vocabulary_->word_count()));
}

std::vector<WordCount> BagOfWords(const AppearanceVocabulary& vocabulary,
                                  std::span<const Descriptor256> descriptors) {
  std::vector<int> words = vocabulary.WordsOf(descriptors);
  std::sort(words.begin(), words.end());
  std::vector<WordCount> bag;
  for (const int word : words) {
    if (bag.empty() || bag.back().word != word) bag.push_back({word, 0});
    ++bag.back().count;
  }
  return bag;
}

void AppearanceIndex::GrowLogTable(std::size_t n) {
  while (log_table_.size() <= n) {
    log_table_.push_back(std::log(static_cast<double>(log_table_.size())));
  }
}

// Posts `document`'s words. Each word's node count n rises to n + 1, which changes
// S_e = sum n_ei ln n_i of every node e already posted under it by n_ei (ln(n + 1) - ln n).
// This loop is most of the cost of Add.
// REQUIRES: the document is not posted; the log table reaches size().
void AppearanceIndex::Post(std::uint32_t document) {
  double count_log_sum = 0.0;
  for (const WordCount& wc : documents_[document].words) {
    std::vector<Posting>& list = postings_[static_cast<std::size_t>(wc.word)];
    const std::size_t n = list.size();
    if (n > 0) {
      const double delta = Log(n + 1) - Log(n);
      for (const Posting& p : list) count_log_sums_[p.document] += p.count * delta;
    }
    list.push_back({document, static_cast<std::uint32_t>(wc.count)});
    count_log_sum += wc.count * Log(n + 1);
  }
  count_log_sums_[document] = count_log_sum;
}

// The inverse of Post: n falls to n - 1 for each of `document`'s words. One pass per list both
// drops the document's posting (keeping the others in order) and updates the rest.
// REQUIRES: the document is posted.
void AppearanceIndex::Unpost(std::uint32_t document) {
  for (const WordCount& wc : documents_[document].words) {
    std::vector<Posting>& list = postings_[static_cast<std::size_t>(wc.word)];
    const std::size_t n = list.size() - 1;  // after removal
    const double delta = n > 0 ? Log(n) - Log(n + 1) : 0.0;
    auto kept = list.begin();
    for (const Posting& p : list) {
      if (p.document == document) continue;
      count_log_sums_[p.document] += p.count * delta;
      *kept++ = p;
    }
    list.erase(kept, list.end());
  }
  count_log_sums_[document] = 0.0;
}

void AppearanceIndex::Add(const Uuid& node, std::span<const Descriptor256> descriptors) {
  if (descriptors.size() > kMaxCount) {
    throw Error(ErrorCode::kInvalidArgument,
                "appearance index: node " + node.ToString() + " has 2^31 or more descriptors");
  }
  // Quantise before touching the index, so nothing is half-done if this throws.
  std::vector<WordCount> bag = BagOfWords(*vocabulary_, descriptors);

  const auto found = document_of_.find(node);
  std::uint32_t document = 0;
  if (found != document_of_.end()) {
    document = found->second;
    Unpost(document);
  } else {
    if (documents_.size() >= kMaxCount) {
      throw Error(ErrorCode::kInvalidArgument, "appearance index: 2^31 nodes already indexed");
    }
    document = static_cast<std::uint32_t>(documents_.size());
    GrowLogTable(documents_.size() + 1);
    documents_.push_back({node, {}, 0});
    count_log_sums_.push_back(0.0);
    document_of_.emplace(node, document);
  }
  documents_[document].words = std::move(bag);
  documents_[document].descriptors = static_cast<int>(descriptors.size());
  Post(document);
}

std::vector<AppearanceMatch> AppearanceIndex::Query(std::span<const Descriptor256> descriptors,
                                                    int k) const {
  if (k < 0) throw Error(ErrorCode::kInvalidArgument, "appearance query: k must be >= 0");
  const std::size_t wanted = std::min(static_cast<std::size_t>(k), documents_.size());
  std::vector<AppearanceMatch> matches;
  if (wanted == 0) return matches;

  // The query's tf-idf weights, L1-normalised. A word no node holds weighs as the rarest
  // indexed word (n = 1): it cannot be shared, but it must still dilute the shared ones, or a
  // frame of mostly unseen words would match whatever little it shares.
  const std::vector<WordCount> bag = BagOfWords(*vocabulary_, descriptors);
  const double log_n = Log(documents_.size());
  std::vector<double> idf(bag.size());
  double query_norm = 0.0;
  for (std::size_t i = 0; i < bag.size(); ++i) {
    const std::size_t n = postings_[static_cast<std::size_t>(bag[i].word)].size();
    idf[i] = log_n - Log(std::max<std::size_t>(n, 1));
    query_norm += bag[i].count * idf[i];
  }

  // Score through the inverted file: s = sum over shared words of min(v_i, w_i). A node's
  // normaliser Z_d = D_d ln N - S_d is computed when one of its postings is first read. The
  // accumulator array is zeroed in O(N), a memset that is small beside reading the postings.
  struct Accumulator {
    double score = 0.0;
    double inverse_norm = 0.0;  // 1 / Z_d, 0 until the node is first touched
  };
  std::vector<Accumulator> accumulators(documents_.size());
  std::vector<std::uint32_t> touched;
  if (query_norm > 0.0) {
    for (std::size_t i = 0; i < bag.size(); ++i) {
      if (idf[i] <= 0.0) continue;  // held by every node (or unseen with N = 1): weighs nothing
      const double query_weight = bag[i].count * idf[i] / query_norm;
      for (const Posting& p : postings_[static_cast<std::size_t>(bag[i].word)]) {
        Accumulator& a = accumulators[p.document];
        if (a.inverse_norm == 0.0) {
          // Z_d >= n_di idf_i > 0 for this posting, up to rounding; the min below caps any excess.
          const double norm =
              documents_[p.document].descriptors * log_n - count_log_sums_[p.document];
          a.inverse_norm = 1.0 / std::max(norm, std::numeric_limits<double>::min());
          touched.push_back(p.document);
        }
        a.score += std::min(query_weight, std::min(1.0, p.count * idf[i] * a.inverse_norm));
      }
    }
  }

  const auto better = [&](std::uint32_t a, std::uint32_t b) {
    const double sa = accumulators[a].score, sb = accumulators[b].score;
    if (sa != sb) return sa > sb;
    return documents_[a].node < documents_[b].node;
  };
  const std::size_t ranked = std::min(wanted, touched.size());
  std::partial_sort(touched.begin(), touched.begin() + static_cast<std::ptrdiff_t>(ranked),
                    touched.end(), better);
  for (std::size_t i = 0; i < ranked; ++i) {
    const std::uint32_t d = touched[i];
    matches.push_back({documents_[d].node, std::clamp(accumulators[d].score, 0.0, 1.0)});
  }
  // Every touched node scored > 0; the untouched ones tie at 0 and follow in Uuid order.
  for (auto it = document_of_.begin(); matches.size() < wanted && it != document_of_.end(); ++it) {
    if (accumulators[it->second].inverse_norm == 0.0) matches.push_back({it->first, 0.0});
  }
  return matches;
}

}  // namespace fleetmap
