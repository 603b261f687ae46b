// Descriptor matching and localisation micro-benchmarks. All matchers run on the same 500 x 500
// random descriptor sets (150 planted near-duplicates) and produce the same cross-checked
// matches: ours, a plain nested loop, and OpenCV's brute-force matcher with crossCheck.
//
// What we hold it to: ours <= 1.5x the plain loop's time and >= 4x faster than
// OpenCV crossCheck.
#include <benchmark/benchmark.h>

#include <bit>
#include <climits>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "fleetmap/ebn/descriptor_matcher.h"
#include "fleetmap/ebn/localiser.h"
#include "landmark_scene.h"

namespace fleetmap {
namespace {

const testing::DescriptorSets& Sets() {
  static const testing::DescriptorSets sets = testing::MakeDescriptorSets(500, 500, 150, 40, 1);
  return sets;
}

const MatchOptions kCrossCheckOnly{.ratio = 1.0, .max_distance = 256};

// The plain baseline: what someone would write without SIMD. One pass over all pairs keeps
// each query's best train descriptor and each train descriptor's best query (the lowest index
// on ties), then the mutual check.
[[gnu::always_inline]] inline std::vector<DescriptorMatch> PlainCrossCheck(
    const std::vector<Descriptor256>& queries, const std::vector<Descriptor256>& train) {
  const std::size_t n = queries.size(), m = train.size();
  std::vector<int> query_best(n, -1), query_best_d(n, INT_MAX);
  std::vector<int> train_best(m, -1), train_best_d(m, INT_MAX);
  for (std::size_t i = 0; i < n; ++i) {
    std::uint64_t q[4];
    std::memcpy(q, queries[i].data(), sizeof q);
    for (std::size_t j = 0; j < m; ++j) {
      std::uint64_t t[4];
      std::memcpy(t, train[j].data(), sizeof t);
      const int d = std::popcount(q[0] ^ t[0]) + std::popcount(q[1] ^ t[1]) +
                    std::popcount(q[2] ^ t[2]) + std::popcount(q[3] ^ t[3]);
      if (d < query_best_d[i]) {
        query_best_d[i] = d;
        query_best[i] = static_cast<int>(j);
      }
      if (d < train_best_d[j]) {
        train_best_d[j] = d;
        train_best[j] = static_cast<int>(i);
      }
    }
  }
  std::vector<DescriptorMatch> matches;
  for (std::size_t i = 0; i < n; ++i) {
    const int j = query_best[i];
    if (j >= 0 && train_best[static_cast<std::size_t>(j)] == static_cast<int>(i)) {
      matches.push_back({static_cast<int>(i), j, query_best_d[i]});
    }
  }
  return matches;
}

// The same loop, built for the baseline x86-64 ISA as the project builds everything: GCC turns
// std::popcount into a call to libgcc's __popcountdi2.
std::vector<DescriptorMatch> PlainCrossCheckBaselineIsa(const std::vector<Descriptor256>& queries,
                                                        const std::vector<Descriptor256>& train) {
  return PlainCrossCheck(queries, train);
}

// The same loop with the POPCNT instruction allowed (as -march=native would).
__attribute__((target("popcnt"))) std::vector<DescriptorMatch> PlainCrossCheckPopcnt(
    const std::vector<Descriptor256>& queries, const std::vector<Descriptor256>& train) {
  return PlainCrossCheck(queries, train);
}

// Refuses to time a matcher that disagrees with ours.
bool AgreesWithOurs(benchmark::State& state, const std::vector<DescriptorMatch>& matches) {
  if (matches == MatchDescriptors(Sets().queries, Sets().train, kCrossCheckOnly)) return true;
  state.SkipWithError("matches differ from MatchDescriptors");
  return false;
}

void BM_MatcherOurs(benchmark::State& state) {
  const auto kernel = static_cast<HammingKernel>(state.range(0));
  if (!HammingKernelAvailable(kernel)) return state.SkipWithError("kernel not available");
  MatchOptions options = kCrossCheckOnly;
  options.kernel = kernel;
  for (auto _ : state) {
    benchmark::DoNotOptimize(MatchDescriptors(Sets().queries, Sets().train, options));
  }
}
BENCHMARK(BM_MatcherOurs)
    ->ArgName("kernel")
    ->Arg(static_cast<int>(HammingKernel::kAuto))
    ->Arg(static_cast<int>(HammingKernel::kScalar))
    ->Unit(benchmark::kMicrosecond);

// Default options (ratio 0.8, at most 80 bits): same single pass, fewer matches kept.
void BM_MatcherOursDefaultOptions(benchmark::State& state) {
  for (auto _ : state) {
    benchmark::DoNotOptimize(MatchDescriptors(Sets().queries, Sets().train));
  }
}
BENCHMARK(BM_MatcherOursDefaultOptions)->Unit(benchmark::kMicrosecond);

void BM_MatcherPlainLoop(benchmark::State& state) {
  if (!AgreesWithOurs(state, PlainCrossCheckBaselineIsa(Sets().queries, Sets().train))) return;
  for (auto _ : state) {
    benchmark::DoNotOptimize(PlainCrossCheckBaselineIsa(Sets().queries, Sets().train));
  }
}
BENCHMARK(BM_MatcherPlainLoop)->Unit(benchmark::kMicrosecond);

void BM_MatcherPlainLoopPopcnt(benchmark::State& state) {
  if (!__builtin_cpu_supports("popcnt")) return state.SkipWithError("CPU without POPCNT");
  if (!AgreesWithOurs(state, PlainCrossCheckPopcnt(Sets().queries, Sets().train))) return;
  for (auto _ : state) {
    benchmark::DoNotOptimize(PlainCrossCheckPopcnt(Sets().queries, Sets().train));
  }
}
BENCHMARK(BM_MatcherPlainLoopPopcnt)->Unit(benchmark::kMicrosecond);

// OpenCV with `threads` worker threads (1: single-threaded like the others; -1: its default).
void BM_MatcherOpenCvCrossCheck(benchmark::State& state) {
  const cv::Mat queries(500, 32, CV_8U, const_cast<Descriptor256*>(Sets().queries.data()));
  const cv::Mat train(500, 32, CV_8U, const_cast<Descriptor256*>(Sets().train.data()));
  const cv::BFMatcher matcher(cv::NORM_HAMMING, /*crossCheck=*/true);
  const int previous_threads = cv::getNumThreads();
  cv::setNumThreads(static_cast<int>(state.range(0)));
  std::vector<cv::DMatch> matches;
  for (auto _ : state) {
    matcher.match(queries, train, matches);
    benchmark::DoNotOptimize(matches.data());
  }
  cv::setNumThreads(previous_threads);
  state.counters["matches"] = static_cast<double>(matches.size());
}
BENCHMARK(BM_MatcherOpenCvCrossCheck)
    ->ArgName("threads")
    ->Arg(1)
    ->Arg(-1)
    ->Unit(benchmark::kMicrosecond);

// The full localisation: 500 frame vs 500 node landmarks, half the frame seen where it is.
void BM_Localise(benchmark::State& state) {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.linear() =
      Eigen::AngleAxisd(0.35, Eigen::Vector3d(0.3, 1.0, 0.2).normalized()).toRotationMatrix();
  node_T_frame.translation() = Eigen::Vector3d(0.6, -0.3, 0.7);
  const auto scene = testing::MakeLandmarkScene(node_T_frame, {});
  const Localiser localiser;
  LocalisationResult result;
  for (auto _ : state) {
    result = localiser.Localise(scene.frame, scene.node);
    benchmark::DoNotOptimize(result);
  }
  if (!result.success) state.SkipWithError("localisation failed");
  state.counters["matches"] = result.matches;
  state.counters["inliers"] = result.inliers;
}
BENCHMARK(BM_Localise)->Unit(benchmark::kMicrosecond);

}  // namespace
}  // namespace fleetmap

BENCHMARK_MAIN();
