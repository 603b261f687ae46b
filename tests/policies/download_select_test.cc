// DOWNLOAD (seed 004 §V-B) end to end: policy names, copy (Eq. 3), time of day (Eq. 4), the
// best paths (Algorithms 2–3, Eq. 7), the byte budget, and the integrity of every download.
// Expectations are worked by hand on small maps; the comments show the working.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "day_stamps.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/subset_contraction.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

struct TestMap {
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Path> paths;

  // A node of `bytes` landmark bytes (0: bare, as a store returns nodes without landmarks).
  void AddNode(int n, std::int64_t stamp_ns, int bytes = 10) {
    Node node;
    node.id = NumberedUuid(n);
    node.stamp_ns = stamp_ns;
    node.landmarks_blob = std::string(static_cast<std::size_t>(bytes), 'x');
    nodes.push_back(node);
  }
  void AddMetric(int id, int from, int to) {
    Edge edge;
    edge.id = NumberedUuid(id);
    edge.from = NumberedUuid(from);
    edge.to = NumberedUuid(to);
    edges.push_back(edge);
  }
  void AddPath(int id) {
    Path path;
    path.id = NumberedUuid(id);
    paths.push_back(path);
  }
  void AddPathEdge(int id, int path, int from, int to) {
    AddMetric(id, from, to);
    edges.back().kind = EdgeKind::kPath;
    edges.back().path = NumberedUuid(path);
  }

  DownloadSelection Select(const DownloadPolicy& policy) const {
    return SelectDownload(nodes, edges, paths, policy);
  }
};

// Integrity checked independently of MakeIntegral: no kept edge has an end outside the
// download, every map edge with both ends kept is kept, the kept paths are those of kept path
// edges, and the download has exactly as many metric components (own union-find) as the map
// components it touches.
class ConnectedParts {
 public:
  const Uuid& Root(const Uuid& id) {
    auto it = parent_.try_emplace(id, id).first;
    if (it->second == id) return it->second;
    const Uuid root = Root(it->second);
    return parent_[id] = root;
  }
  void Join(const Uuid& a, const Uuid& b) { parent_[Root(a)] = Root(b); }

 private:
  std::map<Uuid, Uuid> parent_;
};

void ExpectIntegral(const TestMap& map, const DownloadSelection& download) {
  const std::set<Uuid> kept(download.nodes.begin(), download.nodes.end());
  const std::set<Uuid> kept_edges(download.edges.begin(), download.edges.end());
  ConnectedParts whole, part;
  std::set<Uuid> kept_paths;
  for (const Edge& edge : map.edges) {
    const bool both_ends = kept.contains(edge.from) && kept.contains(edge.to);
    EXPECT_EQ(kept_edges.contains(edge.id), both_ends) << "edge " << edge.id.ToString();
    if (both_ends && edge.kind == EdgeKind::kPath) kept_paths.insert(edge.path);
    if (edge.kind != EdgeKind::kMetric) continue;
    whole.Join(edge.from, edge.to);
    if (both_ends) part.Join(edge.from, edge.to);
  }
  std::set<Uuid> touched, fragments;
  for (const Uuid& id : kept) {
    touched.insert(whole.Root(id));
    fragments.insert(part.Root(id));
  }
  EXPECT_EQ(fragments.size(), touched.size()) << "the download fell apart";
  EXPECT_EQ(download.report.integrity.touched_components, touched.size());
  EXPECT_EQ(download.report.integrity.components_after, touched.size());
  // Contracted edges (subset_contraction.h) join sent nodes only, carry derived ids, and put
  // their paths in the download; a policy that does not contract has none.
  for (const Edge& edge : download.derived_edges) {
    EXPECT_TRUE(kept.contains(edge.from) && kept.contains(edge.to)) << edge.id.ToString();
    EXPECT_TRUE(IsDerivedEdge(edge)) << edge.id.ToString();
    if (edge.kind == EdgeKind::kPath) kept_paths.insert(edge.path);
  }
  EXPECT_EQ(download.paths, std::vector<Uuid>(kept_paths.begin(), kept_paths.end()));
  EXPECT_EQ(download.report.nodes, download.nodes.size());
  EXPECT_EQ(download.report.derived_edges, download.derived_edges.size());
  EXPECT_EQ(download.report.edges, download.edges.size() + download.derived_edges.size());
  EXPECT_EQ(download.report.paths, download.paths.size());
}

// ---------------------------------------------------------------------------------------
// Names and parameters

TEST(DownloadPolicyName, EveryValidNameParsesAndPrintsInCanonicalOrder) {
  struct Case {
    const char* name;
    bool tod, paths, budget;
    const char* canonical;
  };
  const Case cases[] = {
      {"copy", false, false, false, "copy"},
      {"tod", true, false, false, "tod"},
      {"paths", false, true, false, "paths"},
      {"tod+paths", true, true, false, "tod+paths"},
      {"budget", false, false, true, "budget"},
      {"tod+budget", true, false, true, "tod+budget"},
      {"paths+budget", false, true, true, "paths+budget"},
      {"tod+paths+budget", true, true, true, "tod+paths+budget"},
      // Parts are a set: any order reads the same.
      {"paths+tod", true, true, false, "tod+paths"},
      {"budget+paths+tod", true, true, true, "tod+paths+budget"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const DownloadPolicy policy = ParseDownloadPolicy(c.name);
    EXPECT_EQ(policy.time_of_day, c.tod);
    EXPECT_EQ(policy.paths, c.paths);
    EXPECT_EQ(policy.budget_bytes.has_value(), c.budget);
    if (c.budget) {
      EXPECT_EQ(*policy.budget_bytes, std::int64_t{1} << 28);  // 256 MiB
    }
    EXPECT_EQ(policy.Name(), c.canonical);
    EXPECT_NO_THROW(ValidateDownloadPolicy(policy));
  }
}

TEST(DownloadPolicyName, RejectsUnknownEmptyRepeatedAndCopyJoined) {
  // Each bad name with a piece of text its message must contain.
  const std::pair<const char*, const char*> bad[] = {
      {"", "empty name"},
      {"foo", "\"foo\""},
      {"tod+tod", "\"tod\" repeated"},
      {"budget+paths+budget", "\"budget\" repeated"},
      {"paths+copy", "\"copy\" stands alone"},
      {"copy+budget", "\"copy\" stands alone"},
      {"copy+copy", "\"copy\" repeated"},
      {"tod+", "empty part"},
      {"+tod", "empty part"},
      {"Tod", "\"Tod\""},
      {"tod +paths", "\"tod \""},
  };
  for (const auto& [name, says] : bad) {
    SCOPED_TRACE(name);
    try {
      ParseDownloadPolicy(name);
      ADD_FAILURE() << "accepted";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::kInvalidArgument);
      EXPECT_NE(std::string(error.what()).find(says), std::string::npos) << error.what();
    }
  }
}

TEST(DownloadPolicyName, CoverPoliciesDefaultToTheirOwnWindow) {
  // The paper's policies keep its T_w; those with the coverage guarantee default to theirs.
  for (const char* name : {"tod", "tod+paths", "paths", "copy", "tod+budget"}) {
    EXPECT_EQ(ParseDownloadPolicy(name).window_min, 180.0) << name;
  }
  for (const char* name : {"tod+cover", "tod+paths+cover", "cover", "route+tod+cover"}) {
    EXPECT_EQ(ParseDownloadPolicy(name).window_min, kCoverWindowMin) << name;
  }
  EXPECT_LT(kCoverWindowMin, 180.0);
}

TEST(DownloadPolicyName, NameFollowsTheFlags) {
  DownloadPolicy policy;
  EXPECT_EQ(policy.Name(), "copy");
  policy.budget_bytes = 5;
  EXPECT_EQ(policy.Name(), "budget");
  policy.time_of_day = true;
  EXPECT_EQ(policy.Name(), "tod+budget");
}

TEST(DownloadPolicyValidate, NamesTheParameterOutOfRange) {
  const auto expect_bad = [](DownloadPolicy policy, const char* parameter) {
    SCOPED_TRACE(parameter);
    try {
      ValidateDownloadPolicy(policy);
      ADD_FAILURE() << "accepted";
    } catch (const Error& error) {
      EXPECT_EQ(error.code(), ErrorCode::kInvalidArgument);
      EXPECT_NE(std::string(error.what()).find(parameter), std::string::npos) << error.what();
    }
  };
  DownloadPolicy policy;
  EXPECT_NO_THROW(ValidateDownloadPolicy(policy));
  policy.mission_start_min = 1439.5;
  EXPECT_NO_THROW(ValidateDownloadPolicy(policy));

  policy = {};
  policy.mission_start_min = 1440;
  expect_bad(policy, "mission_start_min");
  policy.mission_start_min = -0.5;
  expect_bad(policy, "mission_start_min");
  policy = {};
  policy.mission_end_min = 1500;
  expect_bad(policy, "mission_end_min");
  policy = {};
  policy.window_min = 0;
  expect_bad(policy, "window_min");
  policy.window_min = std::numeric_limits<double>::infinity();
  expect_bad(policy, "window_min");
  policy = {};
  policy.epoch_min = 0;
  expect_bad(policy, "epoch_min");
  policy.epoch_min = 1441;
  expect_bad(policy, "epoch_min");
  policy = {};
  policy.best_percent = 0;
  expect_bad(policy, "best_percent");
  policy.best_percent = 100.5;
  expect_bad(policy, "best_percent");
  policy = {};
  policy.budget_bytes = 0;
  expect_bad(policy, "budget_bytes");
  policy.epoch_min = std::numeric_limits<double>::quiet_NaN();  // the first bad one is named
  expect_bad(policy, "epoch_min");
}

// ---------------------------------------------------------------------------------------
// copy and tod

// Two metric components: the chain 1-2-3 and 4-5, path P90 1→2, 4→5, P91 3→5 (a path edge
// across components, which never joins them). Node bytes 10, 20, 30, 40, 50.
TestMap TwoPartMap() {
  TestMap map;
  for (int n = 1; n <= 5; ++n) map.AddNode(n, At(n, 0), 10 * n);
  map.AddMetric(101, 1, 2);
  map.AddMetric(102, 2, 3);
  map.AddMetric(103, 4, 5);
  map.AddPath(90);
  map.AddPath(91);
  map.AddPathEdge(201, 90, 1, 2);
  map.AddPathEdge(202, 90, 4, 5);
  map.AddPathEdge(203, 91, 3, 5);
  return map;
}

TEST(DownloadSelect, CopyKeepsEverything) {
  const TestMap map = TwoPartMap();
  const DownloadSelection copy = map.Select(ParseDownloadPolicy("copy"));
  EXPECT_EQ(copy.nodes, NumberedUuids({1, 2, 3, 4, 5}));
  EXPECT_EQ(copy.edges, NumberedUuids({101, 102, 103, 201, 202, 203}));
  EXPECT_EQ(copy.paths, NumberedUuids({90, 91}));
  EXPECT_EQ(copy.report.policy, "copy");
  EXPECT_EQ(copy.report.map_nodes, 5u);
  EXPECT_EQ(copy.report.picked_nodes, 5u);
  EXPECT_EQ(copy.report.map_bytes, 150);
  EXPECT_EQ(copy.report.bytes, 150);
  EXPECT_EQ(copy.report.paths_chosen, 0u);
  EXPECT_FALSE(copy.report.epoch_start.has_value());
  EXPECT_EQ(copy.report.integrity.map_components, 2u);
  EXPECT_EQ(copy.report.integrity.fragments_before, 2u);
  EXPECT_EQ(copy.report.integrity.bridging_nodes, 0u);
  ExpectIntegral(map, copy);
}

TEST(DownloadSelect, CopyOfAnEmptyMapIsEmpty) {
  const DownloadSelection copy = SelectDownload({}, {}, {}, ParseDownloadPolicy("copy"));
  EXPECT_TRUE(copy.nodes.empty());
  EXPECT_TRUE(copy.edges.empty());
  EXPECT_EQ(copy.report.integrity.components_after, 0u);
}

// Mission 23:30, T_w = 60 min (Eq. 4 on the 24-hour clock):
//   n1 23:00 (30 min) kept, n2 00:15 next day (45 min) kept, n3 12:00 (690 min) dropped,
//   n4 00:30 (exactly 60 min) kept, n5 22:29 (61 min) dropped.
// Metric 1-2 (101), 2-3 (102), 3-5 (103); n4 alone.
TEST(DownloadSelect, TimeOfDayWindowWrapsAroundMidnight) {
  TestMap map;
  map.AddNode(1, At(23, 0));
  map.AddNode(2, At(0, 15, 1));
  map.AddNode(3, At(12, 0));
  map.AddNode(4, At(0, 30, 3), /*bytes=*/0);  // bare nodes are fine without a budget
  map.AddNode(5, At(22, 29));
  map.AddMetric(101, 1, 2);
  map.AddMetric(102, 2, 3);
  map.AddMetric(103, 3, 5);
  DownloadPolicy tod = ParseDownloadPolicy("tod");
  tod.mission_start_min = 23 * 60 + 30;
  tod.window_min = 60;
  const DownloadSelection download = map.Select(tod);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 4}));
  EXPECT_EQ(download.edges, NumberedUuids({101}));
  EXPECT_EQ(download.report.picked_nodes, 3u);
  EXPECT_EQ(download.report.bytes, 20);
  EXPECT_EQ(download.report.map_bytes, 40);
  EXPECT_EQ(download.report.integrity.touched_components, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 0u);
  EXPECT_FALSE(download.report.epoch_start.has_value());  // "tod" alone walks no epochs
  ExpectIntegral(map, download);

  // At 12:00 the same window keeps n3 only.
  tod.mission_start_min = 12 * 60;
  EXPECT_EQ(map.Select(tod).nodes, NumberedUuids({3}));
}

// The chain 1-3-2: a mission at 23:30 picks n1 (23:00) and n2 (00:15); n3 (12:00) joins them
// as a bridge and is sent, so it counts in the bytes.
TEST(DownloadSelect, BridgingNodesKeepTheDownloadInOnePiece) {
  TestMap map;
  map.AddNode(1, At(23, 0), 10);
  map.AddNode(2, At(0, 15), 20);
  map.AddNode(3, At(12, 0), 40);
  map.AddMetric(101, 1, 3);
  map.AddMetric(102, 3, 2);
  DownloadPolicy tod = ParseDownloadPolicy("tod");
  tod.mission_start_min = 23 * 60 + 30;
  tod.window_min = 60;
  const DownloadSelection download = map.Select(tod);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3}));
  EXPECT_EQ(download.edges, NumberedUuids({101, 102}));
  EXPECT_EQ(download.report.picked_nodes, 2u);
  EXPECT_EQ(download.report.integrity.fragments_before, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 1u);
  EXPECT_EQ(download.report.bytes, 70);
  ExpectIntegral(map, download);
}

// ---------------------------------------------------------------------------------------
// paths: the hand-worked example of download_policy_test.cc with a metric chain.
//
// Four 6-hour epochs. P1 (101) = {n1, n2}, P2 (102) = {n1, n3}, P3 (103) = {n3, n4}; n1 06:10
// and n2 07:00 are in epoch 1, n3 13:00 and n4 13:30 in epoch 2, n5 02:00 (epoch 0) is on no
// path.
//   PCM: P1 = [0, 2, 0, 0], P2 = [0, 1, 1, 0], P3 = [0, 0, 2, 0]
//   PWM: P1 = [0, 2/3, 0, 0], P2 = [0, 1/3, 1/3, 0], P3 = [0, 0, 2/3, 0]
// Metric chain 1-2-3-4-5 (edges 11..14); path edges 21 (P1 1→2), 22 (P2 1→3), 23 (P3 3→4).
// Every node 10 bytes.
TestMap PathsMap() {
  TestMap map;
  map.AddNode(1, At(6, 10));
  map.AddNode(2, At(7, 0, 2));
  map.AddNode(3, At(13, 0, 5));
  map.AddNode(4, At(13, 30));
  map.AddNode(5, At(2, 0));
  for (int n = 1; n <= 4; ++n) map.AddMetric(10 + n, n, n + 1);
  for (int p = 101; p <= 103; ++p) map.AddPath(p);
  map.AddPathEdge(21, 101, 1, 2);
  map.AddPathEdge(22, 102, 1, 3);
  map.AddPathEdge(23, 103, 3, 4);
  return map;
}

// Algorithm 3's selection as seed 004 gives it: the map's edges with both ends kept, nothing
// contracted over the nodes left out (what a download then carries more is
// subset_contraction_test's).
DownloadPolicy PathsPolicy(const char* name) {
  DownloadPolicy policy = ParseDownloadPolicy(name);
  policy.contract = false;
  policy.epoch_min = 360;
  policy.best_percent = 50;
  return policy;
}

TEST(DownloadSelect, PathsTakesTheBestPathOfEachEpochOfTheMission) {
  const TestMap map = PathsMap();
  DownloadPolicy paths = PathsPolicy("paths");

  // 06:30–07:30 is epoch 1 alone: its better half is P1 (2/3 against P2's 1/3).
  paths.mission_start_min = 6 * 60 + 30;
  paths.mission_end_min = 7 * 60 + 30;
  DownloadSelection download = map.Select(paths);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 21}));
  EXPECT_EQ(download.paths, NumberedUuids({101}));
  EXPECT_EQ(download.report.paths_chosen, 1u);
  EXPECT_EQ(download.report.epoch_start, 1);
  EXPECT_EQ(download.report.epoch_end, 1);
  ExpectIntegral(map, download);

  // No end: epochs 1 … k_max = 2, so P1 and P3. P2's edge 1→3 has both ends and comes too.
  paths.mission_end_min.reset();
  download = map.Select(paths);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 12, 13, 21, 22, 23}));
  EXPECT_EQ(download.paths, NumberedUuids({101, 102, 103}));
  EXPECT_EQ(download.report.paths_chosen, 2u);
  EXPECT_EQ(download.report.picked_nodes, 4u);
  EXPECT_EQ(download.report.epoch_start, 1);
  EXPECT_EQ(download.report.epoch_end, 2);
  ExpectIntegral(map, download);

  // Starting at 13:00 (epoch 2) with no end: P3 only.
  paths.mission_start_min = 13 * 60;
  download = map.Select(paths);
  EXPECT_EQ(download.nodes, NumberedUuids({3, 4}));
  EXPECT_EQ(download.paths, NumberedUuids({103}));
  ExpectIntegral(map, download);

  // Starting at 20:00 (epoch 3, after k_max) with no end: Algorithm 3 walks no epoch.
  paths.mission_start_min = 20 * 60;
  download = map.Select(paths);
  EXPECT_TRUE(download.nodes.empty());
  EXPECT_EQ(download.report.paths_chosen, 0u);
  EXPECT_FALSE(download.report.epoch_start.has_value());
  ExpectIntegral(map, download);
}

TEST(DownloadSelect, TimeOfDayAndPathsIntersect) {
  const TestMap map = PathsMap();
  // 07:00 ± 30 min: epochs of 06:30 and 07:30 are both 1, so P* = {P1} = {n1, n2}; the window
  // keeps n2 (07:00) but not n1 (06:10, 50 min away).
  DownloadPolicy policy = PathsPolicy("tod+paths");
  policy.mission_start_min = 7 * 60;
  policy.window_min = 30;
  DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({2}));
  EXPECT_TRUE(download.edges.empty());
  EXPECT_TRUE(download.paths.empty());
  EXPECT_EQ(download.report.picked_nodes, 1u);
  EXPECT_EQ(download.report.paths_chosen, 1u);
  ExpectIntegral(map, download);

  // 23:30 ± 7 h: 16:30 is in epoch 2, 06:30 in epoch 1, so the mission runs across midnight
  // through epochs 2, 3, 0, 1: P* = {P1, P3} = {n1, n2, n3, n4}. The window (16:30 … 06:30)
  // keeps n1 (06:10) and n5 (02:00, on no path): together, n1.
  policy.mission_start_min = 23 * 60 + 30;
  policy.window_min = 7 * 60;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1}));
  EXPECT_EQ(download.report.paths_chosen, 2u);
  EXPECT_EQ(download.report.epoch_start, 2);
  EXPECT_EQ(download.report.epoch_end, 1);
  ExpectIntegral(map, download);

  // T_w = 12 h keeps the whole clock and every epoch: k_min … k_max = 1 … 2, P* = {P1, P3}.
  policy.window_min = 720;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4}));
  EXPECT_EQ(download.report.epoch_start, 1);
  EXPECT_EQ(download.report.epoch_end, 2);
  ExpectIntegral(map, download);
}

// P* = {n1, n4} only, apart on the chain 1-2-3-4: the download is the whole chain.
TEST(DownloadSelect, PathsAreBridgedAlongTheMetricChain) {
  TestMap map;
  for (int n = 1; n <= 4; ++n) map.AddNode(n, At(9, n));
  for (int n = 1; n <= 3; ++n) map.AddMetric(10 + n, n, n + 1);
  map.AddPath(101);
  map.AddPathEdge(21, 101, 1, 4);
  DownloadPolicy policy = ParseDownloadPolicy("paths");
  policy.mission_start_min = 9 * 60;
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 12, 13, 21}));
  EXPECT_EQ(download.report.picked_nodes, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  EXPECT_EQ(download.report.integrity.fragments_before, 2u);
  ExpectIntegral(map, download);
}

// ---------------------------------------------------------------------------------------
// budget

// The chain 1-2-…-9 (edges 11..18) at 10:00 + n min, epoch 10 of 24 for every path node:
//   A (101) = {1, 2, 3, 4}: PCM 4, weight 4/9, 40 bytes;
//   B (102) = {7, 8, 9}:    PCM 3, weight 3/9, 120 bytes (n8 is 100), 140 with bridges 5, 6;
//   C (103) = {5, 6}:       PCM 2, weight 2/9, 20 bytes, next to A.
// Bare nodes (on no path): n10 at 09:00 hangs off n1 (edge 19), n11 at 10:30 stands alone.
TestMap BudgetMap() {
  TestMap map;
  for (int n = 1; n <= 9; ++n) map.AddNode(n, At(10, n), n == 8 ? 100 : 10);
  map.AddNode(10, At(9, 0));
  map.AddNode(11, At(10, 30));
  for (int n = 1; n <= 8; ++n) map.AddMetric(10 + n, n, n + 1);
  map.AddMetric(19, 1, 10);
  for (int p = 101; p <= 103; ++p) map.AddPath(p);
  for (const auto& [edge, path, from, to] : std::vector<std::array<int, 4>>{{21, 101, 1, 2},
                                                                            {22, 101, 2, 3},
                                                                            {23, 101, 3, 4},
                                                                            {24, 102, 7, 8},
                                                                            {25, 102, 8, 9},
                                                                            {26, 103, 5, 6}}) {
    map.AddPathEdge(edge, path, from, to);
  }
  return map;
}

TEST(DownloadSelect, BudgetTakesPathsByWeightAndSkipsOneThatDoesNotFit) {
  const TestMap map = BudgetMap();
  DownloadPolicy policy = ParseDownloadPolicy("budget");
  policy.mission_start_min = 10 * 60;
  policy.budget_bytes = 70;
  // A (40) fits; B would make 40 + 140: skipped; C (20) fits: 60. Bare nodes by clock distance
  // from 10:00: n11 (30 min, 10 bytes) fits exactly, 70; then n10 (60 min) cannot.
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4, 5, 6, 11}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 12, 13, 14, 15, 21, 22, 23, 26}));
  EXPECT_EQ(download.paths, NumberedUuids({101, 103}));
  EXPECT_EQ(download.report.bytes, 70);
  EXPECT_EQ(download.report.map_bytes, 200);
  EXPECT_EQ(download.report.picked_nodes, 7u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 0u);
  EXPECT_EQ(download.report.epoch_start, 10);  // the only epoch with path data
  EXPECT_EQ(download.report.epoch_end, 10);
  ExpectIntegral(map, download);

  // With room for B and its bridges (40 + 140 + n11), C comes free as B's bridge: 190.
  policy.budget_bytes = 190;
  const DownloadSelection wider = map.Select(policy);
  EXPECT_EQ(wider.nodes, NumberedUuids({1, 2, 3, 4, 5, 6, 7, 8, 9, 11}));
  EXPECT_EQ(wider.report.bytes, 190);
  EXPECT_EQ(wider.report.picked_nodes, 10u);  // C's turn picks n5, n6 on merit
  EXPECT_EQ(wider.report.integrity.bridging_nodes, 0u);
  ExpectIntegral(map, wider);

  // 179: A with B and its bridges is 180, so B is skipped; A, C and n11 (70), then n10 (80).
  policy.budget_bytes = 179;
  EXPECT_EQ(map.Select(policy).nodes, NumberedUuids({1, 2, 3, 4, 5, 6, 10, 11}));
}

// The chain 1-2-3-4-5, 10 bytes each; one path P (101) over n1 and n4 only (edge 21), and n5
// on no path. n1, n4, n5 at 08:01, 08:04, 08:05; n2 and n3 at 14:00, outside a mission window
// of 08:00 ± 30 min, so they can only come as bridges: P with them is 40 bytes.
TestMap BridgedPathMap() {
  TestMap map;
  for (int n = 1; n <= 5; ++n) map.AddNode(n, n == 2 || n == 3 ? At(14, 0) : At(8, n));
  for (int n = 1; n <= 4; ++n) map.AddMetric(10 + n, n, n + 1);
  map.AddPath(101);
  map.AddPathEdge(21, 101, 1, 4);
  return map;
}

TEST(DownloadSelect, BudgetCountsBridgingNodes) {
  const TestMap map = BridgedPathMap();
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 8 * 60;
  policy.window_min = 30;

  policy.budget_bytes = 45;  // P with bridges: 40; n5 would make 50
  DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 12, 13, 21}));
  EXPECT_EQ(download.report.bytes, 40);
  EXPECT_EQ(download.report.picked_nodes, 2u);
  EXPECT_EQ(download.report.integrity.fragments_before, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  ExpectIntegral(map, download);

  policy.budget_bytes = 50;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4, 5}));
  EXPECT_EQ(download.report.picked_nodes, 3u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  ExpectIntegral(map, download);

  // P alone is 20 bytes, but integral it is 40: it does not fit 35, and then n5 alone does.
  policy.budget_bytes = 35;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({5}));
  EXPECT_EQ(download.report.bytes, 10);
  ExpectIntegral(map, download);

  // Not even a bare node fits: an empty download.
  policy.budget_bytes = 9;
  download = map.Select(policy);
  EXPECT_TRUE(download.nodes.empty());
  EXPECT_TRUE(download.edges.empty());
  EXPECT_EQ(download.report.bytes, 0);
  EXPECT_EQ(download.report.picked_nodes, 0u);
  EXPECT_EQ(download.report.integrity.touched_components, 0u);
  ExpectIntegral(map, download);
}

// Two equally short ways between n1 and n4: 1-2-6-4 (n2, n6: 50 bytes each) and 1-3-5-4 (n3,
// n5: 10 bytes each); n1, n4 10 bytes. A (101) = {n1} and B (102) = {n4} weigh the same (one
// node each in epoch 8), so A goes first. n1 and n4 are at 08:00, the rest at 20:00, outside
// the mission's window: they come only as bridges.
//   The fill joins n4 to n1 searching from n4 (neighbours n5 < n6): via n5, n3, 40 bytes.
//   MakeIntegral of the picks {n1, n4} searches from n1 (neighbours n2 < n3): via n2, n6, 120.
TEST(DownloadSelect, BudgetKeepsItsOwnBridgesWhenMakeIntegralsDoNotFit) {
  TestMap map;
  for (int n = 1; n <= 6; ++n) {
    map.AddNode(n, n == 1 || n == 4 ? At(8, 0) : At(20, 0), n == 2 || n == 6 ? 50 : 10);
  }
  map.AddMetric(11, 1, 2);
  map.AddMetric(12, 2, 6);
  map.AddMetric(13, 6, 4);
  map.AddMetric(14, 1, 3);
  map.AddMetric(15, 3, 5);
  map.AddMetric(16, 5, 4);
  map.AddPath(101);
  map.AddPath(102);
  map.AddPathEdge(21, 101, 1, 1);
  map.AddPathEdge(22, 102, 4, 4);
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 8 * 60;
  policy.window_min = 60;

  // 40: MakeIntegral's 120 does not fit; the fill's own selection does.
  policy.budget_bytes = 40;
  DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 3, 4, 5}));
  EXPECT_EQ(download.edges, NumberedUuids({14, 15, 16, 21, 22}));
  EXPECT_EQ(download.paths, NumberedUuids({101, 102}));
  EXPECT_EQ(download.report.bytes, 40);
  EXPECT_EQ(download.report.picked_nodes, 2u);
  EXPECT_EQ(download.report.integrity.fragments_before, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  ExpectIntegral(map, download);

  // 120: MakeIntegral of the picks fits, so the download is that, as without a budget.
  policy.budget_bytes = 120;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 4, 6}));
  EXPECT_EQ(download.edges, NumberedUuids({11, 12, 13, 21, 22}));
  EXPECT_EQ(download.report.bytes, 120);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  ExpectIntegral(map, download);

  // 39: B with its bridges does not fit at all.
  policy.budget_bytes = 39;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1}));
  EXPECT_EQ(download.edges, NumberedUuids({21}));
  ExpectIntegral(map, download);
}

// The same two ways with the weights swapped: n3, n5 are 50 bytes, n2, n6 10. The fill joins
// n4 via n5, n3 (120 bytes), so the bare node n7 (alone, 08:30, 10 bytes) no longer fits 125.
// MakeIntegral of the picks {n1, n4} goes via n2, n6 (40 bytes), which leaves room: the next
// round grows from there and takes n7 (50).
TEST(DownloadSelect, BudgetSpendsTheRoomMakeIntegralLeavesOnANextRound) {
  TestMap map;
  for (int n = 1; n <= 6; ++n) {
    map.AddNode(n, n == 1 || n == 4 ? At(8, 0) : At(20, 0), n == 3 || n == 5 ? 50 : 10);
  }
  map.AddNode(7, At(8, 30));
  map.AddMetric(11, 1, 2);
  map.AddMetric(12, 2, 6);
  map.AddMetric(13, 6, 4);
  map.AddMetric(14, 1, 3);
  map.AddMetric(15, 3, 5);
  map.AddMetric(16, 5, 4);
  map.AddPath(101);
  map.AddPath(102);
  map.AddPathEdge(21, 101, 1, 1);
  map.AddPathEdge(22, 102, 4, 4);
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 8 * 60;
  policy.window_min = 60;
  policy.budget_bytes = 125;
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 4, 6, 7}));
  EXPECT_EQ(download.report.bytes, 50);
  EXPECT_EQ(download.report.picked_nodes, 3u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 2u);
  EXPECT_EQ(download.report.integrity.touched_components, 2u);
  ExpectIntegral(map, download);
}

// Joining a path, the fill passes through the path's own nodes for free: A (101) = {n1, n7}
// goes first (the same weight as B, lower UUID); B (102) = {n4, n6}. From n4 the way to n1
// through n6 needs one bridge, n5; the way through n3, n2 needs two. All 10 bytes; n2, n3, n5
// are outside the mission's window. Budget 50: A (20) and B with n5 (30) fit exactly; through
// n3, n2 (and then n6) B would need 40.
TEST(DownloadSelect, BudgetBridgesThroughThePathsOwnNodes) {
  TestMap map;
  for (int n = 1; n <= 7; ++n) map.AddNode(n, n == 2 || n == 3 || n == 5 ? At(20, 0) : At(8, 0));
  map.AddMetric(11, 1, 2);
  map.AddMetric(12, 2, 3);
  map.AddMetric(13, 3, 4);
  map.AddMetric(14, 1, 5);
  map.AddMetric(15, 5, 6);
  map.AddMetric(16, 6, 4);
  map.AddMetric(17, 1, 7);
  map.AddPath(101);
  map.AddPath(102);
  map.AddPathEdge(21, 101, 1, 7);
  map.AddPathEdge(22, 102, 4, 6);
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 8 * 60;
  policy.window_min = 60;
  policy.budget_bytes = 50;
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 4, 5, 6, 7}));
  EXPECT_EQ(download.report.picked_nodes, 4u);
  EXPECT_EQ(download.report.bytes, 50);
  ExpectIntegral(map, download);
}

// Bare nodes far from the selection bring their bridges too, and are skipped when those do not
// fit: the chain 1-2-3-4, P (101) = {n1} via a path edge to itself (edge 21); n4 (bare,
// nearest the mission) needs n2 and n3; n5 (bare) stands alone, later in the day.
TEST(DownloadSelect, BudgetSkipsABareNodeWhoseBridgesDoNotFit) {
  TestMap map;
  map.AddNode(1, At(3, 0));
  map.AddNode(2, At(3, 0));
  map.AddNode(3, At(3, 0));
  map.AddNode(4, At(8, 0));
  map.AddNode(5, At(9, 0));
  for (int n = 1; n <= 3; ++n) map.AddMetric(10 + n, n, n + 1);
  map.AddPath(101);
  map.AddPathEdge(21, 101, 1, 1);
  DownloadPolicy policy = ParseDownloadPolicy("budget");
  policy.mission_start_min = 8 * 60;
  // Bare nodes n2, n3 (5 h away), n4 (0 h), n5 (1 h): after P (10), n4 needs n2 and n3 (40 in
  // all, over 35): skipped; n5 fits (20); n2 (30), n3 (40, over): n2 only.
  policy.budget_bytes = 35;
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 5}));
  EXPECT_EQ(download.report.bytes, 30);
  ExpectIntegral(map, download);
}

// Time of day changes the paths' weights: A (101) = {n1, n2, n3} at 10:15, 10:20, 10:25;
// B (102) = {n4 at 10:30, n5, n6, n7 at 15:10 … 15:30}. One-hour epochs, 10 bytes a node, no
// metric edges.
//   Over the whole day: epoch 10 holds A 3, B 1 (3/4, 1/4); epoch 15 B 3 (1): A 3/4, B 5/4.
//   Mission 10:30 ± 20 min: epoch 10 only: A 3/4, B 1/4; the window allows n1…n4.
TestMap WeightedByTimeMap() {
  TestMap map;
  map.AddNode(1, At(10, 15));
  map.AddNode(2, At(10, 20));
  map.AddNode(3, At(10, 25));
  map.AddNode(4, At(10, 30));
  map.AddNode(5, At(15, 10));
  map.AddNode(6, At(15, 20));
  map.AddNode(7, At(15, 30));
  map.AddPath(101);
  map.AddPath(102);
  map.AddPathEdge(21, 101, 1, 2);
  map.AddPathEdge(22, 101, 2, 3);
  map.AddPathEdge(23, 102, 4, 5);
  map.AddPathEdge(24, 102, 5, 6);
  map.AddPathEdge(25, 102, 6, 7);
  return map;
}

TEST(DownloadSelect, BudgetWeighsPathsOverTheMissionsEpochs) {
  const TestMap map = WeightedByTimeMap();
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 10 * 60 + 30;
  policy.window_min = 20;
  policy.budget_bytes = 30;
  // A first (its 30 bytes fit); then B's allowed node n4 would make 40.
  DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3}));
  EXPECT_EQ(download.report.epoch_start, 10);
  EXPECT_EQ(download.report.epoch_end, 10);
  ExpectIntegral(map, download);

  // Without the window B is heavier: all four of its nodes (40) fit 40, then A does not.
  policy = ParseDownloadPolicy("budget");
  policy.mission_start_min = 10 * 60 + 30;
  policy.budget_bytes = 40;
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({4, 5, 6, 7}));
  EXPECT_EQ(download.paths, NumberedUuids({102}));
  EXPECT_EQ(download.report.epoch_start, 10);
  EXPECT_EQ(download.report.epoch_end, 15);
  ExpectIntegral(map, download);
}

TEST(DownloadSelect, PathsAndBudgetFillFromTheBestPathsOnly) {
  const TestMap map = PathsMap();
  DownloadPolicy policy = PathsPolicy("paths+budget");
  policy.mission_start_min = 6 * 60 + 30;  // epochs 1 … 2: P* = {P1, P3}
  // P1 and P3 weigh 2/3 each over epochs 1 … 2; the tie goes to the lower UUID, P1 (20
  // bytes). P3 would make 40. P2 (also 2/3, all of its nodes on P*) is not a candidate, or
  // n3 would join for 30.
  policy.budget_bytes = 30;
  DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2}));
  EXPECT_EQ(download.report.paths_chosen, 2u);
  EXPECT_EQ(download.report.bytes, 20);
  ExpectIntegral(map, download);

  policy.budget_bytes = 1000;  // everything P* allows, never n5
  download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({1, 2, 3, 4}));
  ExpectIntegral(map, download);
}

TEST(DownloadSelect, TimeOfDayBudgetNeverPicksNodesOutsideTheWindow) {
  const TestMap map = BudgetMap();
  DownloadPolicy policy = ParseDownloadPolicy("tod+budget");
  policy.mission_start_min = 9 * 60;
  policy.window_min = 30;  // 08:30 … 09:30: n10 only
  policy.budget_bytes = 1000;
  const DownloadSelection download = map.Select(policy);
  EXPECT_EQ(download.nodes, NumberedUuids({10}));
  EXPECT_EQ(download.report.bytes, 10);
  ExpectIntegral(map, download);
}

// Invariants on random maps (several metric components, paths over them, random stamps and
// sizes), for every policy: integral (checked independently), bytes as sent, a budget never
// passed, nodes outside the time window only as bridges, and a budget of the whole map sending
// everything the other parts allow, like the same policy without a budget.
// A chain n1 - n2 - n3 - n4 - n5 of 10-byte nodes; n1 is the dock, captured at 03:00, the
// others around noon. A noon mission with T_w = 60 min picks n2 … n5; including the dock adds
// n1 (joined directly to n2, no bridge needed).
TEST(DownloadSelect, IncludedNodesAreKeptWhateverThePolicyPicks) {
  TestMap map;
  map.AddNode(1, At(3, 0));
  for (int n = 2; n <= 5; ++n) map.AddNode(n, At(12, n));
  for (int n = 1; n < 5; ++n) map.AddMetric(100 + n, n, n + 1);
  DownloadPolicy tod = ParseDownloadPolicy("tod");
  tod.mission_start_min = 12 * 60;
  tod.window_min = 60;
  EXPECT_EQ(map.Select(tod).nodes, NumberedUuids({2, 3, 4, 5}));
  tod.include = {NumberedUuid(1)};
  const DownloadSelection with_dock = map.Select(tod);
  EXPECT_EQ(with_dock.nodes, NumberedUuids({1, 2, 3, 4, 5}));
  EXPECT_EQ(with_dock.report.picked_nodes, 5u);
  ExpectIntegral(map, with_dock);
  // Under a budget the dock comes first: 30 bytes hold it and the two nodes nearest it.
  DownloadPolicy budget = ParseDownloadPolicy("tod+budget");
  budget.mission_start_min = 12 * 60;
  budget.window_min = 60;
  budget.budget_bytes = 30;
  budget.include = {NumberedUuid(1)};
  const DownloadSelection small = map.Select(budget);
  EXPECT_TRUE(std::find(small.nodes.begin(), small.nodes.end(), NumberedUuid(1)) !=
              small.nodes.end());
  EXPECT_LE(small.report.bytes, 30);
  ExpectIntegral(map, small);
  // A node the map does not hold cannot be included.
  tod.include = {NumberedUuid(99)};
  try {
    map.Select(tod);
    ADD_FAILURE() << "an unknown node was included";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), ErrorCode::kNotFound);
    EXPECT_NE(std::string(error.what()).find(NumberedUuid(99).ToString()), std::string::npos);
  }
}

TEST(DownloadSelect, RandomMapsKeepTheInvariants) {
  std::mt19937 rng(5);
  const char* const names[] = {"copy",   "tod",        "paths",        "tod+paths",
                               "budget", "tod+budget", "paths+budget", "tod+paths+budget"};
  for (int round = 0; round < 60; ++round) {
    SCOPED_TRACE(round);
    TestMap map;
    std::uniform_int_distribution<int> minute(0, 1439), size(1, 50), node(1, 30), coin(0, 3);
    std::map<Uuid, std::int64_t> bytes;
    for (int n = 1; n <= 30; ++n) {
      map.AddNode(n, At(0, minute(rng), n), size(rng));
      bytes[NumberedUuid(n)] = static_cast<std::int64_t>(map.nodes.back().landmarks_blob.size());
    }
    int edge = 1000;
    for (int n = 1; n < 30; ++n) {
      if (coin(rng) != 0) map.AddMetric(edge++, n, n + 1);  // about a quarter of the links cut
    }
    for (int extra = 0; extra < 6; ++extra) map.AddMetric(edge++, node(rng), node(rng));
    for (int p = 0; p < 5; ++p) {
      map.AddPath(500 + p);
      for (int e = coin(rng) + 1; e > 0; --e)
        map.AddPathEdge(edge++, 500 + p, node(rng), node(rng));
    }
    std::int64_t map_bytes = 0;
    for (const auto& [id, b] : bytes) map_bytes += b;

    for (const char* name : names) {
      SCOPED_TRACE(name);
      DownloadPolicy policy = ParseDownloadPolicy(name);
      policy.mission_start_min = minute(rng);
      policy.window_min = 30 + minute(rng) / 4;
      policy.epoch_min = 120;
      if (coin(rng) == 0) policy.mission_end_min = minute(rng);
      if (policy.budget_bytes) policy.budget_bytes = 1 + size(rng) * 8;
      const DownloadSelection download = map.Select(policy);
      ExpectIntegral(map, download);
      std::int64_t sent = 0;
      for (const Uuid& id : download.nodes) sent += bytes.at(id);
      EXPECT_EQ(download.report.bytes, sent);
      EXPECT_EQ(download.report.map_bytes, map_bytes);
      if (policy.budget_bytes) {
        EXPECT_LE(sent, *policy.budget_bytes);
      }
      EXPECT_EQ(download.report.nodes,
                download.report.picked_nodes + download.report.integrity.bridging_nodes);
      if (policy.time_of_day) {
        std::size_t outside = 0;
        for (const Node& n : map.nodes) {
          const double at_min = static_cast<double>((n.stamp_ns % kDay) / kNsPerMinute);
          const double apart = std::abs(at_min - policy.mission_start_min);
          const bool inside = std::min(apart, 1440 - apart) <= policy.window_min;
          if (!inside && std::binary_search(download.nodes.begin(), download.nodes.end(), n.id)) {
            ++outside;
          }
        }
        EXPECT_LE(outside, download.report.integrity.bridging_nodes);
      }
      if (policy.budget_bytes) {
        policy.budget_bytes = map_bytes;
        DownloadPolicy unlimited = policy;
        unlimited.budget_bytes.reset();
        EXPECT_EQ(map.Select(policy).nodes, map.Select(unlimited).nodes);
      }
    }
  }
}

// ---------------------------------------------------------------------------------------
// Errors

void ExpectError(const TestMap& map, const DownloadPolicy& policy, ErrorCode code,
                 const std::string& says) {
  try {
    map.Select(policy);
    ADD_FAILURE() << "no error";
  } catch (const Error& error) {
    EXPECT_EQ(error.code(), code) << error.what();
    EXPECT_NE(std::string(error.what()).find(says), std::string::npos) << error.what();
  }
}

TEST(DownloadSelectErrors, DanglingEdgesAndUnknownPathsAreIntegrityErrors) {
  TestMap map = TwoPartMap();
  map.AddMetric(150, 1, 77);  // n77 is not in the map
  ExpectError(map, ParseDownloadPolicy("copy"), ErrorCode::kIntegrity,
              NumberedUuid(150).ToString());

  map = TwoPartMap();
  map.AddPathEdge(250, 95, 1, 2);  // P95 is not among the paths
  ExpectError(map, ParseDownloadPolicy("copy"), ErrorCode::kIntegrity, NumberedUuid(95).ToString());
  ExpectError(map, ParseDownloadPolicy("tod+paths"), ErrorCode::kIntegrity,
              NumberedUuid(250).ToString());
}

TEST(DownloadSelectErrors, BudgetOnBareNodesAndBadPoliciesAreInvalidArguments) {
  TestMap map = TwoPartMap();
  map.nodes[3].landmarks_blob.clear();  // n4
  ExpectError(map, ParseDownloadPolicy("budget"), ErrorCode::kInvalidArgument,
              NumberedUuid(4).ToString());
  EXPECT_NO_THROW(map.Select(ParseDownloadPolicy("paths")));  // no budget: bare is fine

  map = TwoPartMap();
  map.nodes.push_back(map.nodes[1]);  // n2 twice
  ExpectError(map, ParseDownloadPolicy("copy"), ErrorCode::kInvalidArgument,
              NumberedUuid(2).ToString());

  DownloadPolicy bad = ParseDownloadPolicy("tod");
  bad.window_min = -5;
  ExpectError(TwoPartMap(), bad, ErrorCode::kInvalidArgument, "window_min");
}

}  // namespace
}  // namespace fleetmap
