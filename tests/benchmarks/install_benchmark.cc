// What a robot's install costs (LocalMap::Install): an incremental download of a twelfth of
// the map onto an installed map, beside the full install of the whole map (the baseline, what
// the install of changes did before it was made in place). The ratio is the figure: an install
// should cost what it changes, not the map. Run by hand:
//   build/tests/benchmarks/install_benchmark --benchmark_counters_tabular=true
// Counters: peak_mib, the growth of the process' peak resident memory over the install. Also the
// digest a sync with nothing new reads, beside the map read whole.
#include <benchmark/benchmark.h>

#include <filesystem>
#include <map>
#include <string>

#include "fleetmap/agent/local_map.h"
#include "fleetmap/store/graph_store.h"
#include "peak_memory.h"
#include "random_robot_map.h"
#include "scratch_dir.h"

namespace fleetmap::testing {
namespace {

namespace fs = std::filesystem;

MapDownload Full(const GraphBatch& map, std::int64_t revision) {
  MapDownload download;
  download.revision = revision;
  download.content = map;
  download.nodes = map.nodes.size();
  download.edges = map.edges.size();
  download.paths = map.paths.size();
  return download;
}

GraphBatch Join(GraphBatch a, const GraphBatch& b) {
  a.nodes.insert(a.nodes.end(), b.nodes.begin(), b.nodes.end());
  a.edges.insert(a.edges.end(), b.edges.begin(), b.edges.end());
  a.paths.insert(a.paths.end(), b.paths.begin(), b.paths.end());
  return a;
}

// The installed map (range(0) nodes, another robot's) and the next revision's new nodes.
struct Maps {
  GraphBatch installed;
  GraphBatch added;
};
const Maps& MapsOf(int nodes) {
  static std::map<int, Maps> maps;
  auto [it, inserted] = maps.try_emplace(nodes);
  if (inserted) {
    it->second.installed = RandomRobotMap(Uuid::Generate(), nodes, 7);
    it->second.added = RandomRobotMap(Uuid::Generate(), nodes / 12, 8);
  }
  return it->second;
}

void Report(benchmark::State& state, std::int64_t before) {
  state.counters["peak_mib"] =
      static_cast<double>(PeakMemoryBytes() - before) / static_cast<double>(1 << 20);
}

// Baseline: the whole next map installed from a full download.
void FullInstall(benchmark::State& state) {
  const Maps& maps = MapsOf(static_cast<int>(state.range(0)));
  const GraphBatch next = Join(maps.installed, maps.added);
  for (auto _ : state) {
    state.PauseTiming();
    const ScratchDir dir("fleetmap-install-bench");
    LocalMap map = LocalMap::Open(dir / "robot");
    ResetPeakMemory();
    const std::int64_t before = PeakMemoryBytes("VmRSS:");
    state.ResumeTiming();
    map.Install(Full(next, 2));
    state.PauseTiming();
    Report(state, before);
    state.ResumeTiming();
  }
}
BENCHMARK(FullInstall)->Arg(20'000)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

// The same next map reached by installing revision 2's changes onto revision 1.
void IncrementalInstall(benchmark::State& state) {
  const Maps& maps = MapsOf(static_cast<int>(state.range(0)));
  const ScratchDir prepared("fleetmap-install-bench");
  {
    LocalMap map = LocalMap::Open(prepared / "robot");
    map.Install(Full(maps.installed, 1));
  }
  MapDownload changes;
  changes.revision = 2;
  changes.base_revision = 1;
  changes.content = maps.added;
  changes.nodes = maps.installed.nodes.size() + maps.added.nodes.size();
  changes.edges = maps.installed.edges.size() + maps.added.edges.size();
  changes.paths = maps.installed.paths.size() + maps.added.paths.size();
  for (auto _ : state) {
    state.PauseTiming();
    const ScratchDir dir("fleetmap-install-bench");
    fs::copy(prepared / "robot", dir / "robot", fs::copy_options::recursive);
    fs::remove(dir / "robot" / "agent.lock");
    LocalMap map = LocalMap::Open(dir / "robot");
    ResetPeakMemory();
    const std::int64_t before = PeakMemoryBytes("VmRSS:");
    state.ResumeTiming();
    const InstallReport report = map.Install(changes);
    state.PauseTiming();
    Report(state, before);
    state.counters["nodes_read"] = static_cast<double>(report.nodes_read);
    state.ResumeTiming();
  }
}
BENCHMARK(IncrementalInstall)
    ->Arg(20'000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

// A sync with nothing new reads the installed selection back for its digest (so a damaged map
// shows): LocalMap::ReadInstalledDigest, a batch of nodes at a time, beside the map read whole
// (GraphStore::ReadMap, the baseline: what the digest read before).
// `read` over an installed map of range(0) nodes, timed with the growth of the peak memory.
template <typename Read>
void ReadInstalledMap(benchmark::State& state, Read read) {
  const Maps& maps = MapsOf(static_cast<int>(state.range(0)));
  const ScratchDir dir("fleetmap-install-bench");
  LocalMap map = LocalMap::Open(dir / "robot");
  map.Install(Full(maps.installed, 1));
  for (auto _ : state) {
    ResetPeakMemory();
    const std::int64_t before = PeakMemoryBytes("VmRSS:");
    read(map);
    Report(state, before);
  }
}

void InstalledDigest(benchmark::State& state) {
  ReadInstalledMap(state,
                   [](LocalMap& map) { benchmark::DoNotOptimize(map.ReadInstalledDigest()); });
}
BENCHMARK(InstalledDigest)
    ->Arg(20'000)
    ->Unit(benchmark::kMillisecond)
    ->Iterations(2)
    ->UseRealTime();

void MapReadWhole(benchmark::State& state) {
  ReadInstalledMap(state, [](LocalMap& map) {
    benchmark::DoNotOptimize(GraphStore::Open(map.map_uri())->ReadMap());
  });
}
BENCHMARK(MapReadWhole)->Arg(20'000)->Unit(benchmark::kMillisecond)->Iterations(2)->UseRealTime();

}  // namespace
}  // namespace fleetmap::testing

BENCHMARK_MAIN();
