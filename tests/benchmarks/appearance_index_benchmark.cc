// Appearance index micro-benchmarks (relocalisation, seed 004 §III-B): a map of 5000 places of
// 150 random descriptors each, a default vocabulary (10 x 3, up to 1000 words) trained on 200 of
// them, and revisit queries (5% of bits flipped, 30% of descriptors replaced).
//
// Targets: Query over 5000 places <= 2 ms; Add <= 200 us.
#include <benchmark/benchmark.h>

#include <algorithm>
#include <memory>
#include <numeric>
#include <random>
#include <vector>

#include "fleetmap/ebn/appearance_index.h"
#include "landmark_scene.h"

namespace fleetmap {
namespace {

constexpr std::size_t kIndexPlaces = 5000;
constexpr std::size_t kIndexDescriptorsPerPlace = 150;
constexpr std::size_t kTrainingPlaces = 200;

Uuid PlaceId(std::size_t place) {
  Uuid::Bytes bytes{};
  for (std::size_t b = 0; b < 8; ++b) bytes[15 - b] = static_cast<std::uint8_t>(place >> (8 * b));
  return Uuid(bytes);
}

struct Map {
  std::vector<std::vector<Descriptor256>> places;
  std::vector<Descriptor256> training_sample;
  std::shared_ptr<const AppearanceVocabulary> vocabulary;
  std::unique_ptr<AppearanceIndex> index;
};

const Map& TheMap() {
  static const Map map = [] {
    Map m;
    std::mt19937 rng(11);
    for (std::size_t p = 0; p < kIndexPlaces; ++p) {
      m.places.push_back(testing::RandomDescriptors(kIndexDescriptorsPerPlace, rng));
    }
    for (std::size_t p = 0; p < kIndexPlaces; p += kIndexPlaces / kTrainingPlaces) {
      m.training_sample.insert(m.training_sample.end(), m.places[p].begin(), m.places[p].end());
    }
    m.vocabulary = std::make_shared<const AppearanceVocabulary>(
        AppearanceVocabulary::Train(m.training_sample));
    m.index = std::make_unique<AppearanceIndex>(m.vocabulary);
    for (std::size_t p = 0; p < kIndexPlaces; ++p) m.index->Add(PlaceId(p), m.places[p]);
    return m;
  }();
  return map;
}

void BM_AppearanceTrain(benchmark::State& state) {
  const Map& map = TheMap();
  for (auto _ : state) {
    benchmark::DoNotOptimize(AppearanceVocabulary::Train(map.training_sample));
  }
  state.counters["sample"] = static_cast<double>(map.training_sample.size());
  state.counters["words"] = map.vocabulary->word_count();
}
BENCHMARK(BM_AppearanceTrain)->Unit(benchmark::kMillisecond)->Iterations(3);

// A revisit of a random place against all 5000; the counter checks the work is meaningful.
void BM_AppearanceQuery(benchmark::State& state) {
  const Map& map = TheMap();
  std::mt19937 rng(3);
  std::vector<std::size_t> truth;
  std::vector<std::vector<Descriptor256>> queries;
  for (int q = 0; q < 64; ++q) {
    truth.push_back(rng() % kIndexPlaces);
    queries.push_back(testing::RevisitPlace(map.places[truth.back()], rng));
  }
  std::size_t next = 0, queried = 0, top1 = 0;
  for (auto _ : state) {
    const std::vector<AppearanceMatch> matches = map.index->Query(queries[next], 5);
    top1 += !matches.empty() && matches[0].node == PlaceId(truth[next]) ? 1 : 0;
    ++queried;
    next = (next + 1) % queries.size();
  }
  state.counters["top1"] = static_cast<double>(top1) / static_cast<double>(queried);
}
BENCHMARK(BM_AppearanceQuery)->Unit(benchmark::kMicrosecond);

// A new place into a copy of the 5000-place index (it grows to 5000 + iterations places).
void BM_AppearanceAdd(benchmark::State& state) {
  const Map& map = TheMap();
  AppearanceIndex index = *map.index;
  std::size_t added = 0;
  for (auto _ : state) {
    index.Add(PlaceId(kIndexPlaces + added), map.places[added % kIndexPlaces]);
    ++added;
  }
  state.counters["places_at_end"] = static_cast<double>(index.size());
}
BENCHMARK(BM_AppearanceAdd)->Unit(benchmark::kMicrosecond)->Iterations(1000);

// Re-adding an indexed place with new descriptors: its postings are removed, then posted again.
void BM_AppearanceReAdd(benchmark::State& state) {
  const Map& map = TheMap();
  AppearanceIndex index = *map.index;
  std::size_t next = 0;
  for (auto _ : state) {
    index.Add(PlaceId(next % kIndexPlaces), map.places[(next + 1) % kIndexPlaces]);
    ++next;
  }
}
BENCHMARK(BM_AppearanceReAdd)->Unit(benchmark::kMicrosecond)->Iterations(1000);

}  // namespace
}  // namespace fleetmap
