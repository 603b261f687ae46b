// A ranking policy that records, per held-out frame, what the fleet's localiser ranked and
// tried (fleet_experiment.h FleetReach: could it reach the experience it needed?).
#pragma once

#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "fleetmap/core/uuid.h"
#include "fleetmap/ebn/ranking_policy.h"

namespace fleetmap::fleet_internal {

// What the localiser did with one held-out frame: the candidates Γ ranked, best first, and the
// nodes it tried (relocalisation's included), for the merge diagnosis.
struct FrameTrace {
  Uuid reference;  // n_k when it ranked (nil: no candidates, nothing ranked)
  std::vector<Uuid> ranked;
  std::vector<Uuid> tried;
};

// The fleet's ranking policy, unchanged, keeping a FrameTrace per localiser iteration (the
// builder runs exactly one per frame, ranking at most once before it).
class TracingRanking final : public RankingPolicy {
 public:
  TracingRanking(RankingPolicy& inner, std::vector<FrameTrace>& traces)
      : inner_(inner), traces_(traces) {}
  std::string name() const override { return inner_.name(); }
  void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override {
    inner_.Rank(reference, candidates);
    reference_ = reference;
    ranked_.clear();
    for (const Candidate& candidate : candidates) ranked_.push_back(candidate.node);
  }
  void ObserveIteration(std::span<const LocalisationAttempt> attempts) override {
    inner_.ObserveIteration(attempts);
    FrameTrace& trace = traces_.emplace_back();
    trace.reference = reference_;
    trace.ranked = std::move(ranked_);
    ranked_.clear();
    reference_ = Uuid();
    for (const LocalisationAttempt& attempt : attempts) trace.tried.push_back(attempt.node);
  }
  void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) override {
    inner_.ObservePathEdge(path, from, to);
  }
  void StartOuting() override { inner_.StartOuting(); }

 private:
  RankingPolicy& inner_;
  std::vector<FrameTrace>& traces_;
  Uuid reference_;
  std::vector<Uuid> ranked_;
};

// A TracingRanking that owns the policy it wraps.
class OwningTracer final : public RankingPolicy {
 public:
  OwningTracer(std::unique_ptr<RankingPolicy> inner, std::vector<FrameTrace>& traces)
      : inner_(std::move(inner)), tracer_(*inner_, traces) {}
  std::string name() const override { return tracer_.name(); }
  void Rank(const Uuid& reference, std::vector<Candidate>& candidates) override {
    tracer_.Rank(reference, candidates);
  }
  void ObserveIteration(std::span<const LocalisationAttempt> attempts) override {
    tracer_.ObserveIteration(attempts);
  }
  void ObservePathEdge(const Uuid& path, const Uuid& from, const Uuid& to) override {
    tracer_.ObservePathEdge(path, from, to);
  }
  void StartOuting() override { tracer_.StartOuting(); }

 private:
  std::unique_ptr<RankingPolicy> inner_;
  TracingRanking tracer_;
};

}  // namespace fleetmap::fleet_internal
