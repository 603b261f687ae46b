#include "fleetmap/ranking/path_weights.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/ranking/time_of_day.h"

namespace fleetmap {

PathWeights PathWeights::Count(const PathMemory& memory, std::span<const Node> nodes,
                               double epoch_min) {
  if (!(epoch_min > 0.0 && epoch_min <= kMinutesPerDay)) {
    throw Error(
        ErrorCode::kInvalidArgument,
        "path weights: the epoch must be in (0, 1440] minutes, not " + std::to_string(epoch_min));
  }
  PathWeights weights;
  weights.epoch_min_ = epoch_min;
  weights.epochs_ = static_cast<int>(std::ceil(kMinutesPerDay / epoch_min - 1e-9));
  weights.path_count_ = memory.path_count();
  weights.counts_.assign(weights.path_count_ * static_cast<std::size_t>(weights.epochs_), 0);
  weights.epoch_totals_.assign(static_cast<std::size_t>(weights.epochs_), 0);
  for (const Node& node : nodes) {  // Algorithm 2: epochs, their nodes, the paths through them
    const int k = weights.EpochOf(MinuteOfDay(node.stamp_ns));
    for (const PathIndex path : memory.PathsThrough(node.id)) {
      ++weights.counts_[path * static_cast<std::size_t>(weights.epochs_) +
                        static_cast<std::size_t>(k)];
      ++weights.epoch_totals_[static_cast<std::size_t>(k)];
      weights.first_epoch_ = std::min(weights.first_epoch_.value_or(k), k);
      weights.last_epoch_ = std::max(weights.last_epoch_.value_or(k), k);
    }
  }
  return weights;
}

int PathWeights::EpochOf(double minute_of_day) const {
  return std::clamp(static_cast<int>(std::floor(minute_of_day / epoch_min_)), 0, epochs_ - 1);
}

int PathWeights::Count(PathIndex path, int epoch) const {
  if (path >= path_count_ || epoch < 0 || epoch >= epochs_) return 0;
  return counts_[path * static_cast<std::size_t>(epochs_) + static_cast<std::size_t>(epoch)];
}

double PathWeights::Weight(PathIndex path, int epoch) const {
  if (epoch < 0 || epoch >= epochs_) return 0.0;
  const int total = epoch_totals_[static_cast<std::size_t>(epoch)];
  return total == 0 ? 0.0 : static_cast<double>(Count(path, epoch)) / total;
}

std::vector<PathWeights::PathIndex> PathWeights::BestPaths(std::optional<int> k_start,
                                                           std::optional<int> k_end,
                                                           double percent) const {
  if (!(percent > 0.0 && percent <= 100.0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "paths policy: p must be in (0, 100] %, not " + std::to_string(percent));
  }
  for (const std::optional<int>& k : {k_start, k_end}) {
    if (k && (*k < 0 || *k >= epochs_)) {
      throw Error(ErrorCode::kInvalidArgument, "paths policy: epoch " + std::to_string(*k) +
                                                   " outside [0, " + std::to_string(epochs_) + ")");
    }
  }
  if (!first_epoch_) return {};
  // Algorithm 3, lines 1–6. Bounds outside the data change nothing (epochs without data
  // choose nothing), so only missing bounds need filling in.
  const int start = !k_start || *k_start < *first_epoch_ ? *first_epoch_ : *k_start;
  const int end = !k_end || *k_end > *last_epoch_ ? *last_epoch_ : *k_end;
  const bool across_midnight = k_start && k_end && *k_start > *k_end;

  std::vector<char> chosen(path_count_, 0);
  std::vector<std::pair<double, PathIndex>> used;
  const auto best_of_epoch = [&](int k) {  // lines 9–10
    used.clear();
    for (PathIndex path = 0; path < path_count_; ++path) {
      const double weight = Weight(path, k);
      if (weight > 0.0) used.emplace_back(-weight, path);
    }
    if (used.empty()) return;
    std::sort(used.begin(), used.end());
    const auto keep = std::max<std::size_t>(
        1, static_cast<std::size_t>(std::ceil(percent / 100.0 * used.size() - 1e-9)));
    for (std::size_t i = 0; i < keep && i < used.size(); ++i) chosen[used[i].second] = 1;
  };
  if (across_midnight) {
    for (int k = *k_start; k < epochs_; ++k) best_of_epoch(k);
    for (int k = 0; k <= *k_end; ++k) best_of_epoch(k);
  } else {
    for (int k = start; k <= end; ++k) best_of_epoch(k);
  }
  std::vector<PathIndex> paths;
  for (PathIndex path = 0; path < path_count_; ++path) {
    if (chosen[path]) paths.push_back(path);
  }
  return paths;
}

}  // namespace fleetmap
