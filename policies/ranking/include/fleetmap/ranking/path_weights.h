// DOWNLOAD's "paths" policy (seed 004 §V-B3): which recorded paths the localiser used at which
// time of day, and the best of them for a mission.
//
// The day is cut into K epochs of `epoch_min` minutes (Eq. 5, on the 24-hour clock: epoch k,
// from 0, holds times of day in [k Δt, (k + 1) Δt)). Algorithm 2 builds the path count matrix:
// PCM(P, k) = number of nodes captured in epoch k that lie on path P (M(n, P) = 1, Eq. 6).
// Eq. 7 normalises each epoch's column into the path weight matrix,
// PWM(P, k) = PCM(P, k) / Σ_P' PCM(P', k) (the paper prints the sum over PWM itself; the
// normaliser can only be the column's counts). Algorithm 3 picks, for every epoch of the
// mission, the best p % of the paths used in that epoch.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ranking/path_memory.h"

namespace fleetmap {

class PathWeights {
 public:
  using PathIndex = PathMemory::PathIndex;

  // Algorithm 2 over `nodes` (their stamps give the epochs; nodes on no path count nowhere).
  // Throws Error(kInvalidArgument) unless 0 < epoch_min <= 1440.
  static PathWeights Count(const PathMemory& memory, std::span<const Node> nodes, double epoch_min);

  int epochs() const { return epochs_; }  // K
  std::size_t path_count() const { return path_count_; }
  // The epoch holding a time of day (minutes since midnight).
  int EpochOf(double minute_of_day) const;

  int Count(PathIndex path, int epoch) const;      // PCM(P, k)
  double Weight(PathIndex path, int epoch) const;  // PWM(P, k), 0 for an epoch without data

  // First and last epochs with any count (k_min, k_max); none without data.
  std::optional<int> first_epoch() const { return first_epoch_; }
  std::optional<int> last_epoch() const { return last_epoch_; }

  // Algorithm 3: the union over epochs k_start … k_end of each epoch's best `percent` % of
  // the paths it used (at least one when it used any; heavier first, ties by lower index).
  // A missing k_start, or one before k_min, becomes k_min; a missing k_end, or one after
  // k_max, becomes k_max (the paper's line 4 tests k_start there, a slip for k_end). Given
  // both with k_start > k_end, the mission runs across midnight: k_start … K − 1, 0 … k_end.
  // Returns ascending path indexes; empty without data. Throws Error(kInvalidArgument) unless
  // 0 < percent <= 100 and given epochs are in [0, K).
  std::vector<PathIndex> BestPaths(std::optional<int> k_start, std::optional<int> k_end,
                                   double percent) const;

 private:
  int epochs_ = 0;
  double epoch_min_ = 0.0;
  std::size_t path_count_ = 0;
  std::vector<int> counts_;        // path-major: counts_[path * epochs_ + epoch]
  std::vector<int> epoch_totals_;  // Σ_P PCM(P, k)
  std::optional<int> first_epoch_, last_epoch_;
};

}  // namespace fleetmap
