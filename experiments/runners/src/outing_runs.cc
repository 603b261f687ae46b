#include "outing_runs.h"

#include <time.h>

#include <algorithm>

#include "task_queue.h"

namespace fleetmap {

std::vector<std::vector<Frame>> RenderOutings(const World& world,
                                              const std::vector<Outing>& outings, int threads) {
  std::vector<std::vector<Frame>> frames(outings.size());
  TaskQueue render;
  for (std::size_t i = 0; i < outings.size(); ++i) {
    render.Push([&, i] { frames[i] = world.Frames(outings[i]); });
  }
  render.Run(threads);
  return frames;
}

double ThreadCpuSeconds() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_nsec) * 1e-9;
}

PathMemory PathMemoryOf(const GraphBatch& map) {
  PathMemory memory;
  for (const Edge& edge : map.edges) {
    if (edge.kind == EdgeKind::kPath) memory.AddPathEdge(edge.path, edge.from, edge.to);
  }
  return memory;
}

void CollectingWriter::Put(const GraphBatch& batch) {
  written_.paths.insert(written_.paths.end(), batch.paths.begin(), batch.paths.end());
  written_.nodes.insert(written_.nodes.end(), batch.nodes.begin(), batch.nodes.end());
  written_.edges.insert(written_.edges.end(), batch.edges.begin(), batch.edges.end());
  written_.annotations.insert(written_.annotations.end(), batch.annotations.begin(),
                              batch.annotations.end());
}

std::int64_t OutingLocalisation::not_localised() const {
  return static_cast<std::int64_t>(std::count(localised.begin(), localised.end(), 0));
}

std::int64_t OutingLocalisation::gaps_beyond(double x_m) const {
  return static_cast<std::int64_t>(
      std::count_if(gaps_m.begin(), gaps_m.end(), [x_m](float gap) { return gap > x_m; }));
}

void LocaliseOuting(const ExperienceMap& map, RankingPolicy& policy, const BuilderOptions& options,
                    const OutingStart& start, const std::vector<Frame>& frames,
                    OutingLocalisation& result) {
  BuilderOptions localise_only = options;
  localise_only.localise_only = true;
  // Localise-only runs never write the map; the builder's interface takes it mutable.
  ExperienceBuilder localiser(nullptr, const_cast<ExperienceMap&>(map), policy, localise_only);
  localiser.StartOuting(start);
  for (const Frame& frame : frames) {
    const FrameReport report = localiser.Process(frame);
    const bool success = report.successes > 0;
    result.gaps_m.push_back(static_cast<float>(report.distance_since_success_m));
    result.localised.push_back(success ? 1 : 0);
    result.references.push_back(success ? report.reference : Uuid());
  }
  localiser.FinishOuting();
}

}  // namespace fleetmap
