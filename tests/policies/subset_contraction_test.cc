// Path memory that survives a download (subset_contraction.h): contracted paths keep
// every sent node on exactly its paths, so Γ(path) (seed 002 Eqs. 5-9) reads the same counts
// over a download as over the whole map restricted to the nodes sent.
#include "fleetmap/map_management/subset_contraction.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <set>
#include <vector>

#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_ranking.h"
#include "fleetmap/ranking/path_weights.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

// Path edges of `path` along `walk`, their ids ascending in walking order (as the builder's
// time-ordered ids are).
std::vector<Edge> Walk(int path, const std::vector<int>& walk, int first_edge_id) {
  std::vector<Edge> edges;
  for (std::size_t i = 0; i + 1 < walk.size(); ++i) {
    Edge edge;
    edge.id = NumberedUuid(first_edge_id + static_cast<int>(i));
    edge.from = NumberedUuid(walk[i]);
    edge.to = NumberedUuid(walk[i + 1]);
    edge.kind = EdgeKind::kPath;
    edge.path = NumberedUuid(path);
    edges.push_back(edge);
  }
  return edges;
}

std::vector<Uuid> Sent(std::initializer_list<int> numbers) {
  std::vector<Uuid> ids;
  for (int n : numbers) ids.push_back(NumberedUuid(n));
  std::sort(ids.begin(), ids.end());
  return ids;
}

std::set<std::pair<Uuid, Uuid>> Ends(const std::vector<Edge>& edges) {
  std::set<std::pair<Uuid, Uuid>> ends;
  for (const Edge& edge : edges) ends.emplace(edge.from, edge.to);
  return ends;
}

PathMemory MemoryOf(const std::vector<Edge>& edges) {
  PathMemory memory;
  for (const Edge& edge : edges) {
    if (edge.kind == EdgeKind::kPath) memory.AddPathEdge(edge.path, edge.from, edge.to);
  }
  return memory;
}

// A metric edge between numbered nodes.
Edge MetricEdge(int id, int from, int to, const Se3& pose,
                std::optional<PoseCovariance> covariance) {
  Edge edge;
  edge.id = NumberedUuid(id);
  edge.from = NumberedUuid(from);
  edge.to = NumberedUuid(to);
  edge.from_T_to = pose;
  edge.covariance = covariance;
  return edge;
}

// The download's path edges: the map's kept ones and the derived ones.
std::vector<Edge> DownloadEdges(const std::vector<Edge>& map, const ContractedPaths& contracted) {
  std::vector<Edge> edges;
  for (const Edge& edge : map) {
    if (std::binary_search(contracted.kept.begin(), contracted.kept.end(), edge.id)) {
      edges.push_back(edge);
    }
  }
  edges.insert(edges.end(), contracted.derived.begin(), contracted.derived.end());
  return edges;
}

// A metric edge contracted over left-out nodes says as much of its uncertainty as the chain it
// stands for: the covariances along it composed (pose_covariance.h), none when no edge of the
// chain carried one; read from either end, the same edge.
TEST(MetricContraction, ADerivedEdgeCarriesItsChainsComposedCovariance) {
  Se3 step = Se3::Identity();
  step.translation() = Eigen::Vector3d(0.0, 0.0, 2.0);
  step.rotate(Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitY()));
  PoseCovariance link = PoseCovariance::Zero();
  link.diagonal() << 1e-4, 2e-4, 3e-4, 0.01, 0.02, 0.03;
  // 1 -> 2 -> 3 with only the second edge uncertain; 4 -> 5 -> 6 with neither.
  const std::vector<Edge> map = {
      MetricEdge(101, 1, 2, step, std::nullopt), MetricEdge(102, 2, 3, step, link),
      MetricEdge(103, 4, 5, step, std::nullopt), MetricEdge(104, 5, 6, step, std::nullopt)};
  const std::vector<Edge> derived = ContractMetric(map, Sent({1, 3, 4, 6}), 25.0);
  ASSERT_EQ(derived.size(), 2u);
  for (const Edge& edge : derived) {
    if (edge.from == NumberedUuid(4) || edge.to == NumberedUuid(4)) {
      EXPECT_FALSE(edge.covariance.has_value());
      continue;
    }
    ASSERT_TRUE(edge.covariance.has_value());
    // 1_T_3 = step * step with the second step's covariance carried through the first.
    const PoseCovariance expected = ComposeCovariance(step, PoseCovariance::Zero(), link);
    const PoseCovariance& got = edge.from == NumberedUuid(1)
                                    ? *edge.covariance
                                    : InverseCovariance(edge.from_T_to, *edge.covariance);
    EXPECT_LT((got - expected).cwiseAbs().maxCoeff(), 1e-12) << got;
  }
}

// A chain is walked whichever way its edges point: an edge walked against its direction gives
// its inverse pose and the covariance of that inverse. Two sent nodes a metric edge already joins
// get no derived edge, however short a chain of left-out nodes between them.
TEST(MetricContraction, AChainWalkedAgainstItsEdgesComposesTheirInversesAndSkipsJoinedPairs) {
  Se3 step = Se3::Identity();
  step.translation() = Eigen::Vector3d(1.0, 0.5, 2.0);
  step.rotate(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()));
  PoseCovariance first = PoseCovariance::Zero(), second = PoseCovariance::Zero();
  first.diagonal() << 1e-4, 2e-4, 3e-4, 0.01, 0.02, 0.03;
  second.diagonal() << 3e-4, 1e-4, 2e-4, 0.03, 0.01, 0.02;
  // 1 <- 2 <- 3 (both edges point back towards 1); 1 - 5 - 4 beside a direct edge 1 -> 4.
  const std::vector<Edge> map = {
      MetricEdge(101, 2, 1, step, first), MetricEdge(102, 3, 2, step, second),
      MetricEdge(103, 1, 5, step, std::nullopt), MetricEdge(104, 5, 4, step, std::nullopt),
      MetricEdge(105, 1, 4, step * step, std::nullopt)};
  const std::vector<Edge> derived = ContractMetric(map, Sent({1, 3, 4}), 25.0);
  ASSERT_EQ(derived.size(), 1u);
  const Edge& edge = derived.front();
  EXPECT_EQ(edge.from, NumberedUuid(1));
  EXPECT_EQ(edge.to, NumberedUuid(3));
  EXPECT_EQ(edge.id, DerivedMetricEdgeId(NumberedUuid(1), NumberedUuid(3)));
  const Se3 one_T_two = step.inverse();
  EXPECT_TRUE(Se3ApproxEqual(edge.from_T_to, one_T_two * step.inverse(), 1e-12, 1e-12));
  ASSERT_TRUE(edge.covariance.has_value());
  const PoseCovariance expected =
      ComposeCovariance(one_T_two, InverseCovariance(step, first), InverseCovariance(step, second));
  EXPECT_LT((*edge.covariance - expected).cwiseAbs().maxCoeff(), 1e-12) << *edge.covariance;
}

TEST(PathContraction, AChainOverLeftOutNodesBecomesOneDerivedEdge) {
  const std::vector<Edge> map = Walk(900, {1, 2, 3, 4}, 100);
  const ContractedPaths contracted = ContractPaths(map, Sent({1, 4}));
  EXPECT_TRUE(contracted.kept.empty());
  ASSERT_EQ(contracted.derived.size(), 1u);
  const Edge& edge = contracted.derived[0];
  EXPECT_EQ(edge.from, NumberedUuid(1));
  EXPECT_EQ(edge.to, NumberedUuid(4));
  EXPECT_EQ(edge.kind, EdgeKind::kPath);
  EXPECT_EQ(edge.path, NumberedUuid(900));
  EXPECT_EQ(edge.id, DerivedPathEdgeId(NumberedUuid(900), NumberedUuid(1), NumberedUuid(4)));
  EXPECT_TRUE(IsDerivedEdge(edge));
  EXPECT_FALSE(IsDerivedEdge(map[0]));
  EXPECT_EQ(contracted.paths, std::vector<Uuid>{NumberedUuid(900)});
}

TEST(PathContraction, EdgesBetweenSentNodesStayAndNothingRepeatsThem) {
  // 1 -> 2 -> 3 -> 2 -> 4 with 3 left out: 1->2 and 2->4 are the map's own; 2 -> 3 -> 2 is a
  // return to the same node, no edge.
  const std::vector<Edge> map = Walk(900, {1, 2, 3, 2, 4}, 100);
  const ContractedPaths contracted = ContractPaths(map, Sent({1, 2, 4}));
  EXPECT_EQ(contracted.kept, (std::vector<Uuid>{NumberedUuid(100), NumberedUuid(103)}));
  EXPECT_TRUE(contracted.derived.empty());
}

TEST(PathContraction, FollowsThePathsOrderThroughARevisit) {
  // 1 -> 5 -> 2 -> 5 -> 3 with 5 left out: the robot went 1, 2, 3, so 1->2 and 2->3 (not
  // 1->3 or 2->2).
  const std::vector<Edge> map = Walk(900, {1, 5, 2, 5, 3}, 100);
  const ContractedPaths contracted = ContractPaths(map, Sent({1, 2, 3}));
  EXPECT_EQ(Ends(contracted.derived),
            (std::set<std::pair<Uuid, Uuid>>{{NumberedUuid(1), NumberedUuid(2)},
                                             {NumberedUuid(2), NumberedUuid(3)}}));
}

TEST(PathContraction, ALoneSentNodeKeepsItsPathByASelfEdge) {
  const std::vector<Edge> map = Walk(900, {1, 2, 3}, 100);
  const ContractedPaths contracted = ContractPaths(map, Sent({2, 7}));
  ASSERT_EQ(contracted.derived.size(), 1u);
  EXPECT_EQ(contracted.derived[0].from, NumberedUuid(2));
  EXPECT_EQ(contracted.derived[0].to, NumberedUuid(2));
  EXPECT_TRUE(IsDerivedEdge(contracted.derived[0]));
  EXPECT_EQ(contracted.paths, std::vector<Uuid>{NumberedUuid(900)});
}

TEST(PathContraction, APathWithNoSentNodeIsLeftOut) {
  std::vector<Edge> map = Walk(900, {1, 2, 3}, 100);
  const std::vector<Edge> other = Walk(901, {4, 5}, 200);
  map.insert(map.end(), other.begin(), other.end());
  const ContractedPaths contracted = ContractPaths(map, Sent({4}));
  EXPECT_EQ(contracted.paths, std::vector<Uuid>{NumberedUuid(901)});
}

TEST(PathContraction, DerivedIdsDependOnPathAndEnds) {
  EXPECT_EQ(DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(2), NumberedUuid(3)),
            DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(2), NumberedUuid(3)));
  EXPECT_NE(DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(2), NumberedUuid(3)),
            DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(3), NumberedUuid(2)));
  EXPECT_NE(DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(2), NumberedUuid(3)),
            DerivedPathEdgeId(NumberedUuid(4), NumberedUuid(2), NumberedUuid(3)));
  Edge forged;
  forged.id = NumberedUuid(77);
  forged.from = NumberedUuid(2);
  forged.to = NumberedUuid(3);
  forged.kind = EdgeKind::kPath;
  forged.path = NumberedUuid(1);
  EXPECT_FALSE(IsDerivedEdge(forged));
  forged.id = DerivedPathEdgeId(NumberedUuid(1), NumberedUuid(2), NumberedUuid(3));
  EXPECT_TRUE(IsDerivedEdge(forged));
  forged.kind = EdgeKind::kMetric;
  EXPECT_FALSE(IsDerivedEdge(forged));
}

// The property: on random maps (paths as random walks with revisits, some broken as a merge
// breaks them) and random selections, every sent node lies on the same paths in the download
// as in the whole map, so Z_ij, N_ik (seed 002 Eqs. 5, 8), Γ(path)'s posterior for any W
// (Eq. 9) and the path count matrix (seed 004 Eq. 6) agree.
TEST(PathContraction, PathRankingOverADownloadEqualsTheWholeMapsRestrictedToTheNodesSent) {
  std::mt19937 rng(34);
  for (int trial = 0; trial < 60; ++trial) {
    const int node_count = 20 + static_cast<int>(rng() % 60);
    const int path_count = 1 + static_cast<int>(rng() % 12);
    std::vector<Edge> map;
    int next_edge = 1000;
    for (int p = 0; p < path_count; ++p) {
      const int length = 2 + static_cast<int>(rng() % 40);
      std::vector<int> walk;
      int at = 1 + static_cast<int>(rng() % node_count);
      for (int i = 0; i < length; ++i) {
        walk.push_back(at);
        // Mostly onward, sometimes back to an earlier node (the robot revisits).
        at = rng() % 5 == 0 && !walk.empty() ? walk[rng() % walk.size()]
                                             : 1 + static_cast<int>(rng() % node_count);
      }
      std::vector<Edge> edges = Walk(500 + p, walk, next_edge);
      next_edge += length;
      // A merge may have dropped a step: break the walk once in a while.
      if (edges.size() > 3 && rng() % 3 == 0) edges.erase(edges.begin() + rng() % edges.size());
      map.insert(map.end(), edges.begin(), edges.end());
    }
    std::vector<Uuid> sent;
    const double share = 0.1 + 0.8 * (rng() % 1000) / 1000.0;
    for (int n = 1; n <= node_count; ++n) {
      if ((rng() % 1000) / 1000.0 < share) sent.push_back(NumberedUuid(n));
    }
    std::sort(sent.begin(), sent.end());

    const ContractedPaths contracted = ContractPaths(map, sent);
    const std::vector<Edge> download = DownloadEdges(map, contracted);
    for (const Edge& edge : download) {
      ASSERT_TRUE(std::binary_search(sent.begin(), sent.end(), edge.from));
      ASSERT_TRUE(std::binary_search(sent.begin(), sent.end(), edge.to));
    }
    const PathMemory whole = MemoryOf(map);
    const PathMemory subset = MemoryOf(download);
    const auto path_ids = [](const PathMemory& memory, const Uuid& node) {
      std::set<Uuid> ids;
      for (const PathMemory::PathIndex p : memory.PathsThrough(node)) ids.insert(memory.path_id(p));
      return ids;
    };
    for (const Uuid& a : sent) {
      ASSERT_EQ(path_ids(whole, a), path_ids(subset, a)) << "trial " << trial;
      for (const Uuid& b : sent) ASSERT_EQ(whole.SharedPaths(a, b), subset.SharedPaths(a, b));
    }
    if (sent.size() < 2) continue;

    // Γ(path) with the same observations W on both.
    PathRanking on_whole(whole, {.window_iterations = 8});
    PathRanking on_subset(subset, {.window_iterations = 8});
    for (int iteration = 0; iteration < 12; ++iteration) {
      std::vector<LocalisationAttempt> attempts;
      for (int a = 0; a < 4; ++a) attempts.push_back({sent[rng() % sent.size()], rng() % 3 != 0});
      on_whole.ObserveIteration(attempts);
      on_subset.ObserveIteration(attempts);
    }
    for (int pair = 0; pair < 40; ++pair) {
      const Uuid& reference = sent[rng() % sent.size()];
      const Uuid& candidate = sent[rng() % sent.size()];
      const double expected = on_whole.LogPosterior(reference, candidate);
      const double actual = on_subset.LogPosterior(reference, candidate);
      if (std::isinf(expected)) {
        EXPECT_EQ(expected, actual);
      } else {
        EXPECT_NEAR(expected, actual, 1e-9) << "trial " << trial;
      }
    }

    // Algorithm 2's counts over the sent nodes, stamped an hour apart.
    std::vector<Node> nodes;
    for (std::size_t i = 0; i < sent.size(); ++i) {
      Node node;
      node.id = sent[i];
      node.stamp_ns = static_cast<std::int64_t>(i % 24) * 3'600'000'000'000;
      nodes.push_back(node);
    }
    const PathWeights whole_weights = PathWeights::Count(whole, nodes, 60.0);
    const PathWeights subset_weights = PathWeights::Count(subset, nodes, 60.0);
    for (PathMemory::PathIndex p = 0; p < subset.path_count(); ++p) {
      const std::optional<PathMemory::PathIndex> in_whole =
          [&]() -> std::optional<PathMemory::PathIndex> {
        for (PathMemory::PathIndex q = 0; q < whole.path_count(); ++q) {
          if (whole.path_id(q) == subset.path_id(p)) return q;
        }
        return std::nullopt;
      }();
      ASSERT_TRUE(in_whole);
      for (int k = 0; k < 24; ++k) {
        EXPECT_EQ(whole_weights.Count(*in_whole, k), subset_weights.Count(p, k));
      }
    }
  }
}

}  // namespace
}  // namespace fleetmap
