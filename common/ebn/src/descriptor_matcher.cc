#include "fleetmap/ebn/descriptor_matcher.h"

#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

std::vector<DescriptorMatch> MatchDescriptors(std::span<const Descriptor256> queries,
                                              std::span<const Descriptor256> train,
                                              const MatchOptions& options) {
  if (!(options.ratio > 0.0 && options.ratio <= 1.0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "match ratio must be in (0, 1], got " + std::to_string(options.ratio));
  }
  if (options.max_distance < 0 || options.max_distance > 256) {
    throw Error(ErrorCode::kInvalidArgument, "match max_distance must be in [0, 256], got " +
                                                 std::to_string(options.max_distance));
  }

  // One pass gives both directions: the queries' two nearest and the train side's nearest.
  const HammingNeighbours neighbours = FindHammingNeighbours(queries, train, options.kernel);
  const bool ratio_test = options.ratio < 1.0;

  std::vector<DescriptorMatch> matches;
  for (std::size_t i = 0; i < neighbours.per_query.size(); ++i) {
    const NearestTwo& nearest = neighbours.per_query[i];
    if (nearest.best.index < 0 || nearest.best.distance > options.max_distance) continue;
    if (neighbours.per_train[static_cast<std::size_t>(nearest.best.index)].index !=
        static_cast<int>(i)) {
      continue;
    }
    if (ratio_test && nearest.second.index >= 0 &&
        !(nearest.best.distance < options.ratio * nearest.second.distance)) {
      continue;
    }
    matches.push_back({static_cast<int>(i), nearest.best.index, nearest.best.distance});
  }
  return matches;
}

}  // namespace fleetmap
