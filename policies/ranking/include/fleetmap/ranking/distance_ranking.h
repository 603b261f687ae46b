// Γ(distance): candidates nearest the robot's position estimate first (seed 002 §III-C), the
// baseline Γ(path) is measured against.
#pragma once

#include "fleetmap/ebn/ranking_policy.h"

namespace fleetmap {

class DistanceRanking final : public RankingPolicy {
 public:
  std::string name() const override { return "distance"; }
  // Ascending distance; ties by UUID so the order is deterministic.
  void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override;
  void ObserveIteration(std::span<const LocalisationAttempt>) override {}
  void ObservePathEdge(const Uuid&, const Uuid&, const Uuid&) override {}
  void StartOuting() override {}
};

}  // namespace fleetmap
