// The relaxed layout's cost (fleetmap/relaxation/relaxed_layout.h) at 10^4 and 10^5 nodes,
// beside the composed layout of the same map (the baseline: what a picture cost before): a
// fleet driving one 1 km loop, outings of 1,000 nodes each, its odometry drifting a little at
// every step, each outing's every 5th node localised against the outing before it. Reports the
// solve's iterations and the process's peak memory growth over the map held in memory.
#include <benchmark/benchmark.h>
#include <sys/resource.h>

#include <cmath>
#include <cstdint>
#include <fstream>
#include <random>
#include <string>
#include <vector>

#include "fleetmap/interchange/graph_layout.h"
#include "fleetmap/relaxation/relaxed_layout.h"
#include "seeded_uuid.h"

namespace fleetmap {
namespace {

constexpr int kNodesPerOuting = 1000;
constexpr double kLoopRadius_m = 1000.0 / (2.0 * M_PI);

struct LoopFleet {
  std::vector<Node> nodes;
  std::vector<Edge> edges;
};

Se3 OnLoop(double angle, double offset_m) {
  const double r = kLoopRadius_m + offset_m;
  return Se3FromTranslationQuaternion(
      Eigen::Vector3d(r * std::sin(angle), 0.0, r * (1.0 - std::cos(angle))),
      Eigen::Quaterniond(Eigen::AngleAxisd(-angle, Eigen::Vector3d::UnitY())));
}

Se3 Noise(std::mt19937_64& rng, double sigma_m, double sigma_rad) {
  std::normal_distribution<double> m(0.0, sigma_m), rad(0.0, sigma_rad);
  return Se3FromTranslationQuaternion(
      Eigen::Vector3d(m(rng), m(rng), m(rng)),
      Eigen::Quaterniond(Eigen::AngleAxisd(rad(rng), Eigen::Vector3d::UnitY())));
}

LoopFleet MakeLoopFleet(std::int64_t nodes) {
  std::mt19937_64 rng(20261203);
  LoopFleet fleet;
  const int outings = static_cast<int>(nodes / kNodesPerOuting);
  std::vector<Se3> previous_truth;
  std::vector<std::size_t> previous_index;
  for (int o = 0; o < outings; ++o) {
    const Uuid robot = SeededUuid(rng), outing = SeededUuid(rng);
    const double lane = 0.5 * (o % 3);  // outings a little apart on the road
    std::vector<Se3> truth;
    std::vector<std::size_t> index;
    for (int i = 0; i < kNodesPerOuting; ++i) {
      const double angle = 2.0 * M_PI * (i + 0.37 * o) / kNodesPerOuting;
      truth.push_back(OnLoop(angle, lane));
      Node node;
      node.id = SeededUuid(rng);
      node.stamp_ns = (static_cast<std::int64_t>(o) * kNodesPerOuting + i) * 1'000'000'000;
      node.robot = robot;
      node.outing = outing;
      index.push_back(fleet.nodes.size());
      fleet.nodes.push_back(node);
      if (i > 0) {
        Edge odometry;
        odometry.id = SeededUuid(rng);
        odometry.from = fleet.nodes[index[i - 1]].id;
        odometry.to = node.id;
        odometry.from_T_to = truth[i - 1].inverse() * truth[i] * Noise(rng, 0.01, 0.002);
        fleet.edges.push_back(odometry);
      }
      if (o > 0 && i % 5 == 0) {
        Edge match;
        match.id = SeededUuid(rng);
        match.from = fleet.nodes[previous_index[i]].id;
        match.to = node.id;
        match.from_T_to = previous_truth[i].inverse() * truth[i] * Noise(rng, 0.05, 0.01);
        fleet.edges.push_back(match);
      }
    }
    previous_truth = std::move(truth);
    previous_index = std::move(index);
  }
  return fleet;
}

double ResidentMb(const char* field) {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    if (line.rfind(field, 0) == 0) return std::stod(line.substr(std::string(field).size())) / 1e3;
  }
  return 0.0;
}

void BM_ComposedLayout(benchmark::State& state) {
  const LoopFleet fleet = MakeLoopFleet(state.range(0));
  for (auto _ : state) {
    benchmark::DoNotOptimize(GraphLayout::Compute(fleet.nodes, fleet.edges));
  }
  state.counters["nodes"] = static_cast<double>(fleet.nodes.size());
}

// Resets the process's peak resident size to what it holds now (Linux: clear_refs 5).
void ResetPeakRss() {
  std::ofstream("/proc/self/clear_refs") << "5";
}

void BM_RelaxedLayout(benchmark::State& state) {
  const LoopFleet fleet = MakeLoopFleet(state.range(0));
  ResetPeakRss();
  const double before_mb = ResidentMb("VmRSS:");
  RelaxationReport report;
  for (auto _ : state) {
    const GraphLayout composed = GraphLayout::Compute(fleet.nodes, fleet.edges);
    benchmark::DoNotOptimize(RelaxLayout(composed, fleet.edges, {}, &report));
  }
  state.counters["nodes"] = static_cast<double>(report.nodes);
  state.counters["edges"] = static_cast<double>(report.edges);
  state.counters["iterations"] = report.iterations;
  state.counters["converged"] = report.converged ? 1 : 0;
  state.counters["peak_growth_MB"] = ResidentMb("VmHWM:") - before_mb;
}

BENCHMARK(BM_ComposedLayout)->Arg(10'000)->Arg(100'000)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_RelaxedLayout)
    ->Arg(10'000)
    ->Arg(100'000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(1);

}  // namespace
}  // namespace fleetmap
