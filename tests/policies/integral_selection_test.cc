// DOWNLOAD's map integrity: completed selections have no dangling edges and no more metric
// components than the map parts they came from.
#include "fleetmap/map_management/integral_selection.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <vector>

#include "fleetmap/core/error.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

// Short names for the readable test UUIDs.

Edge Metric(int id, int from, int to) {
  Edge edge;
  edge.id = NumberedUuid(id);
  edge.from = NumberedUuid(from);
  edge.to = NumberedUuid(to);
  edge.kind = EdgeKind::kMetric;
  return edge;
}

Edge PathEdge(int id, int from, int to) {
  Edge edge = Metric(id, from, to);
  edge.kind = EdgeKind::kPath;
  edge.path = NumberedUuid(999);
  return edge;
}

// Chain 0-1-2-...-9 (edges 100..108), a branch 3-10-11 (109, 110), a separate chain 20-21
// (111), and path edges 0→9 (200) and 1→20 (201).
struct Map {
  std::vector<Uuid> nodes;
  std::vector<Edge> edges;
};

Map MakeMap() {
  Map map;
  for (int n : {0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 20, 21}) map.nodes.push_back(NumberedUuid(n));
  for (int i = 0; i < 9; ++i) map.edges.push_back(Metric(100 + i, i, i + 1));
  map.edges.push_back(Metric(109, 3, 10));
  map.edges.push_back(Metric(110, 10, 11));
  map.edges.push_back(Metric(111, 20, 21));
  map.edges.push_back(PathEdge(200, 0, 9));
  map.edges.push_back(PathEdge(201, 1, 20));
  return map;
}

TEST(IntegralSelection, GapsInAChainAreBridgedByTheShortestWay) {
  const Map map = MakeMap();
  const std::vector<Uuid> selected = NumberedUuids({0, 1, 5, 6, 11});
  const IntegralSelection result = MakeIntegral(map.nodes, map.edges, selected);
  // 1 → 5 needs 2, 3, 4; 11 hangs off 3 through 10.
  EXPECT_EQ(result.nodes, NumberedUuids({0, 1, 2, 3, 4, 5, 6, 10, 11}));
  EXPECT_EQ(result.report.map_components, 2u);
  EXPECT_EQ(result.report.touched_components, 1u);
  EXPECT_EQ(result.report.fragments_before, 3u);
  EXPECT_EQ(result.report.components_after, 1u);
  EXPECT_EQ(result.report.bridging_nodes, 4u);
  // Metric edges inside the selection only; the path edge 0→9 lost its end 9.
  EXPECT_EQ(result.edges, NumberedUuids({100, 101, 102, 103, 104, 105, 109, 110}));
}

TEST(IntegralSelection, SeparateMapPartsStaySeparateAndPathEdgesNeverBridge) {
  const Map map = MakeMap();
  const std::vector<Uuid> selected = NumberedUuids({1, 20, 21});
  const IntegralSelection result = MakeIntegral(map.nodes, map.edges, selected);
  EXPECT_EQ(result.nodes, NumberedUuids({1, 20, 21}));
  EXPECT_EQ(result.report.touched_components, 2u);
  EXPECT_EQ(result.report.components_after, 2u);
  EXPECT_EQ(result.report.bridging_nodes, 0u);
  EXPECT_EQ(result.edges, NumberedUuids({111, 201}));  // the path edge 1→20 has both ends: kept
}

TEST(IntegralSelection, EverySelectionComesOutWithoutDanglingEdgesOrNewFragments) {
  const Map map = MakeMap();
  // Every subset of the first chain's ten nodes.
  for (int mask = 0; mask < 1024; ++mask) {
    std::vector<Uuid> selected;
    for (int i = 0; i < 10; ++i) {
      if (mask & (1 << i)) selected.push_back(NumberedUuid(i));
    }
    const IntegralSelection result = MakeIntegral(map.nodes, map.edges, selected);
    EXPECT_EQ(result.report.components_after, mask == 0 ? 0u : 1u) << mask;
    for (const Uuid& id : selected) {
      EXPECT_TRUE(std::binary_search(result.nodes.begin(), result.nodes.end(), id)) << mask;
    }
    for (const Edge& edge : map.edges) {
      const bool kept = std::binary_search(result.edges.begin(), result.edges.end(), edge.id);
      const bool ends_in =
          std::binary_search(result.nodes.begin(), result.nodes.end(), edge.from) &&
          std::binary_search(result.nodes.begin(), result.nodes.end(), edge.to);
      EXPECT_EQ(kept, ends_in) << mask;
    }
    // A chain needs exactly the span between its outermost selected nodes.
    if (mask != 0) {
      const int lo = __builtin_ctz(static_cast<unsigned>(mask));
      const int hi = 31 - __builtin_clz(static_cast<unsigned>(mask));
      EXPECT_EQ(result.nodes.size(), static_cast<std::size_t>(hi - lo + 1)) << mask;
    }
  }
}

TEST(IntegralSelection, EmptySelectionAndBadInput) {
  const Map map = MakeMap();
  const IntegralSelection empty = MakeIntegral(map.nodes, map.edges, {});
  EXPECT_TRUE(empty.nodes.empty());
  EXPECT_TRUE(empty.edges.empty());
  EXPECT_EQ(empty.report.map_components, 2u);
  EXPECT_EQ(empty.report.components_after, 0u);

  const std::vector<Uuid> unknown = NumberedUuids({1, 77});
  EXPECT_THROW(MakeIntegral(map.nodes, map.edges, unknown), Error);
  std::vector<Edge> dangling = map.edges;
  dangling.push_back(Metric(300, 9, 88));
  const std::vector<Uuid> one = NumberedUuids({1});
  EXPECT_THROW(MakeIntegral(map.nodes, dangling, one), Error);
}

}  // namespace
}  // namespace fleetmap
