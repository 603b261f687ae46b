#include "fleetmap/ranking/path_ranking.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <limits>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// The hot loops of ranking: over the members of W, Z_ij is the popcount of the candidate's
// and j's compact path sets. Built twice so CPUs with the POPCNT instruction use it (GCC
// picks the clone at load time); four partial sums, since one chain of dependent additions
// would bound the loop by floating-point latency.
//
// Σ_j table[Z_ij + offset] when kAscending, Σ_j table[offset − Z_ij] otherwise. Always
// inlined, so each clone below compiles it for its own instruction set.
template <bool kAscending>
[[gnu::always_inline]] inline double SumOverMembersImpl(const std::uint64_t* candidate,
                                                        const std::uint64_t* members,
                                                        std::size_t count, std::size_t words,
                                                        const double* table, int offset) {
  const auto at = [&](int z) { return table[kAscending ? offset + z : offset - z]; };
  double s0 = 0.0, s1 = 0.0, s2 = 0.0, s3 = 0.0;
  std::size_t j = 0;
  if (words == 1) {
    const std::uint64_t bits = candidate[0];
    for (; j + 4 <= count; j += 4) {
      s0 += at(std::popcount(bits & members[j]));
      s1 += at(std::popcount(bits & members[j + 1]));
      s2 += at(std::popcount(bits & members[j + 2]));
      s3 += at(std::popcount(bits & members[j + 3]));
    }
    for (; j < count; ++j) s0 += at(std::popcount(bits & members[j]));
  } else {
    for (; j < count; ++j) {
      const std::uint64_t* row = members + j * words;
      int z = 0;
      for (std::size_t k = 0; k < words; ++k) z += std::popcount(candidate[k] & row[k]);
      s0 += at(z);
    }
  }
  return (s0 + s1) + (s2 + s3);
}

__attribute__((target_clones("popcnt", "default"))) double SumLogZPlusOne(
    const std::uint64_t* candidate, const std::uint64_t* members, std::size_t count,
    std::size_t words, const double* log) {
  return SumOverMembersImpl<true>(candidate, members, count, words, log, 1);
}

__attribute__((target_clones("popcnt", "default"))) double SumLogRestMinusZ(
    const std::uint64_t* candidate, const std::uint64_t* members, std::size_t count,
    std::size_t words, const double* log, int rest) {
  return SumOverMembersImpl<false>(candidate, members, count, words, log, rest);
}

// Sets the bits of ascending `paths` in `bits` (`words` words, already zero). A single word
// is built in a register: OR-ing into memory chains every bit through a store and a load.
void SetBits(std::span<const PathMemory::PathIndex> paths, std::uint64_t* bits, std::size_t words) {
  if (words == 1) {
    std::uint64_t word = 0;
    for (const PathMemory::PathIndex path : paths) word |= std::uint64_t{1} << path;
    bits[0] = word;
    return;
  }
  for (const PathMemory::PathIndex path : paths) bits[path / 64] |= std::uint64_t{1} << (path % 64);
}

}  // namespace

PathRanking::PathRanking(PathMemory memory, const PathRankingOptions& options)
    : memory_(std::move(memory)), options_(options) {
  if (options_.window_iterations < 0) {
    throw Error(ErrorCode::kInvalidArgument, "PathRanking: window_iterations must be >= 0");
  }
}

double PathRanking::Log(int n) {
  // log of small integers, cached: the posterior needs log D, log(Z + 1) and log(D - 1 - Z)
  // for every candidate, all at most D. Entry 0 is log 0 = −∞ (the table is indexed directly).
  if (n < 0) return -std::numeric_limits<double>::infinity();
  if (static_cast<std::size_t>(n) >= log_table_.size()) {
    const std::size_t old_size = log_table_.size();
    log_table_.resize(std::max<std::size_t>(static_cast<std::size_t>(n) + 1, 2 * old_size));
    for (std::size_t i = old_size; i < log_table_.size(); ++i) {
      log_table_[i] = std::log(static_cast<double>(i));  // std::log(0) is −∞
    }
  }
  return log_table_[static_cast<std::size_t>(n)];
}

void PathRanking::Prepare(std::optional<PathMemory::NodeIndex> reference) {
  for (const PathMemory::PathIndex path : touching_) local_of_path_[path] = -1;
  touching_.clear();
  // W's members on paths, successes first; members on no path only count.
  observed_nodes_.clear();
  failed_nodes_.clear();
  observed_count_ = static_cast<int>(observed_.size());
  off_path_failures_ = 0;
  for (const Observation& observation : observed_) {
    if (observation.node) {
      (observation.success ? observed_nodes_ : failed_nodes_).push_back(*observation.node);
    } else if (!observation.success) {
      ++off_path_failures_;
    }
  }
  successes_ = static_cast<int>(observed_nodes_.size());
  observed_nodes_.insert(observed_nodes_.end(), failed_nodes_.begin(), failed_nodes_.end());

  // Path sets as bitsets, and how many members each path holds: S_i = Σ_j Z_ij =
  // Σ_{p ∋ i} |W ∩ p|. With few paths in memory a set is a bitset over all of them, built in
  // one pass; with many, only the paths that touch W get a bit (no other path can link a
  // candidate to a member of W), which keeps the sets short.
  const std::size_t paths = memory_.path_count();
  if (local_of_path_.size() < paths) local_of_path_.resize(paths, -1);
  members_on_path_.clear();
  direct_ = paths <= kDirectBitsetPaths;
  if (direct_) {
    words_ = std::max<std::size_t>(1, (paths + 63) / 64);
    members_on_path_.assign(paths, 0);
    observed_bits_.assign(observed_nodes_.size() * words_, 0);
    for (std::size_t row = 0; row < observed_nodes_.size(); ++row) {
      const std::span<const PathMemory::PathIndex> member_paths =
          memory_.PathsThrough(observed_nodes_[row]);
      for (const PathMemory::PathIndex path : member_paths) ++members_on_path_[path];
      SetBits(member_paths, observed_bits_.data() + row * words_, words_);
    }
  } else {
    for (const PathMemory::NodeIndex node : observed_nodes_) {
      for (const PathMemory::PathIndex path : memory_.PathsThrough(node)) {
        int& local = local_of_path_[path];
        if (local < 0) {
          local = static_cast<int>(touching_.size());
          touching_.push_back(path);
          members_on_path_.push_back(0);
        }
        ++members_on_path_[static_cast<std::size_t>(local)];
      }
    }
    words_ = std::max<std::size_t>(1, (touching_.size() + 63) / 64);
    observed_bits_.assign(observed_nodes_.size() * words_, 0);
    for (std::size_t row = 0; row < observed_nodes_.size(); ++row) {
      std::uint64_t* bits = observed_bits_.data() + row * words_;
      for (const PathMemory::PathIndex path : memory_.PathsThrough(observed_nodes_[row])) {
        const auto bit = static_cast<std::size_t>(local_of_path_[path]);
        bits[bit / 64] |= std::uint64_t{1} << (bit % 64);
      }
    }
  }
  candidate_bits_.assign(words_, 0);
  // With bitsets over every path, N_ik is a popcount too.
  reference_bits_.assign(words_, 0);
  if (direct_ && reference) {
    SetBits(memory_.PathsThrough(*reference), reference_bits_.data(), words_);
  }
}

double PathRanking::Score(std::optional<PathMemory::NodeIndex> reference, const Uuid& candidate) {
  // Memory cannot change between Prepare and Score (path edges arrive between iterations),
  // so every path of the candidate has its bit.
  const std::optional<PathMemory::NodeIndex> node = memory_.Find(candidate);

  // The candidate's path set as a bitset (see Prepare) and S_i.
  std::fill(candidate_bits_.begin(), candidate_bits_.end(), 0);
  int s_i = 0;
  if (node && direct_) {
    const std::span<const PathMemory::PathIndex> paths = memory_.PathsThrough(*node);
    for (const PathMemory::PathIndex path : paths) s_i += members_on_path_[path];
    SetBits(paths, candidate_bits_.data(), words_);
  } else if (node) {
    for (const PathMemory::PathIndex path : memory_.PathsThrough(*node)) {
      if (path >= local_of_path_.size() || local_of_path_[path] < 0) continue;
      const auto bit = static_cast<std::size_t>(local_of_path_[path]);
      candidate_bits_[bit / 64] |= std::uint64_t{1} << (bit % 64);
      s_i += members_on_path_[bit];
    }
  }

  // Prior (Eq. 8), dropping the normaliser Σ_x (N_xk + γ) which all candidates share.
  int n_ik = 0;
  if (reference && node) {
    if (direct_) {
      for (std::size_t k = 0; k < words_; ++k) {
        n_ik += std::popcount(candidate_bits_[k] & reference_bits_[k]);
      }
    } else {
      n_ik = memory_.SharedPaths(*node, *reference);
    }
  }
  double score = Log(n_ik + 1);
  const int w = observed_count_;
  if (w == 0) return score;

  // Eqs. 5–6 with α = 1: θ_ij = (Z_ij + 1) / D, D = |W| + S_i. Summing log θ over successes
  // and log(1 − θ) = log(D − 1 − Z_ij) − log D over failures gives −|W| log D plus the
  // per-member terms. log(0) = −∞ is θ = 1 for a failure: that candidate cannot explain it.
  const int d = w + s_i;
  Log(d);  // grows the table to cover every index used below
  const double* log = log_table_.data();
  const auto successes = static_cast<std::size_t>(successes_);
  const std::size_t failures = observed_nodes_.size() - successes;
  score -= w * log[d];
  score += SumLogZPlusOne(candidate_bits_.data(), observed_bits_.data(), successes, words_, log);
  score += SumLogRestMinusZ(candidate_bits_.data(), observed_bits_.data() + successes * words_,
                            failures, words_, log, d - 1);
  if (off_path_failures_ > 0) score += off_path_failures_ * log[d - 1];
  return score;
}

double PathRanking::LogPosterior(const Uuid& reference, const Uuid& candidate) {
  const std::optional<PathMemory::NodeIndex> reference_node = memory_.Find(reference);
  Prepare(reference_node);
  return Score(reference_node, candidate);
}

void PathRanking::Rank(const Uuid& reference, std::vector<Candidate>& candidates) {
  const std::optional<PathMemory::NodeIndex> reference_node = memory_.Find(reference);
  Prepare(reference_node);
  std::vector<std::pair<double, std::size_t>> scored;
  scored.reserve(candidates.size());
  // While W holds failures only (the robot is lost, or on ground its paths never covered),
  // the posterior of seed 002 eq. 8 can only say which candidates are *not* on the failed
  // members' paths; with the neighbourhood widened by the estimate's uncertainty that favours
  // far candidates no path vouches for. Rank by distance to the estimate until one succeeds.
  const bool lost = successes_ == 0 && observed_count_ > 0;
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    scored.emplace_back(
        lost ? -candidates[i].distance_m : Score(reference_node, candidates[i].node), i);
  }
  std::sort(scored.begin(), scored.end(), [&](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first > b.first;
    const Candidate& ca = candidates[a.second];
    const Candidate& cb = candidates[b.second];
    return ca.distance_m != cb.distance_m ? ca.distance_m < cb.distance_m : ca.node < cb.node;
  });
  std::vector<Candidate> ranked;
  ranked.reserve(candidates.size());
  for (const auto& [score, index] : scored) ranked.push_back(candidates[index]);
  candidates = std::move(ranked);
}

void PathRanking::Observe(const LocalisationAttempt& attempt) {
  const auto [it, inserted] = slot_of_.try_emplace(attempt.node, observed_.size());
  if (inserted) observed_.push_back({attempt.node, memory_.Find(attempt.node)});
  Observation& observation = observed_[it->second];
  ++observation.occurrences;
  observation.success = attempt.success;
}

void PathRanking::Forget(const Uuid& node) {
  const auto it = slot_of_.find(node);
  if (it == slot_of_.end()) return;
  const std::size_t slot = it->second;
  if (--observed_[slot].occurrences > 0) return;
  // Swap-remove: the last member takes the freed slot.
  if (slot + 1 != observed_.size()) {
    observed_[slot] = std::move(observed_.back());
    slot_of_[observed_[slot].id] = slot;
  }
  observed_.pop_back();
  slot_of_.erase(it);
}

void PathRanking::ObserveIteration(std::span<const LocalisationAttempt> attempts) {
  if (options_.window_iterations == 0) return;
  window_.emplace_back(attempts.begin(), attempts.end());
  for (const LocalisationAttempt& attempt : window_.back()) Observe(attempt);
  if (static_cast<int>(window_.size()) > options_.window_iterations) {
    for (const LocalisationAttempt& attempt : window_.front()) Forget(attempt.node);
    window_.pop_front();
  }
}

void PathRanking::ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) {
  memory_.AddPathEdge(path, from, to);
  // A member of W that just joined its first path counts on it from the next Rank.
  for (const Uuid& node : {from, to}) {
    const auto it = slot_of_.find(node);
    if (it == slot_of_.end()) continue;
    Observation& observation = observed_[it->second];
    if (!observation.node) observation.node = memory_.Find(node);
  }
}

void PathRanking::StartOuting() {
  window_.clear();
  observed_.clear();
  slot_of_.clear();
}

}  // namespace fleetmap
