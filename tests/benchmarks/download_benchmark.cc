// DOWNLOAD selection cost (seed 004 §V-B) on a month of driving one route: 40 outings each
// laid 500 nodes along the same 500-place loop (20,000 nodes, 1 kB of landmarks each), joined
// along each outing and, every 10th place, to the previous outing there; 300 localisation
// paths, each localising at every place against an outing captured near its own time of
// day. The budget is a quarter of the map, so the fill tries every path and then the bare
// nodes until it is full.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <random>
#include <vector>

#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/integral_selection.h"
#include "seeded_uuid.h"

namespace fleetmap {
namespace {

constexpr int kOutings = 40;
constexpr int kDownloadPlaces = 500;
constexpr int kDownloadPaths = 300;
constexpr std::int64_t kDownloadNsPerMinute = 60'000'000'000;

struct DownloadScene {
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Path> paths;
  std::vector<Uuid> node_ids;
};

DownloadScene MakeDownloadScene() {
  DownloadScene scene;
  std::mt19937_64 rng(11);
  std::uniform_int_distribution<int> minute_of_day(0, 1439);
  std::vector<int> outing_minute;
  const auto node_at = [](int outing, int place) {
    return static_cast<std::size_t>(outing * kDownloadPlaces + place);
  };
  const auto add_edge = [&scene, &rng](const Uuid& from, const Uuid& to, EdgeKind kind,
                                       const Uuid& path) {
    Edge edge;
    edge.id = SeededUuid(rng);
    edge.from = from;
    edge.to = to;
    edge.kind = kind;
    edge.path = path;
    scene.edges.push_back(edge);
  };
  for (int outing = 0; outing < kOutings; ++outing) {
    outing_minute.push_back(minute_of_day(rng));
    for (int place = 0; place < kDownloadPlaces; ++place) {
      Node node;
      node.id = SeededUuid(rng);
      node.stamp_ns = (outing * 1440 + outing_minute.back()) * kDownloadNsPerMinute +
                      std::int64_t{place} * 2'000'000'000;
      node.landmarks_blob.assign(1000, 'x');
      scene.nodes.push_back(node);
      scene.node_ids.push_back(node.id);
      if (place > 0) {
        add_edge(scene.nodes[node_at(outing, place - 1)].id, node.id, EdgeKind::kMetric, {});
      }
      if (outing > 0 && place % 10 == 0) {
        add_edge(scene.nodes[node_at(outing - 1, place)].id, node.id, EdgeKind::kMetric, {});
      }
    }
  }
  for (int p = 0; p < kDownloadPaths; ++p) {
    Path path;
    path.id = SeededUuid(rng);
    scene.paths.push_back(path);
    // The outings captured within two hours of this path's time of day, or any.
    const int minute = minute_of_day(rng);
    std::vector<int> near;
    for (int outing = 0; outing < kOutings; ++outing) {
      const int apart = std::abs(outing_minute[static_cast<std::size_t>(outing)] - minute);
      if (std::min(apart, 1440 - apart) <= 120) near.push_back(outing);
    }
    if (near.empty()) near.push_back(p % kOutings);
    std::uniform_int_distribution<std::size_t> pick(0, near.size() - 1);
    Uuid previous;
    for (int place = 0; place < kDownloadPlaces; ++place) {
      const Uuid& at = scene.nodes[node_at(near[pick(rng)], place)].id;
      if (place > 0) add_edge(previous, at, EdgeKind::kPath, path.id);
      previous = at;
    }
  }
  return scene;
}

const DownloadScene& TheDownloadScene() {
  static const DownloadScene scene = MakeDownloadScene();
  return scene;
}

void RunPolicy(benchmark::State& state, const char* name) {
  const DownloadScene& scene = TheDownloadScene();
  DownloadPolicy policy = ParseDownloadPolicy(name);
  policy.mission_start_min = 9 * 60;
  policy.window_min = 180;
  if (policy.budget_bytes)
    policy.budget_bytes = std::int64_t{kOutings * kDownloadPlaces} * 1000 / 4;
  DownloadSelection selection;
  for (auto _ : state) {
    selection = SelectDownload(scene.nodes, scene.edges, scene.paths, policy);
    benchmark::DoNotOptimize(selection.nodes.data());
  }
  state.counters["nodes"] = static_cast<double>(selection.report.nodes);
  state.counters["bridging"] = static_cast<double>(selection.report.integrity.bridging_nodes);
  state.counters["MB"] = static_cast<double>(selection.report.bytes) / 1e6;
}

void BM_Download_Copy(benchmark::State& state) {
  RunPolicy(state, "copy");
}
BENCHMARK(BM_Download_Copy)->Unit(benchmark::kMillisecond);
void BM_Download_TodPaths(benchmark::State& state) {
  RunPolicy(state, "tod+paths");
}
BENCHMARK(BM_Download_TodPaths)->Unit(benchmark::kMillisecond);
void BM_Download_Budget(benchmark::State& state) {
  RunPolicy(state, "budget");
}
BENCHMARK(BM_Download_Budget)->Unit(benchmark::kMillisecond);
void BM_Download_TodBudget(benchmark::State& state) {
  RunPolicy(state, "tod+budget");
}
BENCHMARK(BM_Download_TodBudget)->Unit(benchmark::kMillisecond);
void BM_Download_TodPathsBudget(benchmark::State& state) {
  RunPolicy(state, "tod+paths+budget");
}
BENCHMARK(BM_Download_TodPathsBudget)->Unit(benchmark::kMillisecond);

// One MakeIntegral over the whole map for a path's worth of nodes: what a budget check would
// cost if every candidate were judged by rebuilding the integral map.
void BM_Download_OneMakeIntegral(benchmark::State& state) {
  const DownloadScene& scene = TheDownloadScene();
  std::vector<Uuid> selected;
  for (const Edge& edge : scene.edges) {
    if (edge.kind == EdgeKind::kPath && edge.path == scene.paths[0].id) {
      selected.push_back(edge.from);
    }
  }
  for (auto _ : state) {
    IntegralSelection integral = MakeIntegral(scene.node_ids, scene.edges, selected);
    benchmark::DoNotOptimize(integral.nodes.data());
  }
}
BENCHMARK(BM_Download_OneMakeIntegral)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace fleetmap
