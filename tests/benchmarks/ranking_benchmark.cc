// Γ(path) ranking cost (seed 002 §VII-B reports it never exceeded 0.5 ms). A map the size of
// a well-used route: 10,000 nodes, 60 paths, each node on 1–12 of them; the robot ranks 64
// candidates against |W| = 200 observations (T = 50 iterations of 4 attempts). Γ(distance)
// on the same candidates is the floor: a plain sort.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_ranking.h"

namespace fleetmap {
namespace {

constexpr int kNodes = 10'000;
constexpr int kPaths = 60;

struct RankingScene {
  std::vector<Uuid> nodes;
  PathMemory memory;
  std::vector<std::vector<LocalisationAttempt>> iterations;
  std::vector<Candidate> candidates;
};

RankingScene MakeScene() {
  RankingScene scene;
  std::mt19937 rng(7);
  for (int i = 0; i < kNodes; ++i) scene.nodes.push_back(Uuid::GenerateRandom());
  std::vector<Uuid> paths;
  for (int p = 0; p < kPaths; ++p) paths.push_back(Uuid::GenerateRandom());
  std::uniform_int_distribution<int> path_count(1, 12), pick_path(0, kPaths - 1);
  for (int i = 0; i + 1 < kNodes; ++i) {
    for (int k = path_count(rng); k > 0; --k) {
      scene.memory.AddPathEdge(paths[static_cast<std::size_t>(pick_path(rng))],
                               scene.nodes[static_cast<std::size_t>(i)],
                               scene.nodes[static_cast<std::size_t>(i + 1)]);
    }
  }
  std::uniform_int_distribution<int> pick_node(0, kNodes - 1);
  std::bernoulli_distribution success(0.3);
  for (int t = 0; t < 50; ++t) {
    std::vector<LocalisationAttempt> attempts;
    for (int a = 0; a < 4; ++a) {
      attempts.push_back({scene.nodes[static_cast<std::size_t>(pick_node(rng))], success(rng)});
    }
    scene.iterations.push_back(std::move(attempts));
  }
  std::uniform_real_distribution<double> distance(0.0, 10.0);
  for (int c = 0; c < 64; ++c) {
    scene.candidates.push_back(
        {scene.nodes[static_cast<std::size_t>(pick_node(rng))], distance(rng)});
  }
  return scene;
}

const RankingScene& Scene() {
  static const RankingScene scene = MakeScene();
  return scene;
}

void BM_Ranking_Path(benchmark::State& state) {
  const RankingScene& scene = Scene();
  PathRanking ranking(scene.memory, {.window_iterations = 50});
  for (const auto& attempts : scene.iterations) ranking.ObserveIteration(attempts);
  for (auto _ : state) {
    std::vector<Candidate> candidates = scene.candidates;
    ranking.Rank(scene.nodes[0], candidates);
    benchmark::DoNotOptimize(candidates.data());
  }
}
BENCHMARK(BM_Ranking_Path)->Unit(benchmark::kMicrosecond);

// One iteration entering (and one leaving) the window: the incremental upkeep of W.
void BM_Ranking_PathObserveIteration(benchmark::State& state) {
  const RankingScene& scene = Scene();
  PathRanking ranking(scene.memory, {.window_iterations = 50});
  std::size_t next = 0;
  for (auto _ : state) {
    ranking.ObserveIteration(scene.iterations[next]);
    next = (next + 1) % scene.iterations.size();
  }
}
BENCHMARK(BM_Ranking_PathObserveIteration)->Unit(benchmark::kMicrosecond);

void BM_Ranking_Distance(benchmark::State& state) {
  const RankingScene& scene = Scene();
  DistanceRanking ranking;
  for (auto _ : state) {
    std::vector<Candidate> candidates = scene.candidates;
    ranking.Rank(Uuid(), candidates);
    benchmark::DoNotOptimize(candidates.data());
  }
}
BENCHMARK(BM_Ranking_Distance)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace fleetmap
