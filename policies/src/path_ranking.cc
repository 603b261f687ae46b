#include "fleetmap/policies/path_ranking.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "fleetmap/common/error.h"

namespace fleetmap {

PathRanking::PathRanking(PathMemory memory, const PathRankingOptions& options)
    : memory_(std::move(memory)), options_(options) {
  if (options_.window_iterations < 0) {
    throw Error(ErrorCode::kInvalidArgument, "PathRanking: window_iterations must be >= 0");
  }
}

double PathRanking::Log(int n) {
  // log of small integers, cached: the likelihood needs log D, log(D - 1) and log(D - c - 1)
  // for every candidate, with D below |W| + S_i.
  if (n <= 0) return -std::numeric_limits<double>::infinity();
  if (static_cast<std::size_t>(n) >= log_table_.size()) {
    const std::size_t old_size = log_table_.size();
    log_table_.resize(std::max<std::size_t>(static_cast<std::size_t>(n) + 1, 2 * old_size));
    for (std::size_t i = old_size; i < log_table_.size(); ++i) {
      log_table_[i] = i == 0 ? 0.0 : std::log(static_cast<double>(i));
    }
  }
  return log_table_[static_cast<std::size_t>(n)];
}

double PathRanking::LogPosterior(const Uuid& reference, const Uuid& candidate) {
  // Prior (Eq. 8), dropping the normaliser Σ_x (N_xk + γ) which all candidates share.
  const int n_ik = reference.IsNil() ? 0 : memory_.SharedPaths(candidate, reference);
  double score = Log(n_ik + 1);

  const int w = static_cast<int>(observed_.size());
  if (w == 0) return score;

  // Z_ij for the W members sharing a path with the candidate; all others have Z_ij = 0.
  int s_i = 0;
  for (const PathMemory::PathIndex path : memory_.PathsThrough(candidate)) {
    if (path >= members_of_path_.size()) continue;
    for (const int slot : members_of_path_[path]) {
      if (counts_[static_cast<std::size_t>(slot)]++ == 0) touched_.push_back(slot);
      ++s_i;
    }
  }

  // Eqs. 5–6 with α = 1: D = Σ_x (Z_ix + 1) = S_i + |W|. Every observation starts at the
  // zero-count value, then those sharing c > 0 paths are corrected.
  const int d = s_i + w;
  const int failures = w - successes_;
  const double log_d = Log(d);
  const double log_d1 = Log(d - 1);
  score += successes_ * -log_d + failures * (log_d1 - log_d);
  for (const int slot : touched_) {
    const int c = counts_[static_cast<std::size_t>(slot)];
    counts_[static_cast<std::size_t>(slot)] = 0;
    if (z_[static_cast<std::size_t>(slot)]) {
      score += Log(c + 1);  // log θ = log(c + 1) - log D
    } else {
      score += Log(d - c - 1) - log_d1;  // log(1 - θ) = log(D - c - 1) - log D
    }
  }
  touched_.clear();
  return score;
}

void PathRanking::Rank(const Uuid& reference, std::vector<Candidate>& candidates) {
  std::vector<std::pair<double, std::size_t>> scored;
  scored.reserve(candidates.size());
  for (std::size_t i = 0; i < candidates.size(); ++i) {
    scored.emplace_back(LogPosterior(reference, candidates[i].node), i);
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

void PathRanking::JoinPath(PathMemory::PathIndex path, int slot) {
  if (path >= members_of_path_.size()) members_of_path_.resize(path + 1);
  std::vector<int>& members = members_of_path_[path];
  if (std::find(members.begin(), members.end(), slot) == members.end()) members.push_back(slot);
}

void PathRanking::Observe(const LocalisationAttempt& attempt) {
  auto [it, inserted] = observed_.try_emplace(attempt.node);
  Observation& observation = it->second;
  if (inserted) {
    if (free_slots_.empty()) {
      observation.slot = static_cast<int>(z_.size());
      z_.push_back(0);
      counts_.push_back(0);
    } else {
      observation.slot = free_slots_.back();
      free_slots_.pop_back();
    }
    for (const PathMemory::PathIndex path : memory_.PathsThrough(attempt.node)) {
      JoinPath(path, observation.slot);
    }
  } else if (observation.success) {
    --successes_;
  }
  ++observation.occurrences;
  observation.success = attempt.success;
  z_[static_cast<std::size_t>(observation.slot)] = attempt.success ? 1 : 0;
  if (attempt.success) ++successes_;
}

void PathRanking::Forget(const Uuid& node) {
  const auto it = observed_.find(node);
  if (it == observed_.end() || --it->second.occurrences > 0) return;
  const int slot = it->second.slot;
  if (it->second.success) --successes_;
  for (const PathMemory::PathIndex path : memory_.PathsThrough(node)) {
    std::vector<int>& members = members_of_path_[path];
    members.erase(std::find(members.begin(), members.end(), slot));
  }
  free_slots_.push_back(slot);
  observed_.erase(it);
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
  const PathMemory::PathIndex index = memory_.AddPathEdge(path, from, to);
  // A node already in W that just joined the path must count on it from now on.
  for (const Uuid& node : {from, to}) {
    const auto it = observed_.find(node);
    if (it != observed_.end()) JoinPath(index, it->second.slot);
  }
}

void PathRanking::StartOuting() {
  window_.clear();
  observed_.clear();
  successes_ = 0;
  for (std::vector<int>& members : members_of_path_) members.clear();
  free_slots_.clear();
  z_.clear();
  counts_.clear();
}

}  // namespace fleetmap
