#include "fleetmap/ranking/distance_ranking.h"

#include <algorithm>

namespace fleetmap {

void DistanceRanking::Rank(const Uuid&, std::vector<Candidate>& candidates) {
  std::sort(candidates.begin(), candidates.end(), [](const Candidate& a, const Candidate& b) {
    return a.distance_m != b.distance_m ? a.distance_m < b.distance_m : a.node < b.node;
  });
}

}  // namespace fleetmap
