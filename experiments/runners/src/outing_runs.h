// What the fleet experiments do with one outing of the synthetic world: drive it with
// single-agent EBN onto a map, or localise it, localise-only, in a map it did not build.
#pragma once

#include <cstdint>
#include <memory>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/ebn/experience_builder.h"
#include "fleetmap/ebn/experience_map.h"
#include "fleetmap/ebn/ranking_policy.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/world/world.h"

namespace fleetmap {

// Every outing's frames, rendered on `threads` threads; in the order of `outings`.
std::vector<std::vector<Frame>> RenderOutings(const World& world,
                                              const std::vector<Outing>& outings, int threads);

// CPU seconds of the calling thread: a task's cost without the time other tasks took from it.
double ThreadCpuSeconds();

// The path memory of a map's path edges (seed 002 §IV).
PathMemory PathMemoryOf(const GraphBatch& map);

// A GraphWriter that keeps what a builder writes: the new nodes, edges and paths of its
// outings, which is what a robot pushes.
class CollectingWriter final : public GraphWriter {
 public:
  void Put(const GraphBatch& batch) override;
  const GraphBatch& written() const { return written_; }

 private:
  GraphBatch written_;
};

// One held-out outing localised in one map: per frame, the ground-truth metres since the last
// success (0 on one) and whether it localised.
struct OutingLocalisation {
  std::vector<float> gaps_m;
  std::vector<char> localised;
  std::vector<Uuid> references;  // the node a frame localised in, nil when it did not

  std::int64_t frames() const { return static_cast<std::int64_t>(gaps_m.size()); }
  std::int64_t not_localised() const;
  std::int64_t gaps_beyond(double x_m) const;
};

// Localises `frames` in `map`, localise-only, with `policy` ranking, from `start`. `options`
// has localise_only forced on. Appends to `result`.
void LocaliseOuting(const ExperienceMap& map, RankingPolicy& policy, const BuilderOptions& options,
                    const OutingStart& start, const std::vector<Frame>& frames,
                    OutingLocalisation& result);

}  // namespace fleetmap
