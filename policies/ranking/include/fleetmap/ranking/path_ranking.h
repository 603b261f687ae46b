// Γ(path): ranks candidate nodes by the posterior probability that each localises the live
// frame, learned from path memory (seed 002 §V, Eqs. 5–9).
//
//   score_i = log π_i + log p(Z | y = i)                                        (Eq. 9)
//   π_i ∝ N_ik + γ, γ = 1, N_ik = paths linking n_k and candidate i              (Eq. 8)
//   θ_ij = (Z_ij + α) / Σ_x (Z_ix + α), α = 1, Z_ij = paths linking i and W_j    (Eq. 5)
//   p(Z | y = i) = Π_j θ_ij^z_j (1 − θ_ij)^(1 − z_j)                            (Eq. 6)
//
// W is every node attempted in the last T localiser iterations with its latest outcome z_j
// (§V-A). Everything is in log space: with |W| in the hundreds the products underflow.
//
// With D = Σ_x (Z_ix + 1) = |W| + Σ_x Z_ix, the log posterior reduces to
//   log(N_ik + 1) − |W| log D + Σ_{z_j=1} log(Z_ij + 1) + Σ_{z_j=0} log(D − 1 − Z_ij)
// (up to a constant shared by all candidates), which depends on the candidate only through
// the histogram of Z_ij over W's successes and failures.
//
// Cost: path memory keeps each node's paths incrementally (PathMemory) and W is kept
// incrementally as iterations enter and leave the window. Once per Rank call W's path sets
// become bitsets: over every path while memory holds at most 256, else over only the paths
// that touch W (no other path can link a candidate to a member of W). Each candidate then
// costs one AND + popcount per member of W and word: O(|Y| |W| ⌈K / 64⌉).
#pragma once

#include <cstdint>
#include <deque>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "fleetmap/ebn/ranking_policy.h"
#include "fleetmap/ranking/path_memory.h"

namespace fleetmap {

struct PathRankingOptions {
  int window_iterations = 10;  // T: localiser iterations remembered in W, >= 0 (0: prior only)
};

class PathRanking final : public RankingPolicy {
 public:
  // Throws Error(kInvalidArgument) for options out of range.
  PathRanking(PathMemory memory, const PathRankingOptions& options = {});

  std::string name() const override { return "path"; }
  // Descending posterior; ties by distance, then UUID.
  void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override;
  void ObserveIteration(std::span<const LocalisationAttempt> attempts) override;
  void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) override;
  void StartOuting() override;

  // log π_i + log p(Z | y = i) up to a constant shared by all candidates; what Rank sorts by.
  // Exposed for tests that check the equations by hand.
  double LogPosterior(const Uuid& reference, const Uuid& candidate);

  const PathMemory& memory() const { return memory_; }
  std::size_t observation_count() const { return observed_.size(); }

 private:
  // A member of W. Kept in a dense vector so ranking walks W without hashing.
  struct Observation {
    Uuid id;
    std::optional<PathMemory::NodeIndex> node;  // in path memory; none while on no path
    bool success = false;                       // the latest outcome z_j
    int occurrences = 0;                        // attempts on this node still inside the window
  };

  void Observe(const LocalisationAttempt& attempt);
  void Forget(const Uuid& node);
  // W's path sets as bitsets, S_i's per-path counts and n_k's bits (see the cost note).
  void Prepare(std::optional<PathMemory::NodeIndex> reference);
  double Score(std::optional<PathMemory::NodeIndex> reference, const Uuid& candidate);
  double Log(int n);

  PathMemory memory_;
  PathRankingOptions options_;

  std::deque<std::vector<LocalisationAttempt>> window_;  // last T iterations, oldest first
  std::vector<Observation> observed_;                    // W
  std::unordered_map<Uuid, std::size_t> slot_of_;        // W member -> index in observed_

  // Scratch of Prepare / Score, kept to avoid allocation per call.
  std::vector<int> local_of_path_;               // path index -> bit in the compact sets, or -1
  std::vector<PathMemory::PathIndex> touching_;  // paths with local_of_path_ set
  std::vector<PathMemory::NodeIndex> observed_nodes_;  // W's members on paths, successes first
  int observed_count_ = 0;                             // |W|, members on no path included
  int successes_ = 0;                                  // leading successes in observed_nodes_
  int off_path_failures_ = 0;  // failed members of W on no path (Z_ij = 0 for every i)
  bool direct_ = true;         // bits stand for every path, not only those touching W
  std::size_t words_ = 1;      // 64-bit words per compact set
  std::vector<std::uint64_t> observed_bits_;  // |W| × words_, W's compact path sets
  std::vector<PathMemory::NodeIndex> failed_nodes_;
  // Up to this many paths in memory, path sets are bitsets over every path; beyond, over the
  // paths touching W only.
  static constexpr std::size_t kDirectBitsetPaths = 256;
  std::vector<int> members_on_path_;  // by bit: |W ∩ p|
  std::vector<std::uint64_t> candidate_bits_;
  std::vector<std::uint64_t> reference_bits_;  // n_k's paths, with bitsets over every path
  std::vector<double> log_table_;
};

}  // namespace fleetmap
