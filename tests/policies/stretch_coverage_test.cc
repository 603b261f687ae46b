// DOWNLOAD's coverage guarantee (stretch_coverage.h) on maps built by hand along a
// straight 30 m route: stretches of 10 m, experiences as chains of nodes every 2 m.
#include "fleetmap/map_management/stretch_coverage.h"

#include <gtest/gtest.h>

#include <map>
#include <set>
#include <vector>

#include "day_stamps.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/download_policy.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

Se3 Along(double x_m) {
  Se3 pose = Se3::Identity();
  pose.translation() = Eigen::Vector3d(x_m, 0.0, 0.0);
  return pose;
}

// Outing 1 is the reference experience: every later one is linked to its node at the same
// place at both ends, as EBN links a new experience where it lost and found the map.
class RouteMap {
 public:
  // Outing `outing` captured at `stamp`, nodes at x = from + 1, from + 3, … < to, chained.
  void Drive(int outing, std::int64_t stamp, int from_m, int to_m) {
    std::vector<Uuid> chain;
    for (int x = from_m + 1; x < to_m; x += 2) {
      Node node;
      node.id = NumberedUuid(next_node_++);
      node.stamp_ns = stamp + x * 1'000'000'000LL;  // 1 m/s
      node.robot = NumberedUuid(9000);
      node.outing = NumberedUuid(8000 + outing);
      nodes_.push_back(node);
      place_[node.id] = x;
      outing_of_[node.id] = outing;
      at_[{outing, x}] = node.id;
      if (!chain.empty()) Metric(chain.back(), node.id, 2.0);
      chain.push_back(node.id);
    }
    if (outing != 1) {
      Metric(at_.at({1, from_m + 1}), chain.front(), 0.0);
      Metric(at_.at({1, to_m - 1}), chain.back(), 0.0);
    }
  }

  // A path (an outing that localised along them) through `outing`'s nodes in [from, to).
  void Use(int path, std::int64_t start, int outing, int from_m, int to_m) {
    Path p;
    p.id = NumberedUuid(7000 + path);
    p.robot = NumberedUuid(9001);
    p.outing = NumberedUuid(7500 + path);
    p.start_ns = start;
    p.end_ns = start + 30 * kNsPerMinute;
    paths_.push_back(p);
    std::optional<Uuid> last;
    for (int x = from_m + 1; x < to_m; x += 2) {
      const Uuid node = at_.at({outing, x});
      if (last) {
        Edge edge;
        edge.id = NumberedUuid(next_edge_++);
        edge.from = *last;
        edge.to = node;
        edge.kind = EdgeKind::kPath;
        edge.path = p.id;
        edges_.push_back(edge);
      }
      last = node;
    }
  }

  DownloadSelection Select(const std::string& name, int hour, int k, int cap,
                           double window_min = 60.0) const {
    DownloadPolicy policy = ParseDownloadPolicy(name);
    policy.mission_start_min = hour * 60.0;
    policy.window_min = window_min;
    policy.coverage = {.stretch_m = 10.0, .experiences = k, .most_experiences = cap};
    return SelectDownload(nodes_, edges_, paths_, policy);
  }

  // The outings with a node in stretch `s` (x in [10 s, 10 s + 10)) of a selection. Integrity
  // may add a bridging node of another outing where two picked experiences meet.
  std::set<int> OutingsIn(const DownloadSelection& selection, int s) const {
    std::set<int> outings;
    for (const Uuid& id : selection.nodes) {
      const int x = place_.at(id);
      if (x / 10 != s) continue;
      outings.insert(outing_of_.at(id));
    }
    return outings;
  }

  // Nodes of `outing` in stretch `s` of a selection.
  int NodesIn(const DownloadSelection& selection, int outing, int s) const {
    int n = 0;
    for (const Uuid& id : selection.nodes) {
      n += outing_of_.at(id) == outing && place_.at(id) / 10 == s ? 1 : 0;
    }
    return n;
  }

  const std::vector<Node>& nodes() const { return nodes_; }
  const std::vector<Edge>& edges() const { return edges_; }

 private:
  void Metric(const Uuid& from, const Uuid& to, double x_m) {
    Edge edge;
    edge.id = NumberedUuid(next_edge_++);
    edge.from = from;
    edge.to = to;
    edge.kind = EdgeKind::kMetric;
    edge.from_T_to = Along(x_m);
    edges_.push_back(edge);
  }

  std::vector<Node> nodes_;
  std::vector<Edge> edges_;
  std::vector<Path> paths_;
  std::map<Uuid, int> place_;
  std::map<Uuid, int> outing_of_;
  std::map<std::pair<int, int>, Uuid> at_;
  int next_node_ = 1, next_edge_ = 5000;
};

TEST(StretchCoverage, CutsTheRouteIntoStretchesByComposedPoses) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  map.Drive(2, At(20), 0, 20);
  std::vector<const Node*> nodes;
  for (const Node& node : map.nodes()) nodes.push_back(&node);
  const MapStretches stretches = MapStretches::Cut(nodes, map.edges(), 10.0);
  EXPECT_EQ(stretches.stretch_count(), 3u);
  // Outing 2's nodes (positions 15 on) share stretches with outing 1's at the same x.
  EXPECT_EQ(stretches.stretch_of(0), stretches.stretch_of(15));       // x = 1
  EXPECT_EQ(stretches.stretch_of(5), stretches.stretch_of(20));       // x = 11
  EXPECT_NE(stretches.stretch_of(4), stretches.stretch_of(5));        // x = 9 | 11
  EXPECT_EQ(stretches.members(stretches.stretch_of(10)).size(), 5u);  // x = 21 … 29: outing 1
}

// The window (20:00 ± 1 h) holds no experience of the last stretch: the paper's tod leaves the
// robot without a node there; the guarantee keeps the best one from outside the window.
TEST(StretchCoverage, KeepsAStretchTheWindowLeavesEmpty) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  map.Drive(2, At(20), 0, 20);
  const DownloadSelection tod = map.Select("tod", 20, 1, 1);
  EXPECT_EQ(map.OutingsIn(tod, 0), (std::set<int>{2}));
  EXPECT_TRUE(map.OutingsIn(tod, 2).empty());

  const DownloadSelection covered = map.Select("tod+cover", 20, 1, 1);
  EXPECT_EQ(map.OutingsIn(covered, 0), (std::set<int>{2}));
  EXPECT_EQ(map.NodesIn(covered, 2, 1), 5);
  EXPECT_EQ(map.NodesIn(covered, 1, 1), 1);  // x = 19, joining outing 2's end to stretch 2
  EXPECT_EQ(map.NodesIn(covered, 1, 2), 5);
  EXPECT_EQ(covered.report.stretches, 3u);
  EXPECT_EQ(covered.report.stretches_reached_outside, 1u);
  EXPECT_EQ(covered.report.policy, "tod+cover");
}

// Where the window holds nothing, the experience a robot used near the mission's time beats
// one captured and used only in the morning, though both were captured outside the window.
TEST(StretchCoverage, PrefersExperiencesUsedNearTheMissionTime) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  map.Drive(2, At(14), 20, 30);
  map.Use(1, At(19, 50, 3), 2, 20, 30);
  map.Use(2, At(8, 30, 4), 1, 0, 30);
  const DownloadSelection evening = map.Select("tod+cover", 20, 1, 1);
  EXPECT_EQ(map.NodesIn(evening, 2, 2), 5);
  EXPECT_LE(map.NodesIn(evening, 1, 2), 1);  // at most the bridge at x = 21
  // In the morning the order turns.
  const DownloadSelection morning = map.Select("tod+cover", 8, 1, 1);
  EXPECT_EQ(map.NodesIn(morning, 1, 2), 5);
  EXPECT_EQ(map.NodesIn(morning, 2, 2), 0);
}

// Five experiences inside the window at one place: beyond the cap they are redundant.
TEST(StretchCoverage, TrimsRedundantExperiencesInsideTheWindow) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  for (int o = 2; o <= 6; ++o) map.Drive(o, At(19, 40 + 5 * o), 0, 10);
  const DownloadSelection tod = map.Select("tod", 20, 1, 3);
  const DownloadSelection covered = map.Select("tod+cover", 20, 1, 3);
  int whole_tod = 0, whole_covered = 0;
  for (int o = 2; o <= 6; ++o) {
    whole_tod += map.NodesIn(tod, o, 0) == 5 ? 1 : 0;
    whole_covered += map.NodesIn(covered, o, 0) == 5 ? 1 : 0;
    EXPECT_TRUE(map.NodesIn(covered, o, 0) == 5 || map.NodesIn(covered, o, 0) == 0);
  }
  EXPECT_EQ(whole_tod, 5);
  EXPECT_EQ(whole_covered, 3);
  // The morning experience is not needed (the window has better): only its x = 1 node,
  // where the evening ones were linked, bridges them.
  EXPECT_EQ(map.NodesIn(covered, 1, 0), 1);
}

// Four paths used the window's epoch; the best 50 % are two, so tod+paths drops the nodes
// only the other two hold, with or without the guarantee.
TEST(StretchCoverage, PathsRemoveNodesWhenMorePathsThanTheBestShare) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  for (int o = 2; o <= 5; ++o) map.Drive(o, At(20, 5 * (o - 2)), 0, 12 - 2 * o);
  for (int o = 2; o <= 5; ++o) map.Use(o, At(20, 5 * (o - 2)), o, 0, 12 - 2 * o);
  const DownloadSelection tod = map.Select("tod", 20, 1, 4);
  const DownloadSelection tod_paths = map.Select("tod+paths", 20, 1, 4);
  EXPECT_EQ(tod_paths.report.paths_chosen, 2u);
  EXPECT_LT(tod_paths.nodes.size(), tod.nodes.size());
  EXPECT_EQ(map.OutingsIn(tod_paths, 0), (std::set<int>{1, 2, 3}));  // 1: a bridging node

  const DownloadSelection cover = map.Select("tod+cover", 20, 1, 4);
  const DownloadSelection cover_paths = map.Select("tod+paths+cover", 20, 1, 4);
  EXPECT_LT(cover_paths.nodes.size(), cover.nodes.size());
  const std::set<int> kept = map.OutingsIn(cover_paths, 0);
  EXPECT_FALSE(kept.contains(4));
  EXPECT_FALSE(kept.contains(5));
}

// A morning experience that evening robots kept localising in: the paper's tod drops it (it
// was captured at 08:00), the guarantee's tod keeps it as used within the window.
TEST(StretchCoverage, TodAllowsWhatRobotsUsedWithinTheWindow) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  map.Drive(2, At(20), 0, 10);
  map.Drive(3, At(9), 0, 10);
  map.Use(1, At(20, 10, 2), 1, 0, 30);  // an evening robot localised along outing 1
  EXPECT_EQ(map.NodesIn(map.Select("tod", 20, 1, 0), 1, 1), 0);
  const DownloadSelection covered = map.Select("tod+cover", 20, 1, 0);
  for (int s = 0; s < 3; ++s) EXPECT_EQ(map.NodesIn(covered, 1, s), 5) << s;
  EXPECT_EQ(map.NodesIn(covered, 3, 0), 0);  // captured in the morning, never used since
}

// With the guarantee, paths keeps the best half of the paths driven within the window (by
// weight over the mission's epochs), however many epochs the window spans.
TEST(StretchCoverage, PathsKeepTheBestShareOfThePathsDrivenInTheWindow) {
  RouteMap map;
  map.Drive(1, At(8), 0, 30);
  // Four evening experiences at 18:30 … 21:30, an epoch each, each on its own path; longer
  // ones weigh more. The mission at 20:00 with T_w = 2 h spans them all.
  for (int o = 2; o <= 5; ++o) map.Drive(o, At(18 + o - 2, 30), 0, 20 - 2 * o);
  for (int o = 2; o <= 5; ++o) map.Use(o, At(18 + o - 2, 30), o, 0, 20 - 2 * o);
  const DownloadSelection paper = map.Select("tod+paths", 20, 1, 0, 120.0);
  const DownloadSelection covered = map.Select("tod+paths+cover", 20, 1, 0, 120.0);
  EXPECT_EQ(paper.report.paths_chosen, 4u);  // each epoch's best: all four
  EXPECT_EQ(covered.report.paths_chosen, 2u);
  EXPECT_LT(covered.nodes.size(), paper.nodes.size());
  EXPECT_EQ(map.NodesIn(covered, 2, 0), 5);  // the heaviest two, whole
  EXPECT_EQ(map.NodesIn(covered, 3, 1), 2);
  EXPECT_EQ(map.NodesIn(covered, 5, 0), 0);  // the lightest, not needed
}

TEST(StretchCoverage, ParsesAndValidates) {
  EXPECT_EQ(ParseDownloadPolicy("cover+tod").Name(), "tod+cover");
  EXPECT_EQ(ParseDownloadPolicy("paths+cover+tod").Name(), "tod+paths+cover");
  EXPECT_THROW(ParseDownloadPolicy("copy+cover"), Error);
  EXPECT_THROW(ParseDownloadPolicy("cover+cover"), Error);
  DownloadPolicy policy = ParseDownloadPolicy("tod+cover");
  policy.coverage.experiences = 0;
  EXPECT_THROW(ValidateDownloadPolicy(policy), Error);
  policy.coverage = {.stretch_m = 10.0, .experiences = 3, .most_experiences = 2};
  EXPECT_THROW(ValidateDownloadPolicy(policy), Error);
  policy.coverage = {.stretch_m = 10.0, .experiences = 3, .most_experiences = 0};  // no cap
  EXPECT_NO_THROW(ValidateDownloadPolicy(policy));
  policy.coverage = {.stretch_m = 0.0};
  EXPECT_THROW(ValidateDownloadPolicy(policy), Error);
}

TEST(StretchCoverage, LikelihoodCountsCaptureAndUsesOnTheClock) {
  EXPECT_DOUBLE_EQ(LocalisationLikelihood(At(20), {}, 20 * 60, 60), 1.0);
  const std::vector<std::int64_t> uses = {At(20, 0, 3), At(23, 0, 1)};
  // 23:00 is three widths away: exp(-4.5).
  EXPECT_NEAR(LocalisationLikelihood(At(20), uses, 20 * 60, 60), 2.0 + std::exp(-4.5), 1e-12);
  // 23:30 and 00:30 are one hour apart across midnight.
  EXPECT_NEAR(LocalisationLikelihood(At(23, 30), {}, 30, 60), std::exp(-0.5), 1e-12);
}

}  // namespace
}  // namespace fleetmap
