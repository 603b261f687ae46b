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
// Cost: the observation window is kept incrementally, as lists of the W members on each path,
// updated when an iteration enters or leaves the window or a path edge is added. Ranking then
// touches, per candidate, only the W members that share a path with it:
// O(Σ_i Σ_{p ∋ i} |W ∩ p|), independent of how many paths avoid the window.
#pragma once

#include <deque>
#include <unordered_map>
#include <vector>

#include "fleetmap/common/ranking_policy.h"
#include "fleetmap/policies/path_memory.h"

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
  struct Observation {
    int slot = 0;          // dense index into z_ and counts_
    int occurrences = 0;   // attempts on this node still inside the window
    bool success = false;  // the latest outcome z_j
  };

  void Observe(const LocalisationAttempt& attempt);
  void Forget(const Uuid& node);
  void JoinPath(PathMemory::PathIndex path, int slot);
  double Log(int n);

  PathMemory memory_;
  PathRankingOptions options_;

  std::deque<std::vector<LocalisationAttempt>> window_;  // last T iterations, oldest first
  std::unordered_map<Uuid, Observation> observed_;       // W
  int successes_ = 0;                                    // |{j : z_j = 1}|
  std::vector<std::vector<int>> members_of_path_;        // path index -> slots of W on it
  std::vector<int> free_slots_;
  std::vector<char> z_;       // slot -> outcome
  std::vector<int> counts_;   // slot -> Z_ij scratch for the candidate being scored
  std::vector<int> touched_;  // slots with counts_ != 0
  std::vector<double> log_table_;
};

}  // namespace fleetmap
