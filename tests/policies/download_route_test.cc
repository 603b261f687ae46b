// Route downloads (download_route.h): the textual route a command line gives,
// the corridor around a route placed in the map's layout, the route's coverage figure, and the
// route composed with the other parts of DOWNLOAD (copy, tod+cover, budget), incrementally.
// The maps are laid out by hand on the ground plane with exact metric edges (translations
// only), node 1 at the origin, so the layout (rooted at the lowest UUID) is the plan below:
//
//   y = 30  C: 201 … 251 at x = 0, 2, …, 100   (joined to A at x = 0 only)
//   y =  4  B: 101 … 151 at x = 0, 2, …, 100   (joined to A at x = 0 and x = 100 only)
//   y =  0  A:   1 …  51 at x = 0, 2, …, 100   (a chain; node 1 at the origin)
//   D: 301 … 305, a component of its own, laid out from 301 at x = 0, 2, …, 8.
#include "fleetmap/map_management/download_route.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <map>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "day_stamps.h"
#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/map_layout.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

constexpr int kRouteNodeBytes = 100;
constexpr double kRouteNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRouteInfinity = std::numeric_limits<double>::infinity();

// Node ids by line: A(x) is A's node at x metres, and so on.
int LineA(int x_m) {
  return 1 + x_m / 2;
}
int LineB(int x_m) {
  return 101 + x_m / 2;
}
int LineC(int x_m) {
  return 201 + x_m / 2;
}

class RoutePlan {
 public:
  RoutePlan() {
    Line(1, 0.0, 800, At(12, 0));
    Line(101, 4.0, 801, At(20, 0));
    Line(201, 30.0, 802, At(12, 0));
    Metric(LineA(0), LineB(0));
    Metric(LineA(100), LineB(100));
    Metric(LineA(0), LineC(0));
    // D: its own component, nothing measured joins it to the rest.
    for (int i = 0; i < 5; ++i) {
      AddNode(301 + i, Eigen::Vector3d(100.0 + 2 * i, 50.0, 0.0), 803, At(12, 0));
      if (i > 0) Metric(300 + i, 301 + i);
    }
    // A's outing drove its line at noon, B's at 20:00: their paths.
    Drive(700, 800, At(12, 0), [](int x) { return LineA(x); });
    Drive(701, 801, At(20, 0), [](int x) { return LineB(x); });
  }

  void AddNode(int n, const Eigen::Vector3d& p_m, int outing, std::int64_t stamp_ns) {
    Node node;
    node.id = NumberedUuid(n);
    node.stamp_ns = stamp_ns;
    node.robot = NumberedUuid(900);
    node.outing = NumberedUuid(outing);
    node.landmarks_blob = std::string(kRouteNodeBytes, 'x');
    nodes.push_back(node);
    at_[node.id] = p_m;
  }
  // A metric edge measuring the plan exactly.
  void Metric(int from, int to) {
    Edge edge;
    edge.id = NumberedUuid(next_edge_++);
    edge.from = NumberedUuid(from);
    edge.to = NumberedUuid(to);
    edge.from_T_to.translation() = at_.at(edge.to) - at_.at(edge.from);
    edges.push_back(edge);
  }
  void AddPath(int path, int outing, std::int64_t start_ns) {
    Path p;
    p.id = NumberedUuid(path);
    p.robot = NumberedUuid(900);
    p.outing = NumberedUuid(outing);
    p.start_ns = start_ns;
    p.end_ns = start_ns + 10 * kNsPerMinute;
    paths.push_back(p);
  }
  // Path edges get ascending ids in the order they are added, as the builder's time-ordered
  // UUIDs do.
  void Step(int path, int from, int to) {
    Edge edge;
    edge.id = NumberedUuid(next_edge_++);
    edge.from = NumberedUuid(from);
    edge.to = NumberedUuid(to);
    edge.kind = EdgeKind::kPath;
    edge.path = NumberedUuid(path);
    edges.push_back(edge);
  }

  DownloadSelection Select(const DownloadPolicy& policy) const {
    return SelectDownload(nodes, edges, paths, policy);
  }

  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Path> paths;

 private:
  void Line(int first, double y_m, int outing, std::int64_t stamp_ns) {
    for (int i = 0; i <= 50; ++i) {
      AddNode(first + i, Eigen::Vector3d(2.0 * i, y_m, 0.0), outing,
              stamp_ns + i * 1'000'000'000LL);
      if (i > 0) Metric(first + i - 1, first + i);
    }
  }
  template <typename NodeAt>
  void Drive(int path, int outing, std::int64_t start_ns, NodeAt node_at) {
    AddPath(path, outing, start_ns);
    for (int x = 2; x <= 100; x += 2) Step(path, node_at(x - 2), node_at(x));
  }

  std::map<Uuid, Eigen::Vector3d> at_;
  int next_edge_ = 10'000;
};

std::vector<const Node*> NodePointers(const std::vector<Node>& nodes) {
  std::vector<const Node*> pointers;
  for (const Node& node : nodes) pointers.push_back(&node);
  return pointers;
}

// The corridor's members as ids.
std::set<Uuid> CorridorIds(const RoutePlan& plan, const DownloadRoute& route) {
  const std::vector<const Node*> nodes = NodePointers(plan.nodes);
  const MapLayout layout = LayOutMap(nodes, plan.edges);
  const RouteCorridor corridor = RouteCorridor::Place(layout, nodes, plan.edges, plan.paths, route);
  std::set<Uuid> ids;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (corridor.members()[i]) ids.insert(nodes[i]->id);
  }
  EXPECT_EQ(ids.size(), corridor.size());
  return ids;
}

std::set<Uuid> Ids(std::initializer_list<std::pair<int (*)(int), std::pair<int, int>>> lines) {
  std::set<Uuid> ids;
  for (const auto& [line, range] : lines) {
    for (int x = range.first; x <= range.second; x += 2) ids.insert(NumberedUuid(line(x)));
  }
  return ids;
}

DownloadRoute AnchoredRoute(int anchor, std::vector<Eigen::Vector3d> anchor_p_m,
                            double radius_m = 10.0) {
  DownloadRoute route;
  route.anchor = NumberedUuid(anchor);
  route.anchor_p_m = std::move(anchor_p_m);
  route.radius_m = radius_m;
  return route;
}

// ---------------------------------------------------------------------------------------
// The textual route

TEST(DownloadRouteParse, AnOutingsUuidAlone) {
  const Uuid outing = NumberedUuid(803);
  const DownloadRoute route = ParseDownloadRoute("  " + outing.ToString() + "\n\n");
  EXPECT_EQ(route.outing, outing);
  EXPECT_FALSE(route.anchor.has_value());
  EXPECT_TRUE(route.anchor_p_m.empty());
  EXPECT_EQ(route.radius_m, 10.0);
}

TEST(DownloadRouteParse, AnAnchorAndPositionsOnLinesOrAfterSemicolons) {
  const Uuid anchor = NumberedUuid(1);
  const DownloadRoute lines =
      ParseDownloadRoute("# the mission of 08:30\nanchor " + anchor.ToString() +
                         "\r\n0 0 0\n\n  10.5\t-2 1e1 \n# end\n");
  EXPECT_EQ(lines.anchor, anchor);
  EXPECT_FALSE(lines.outing.has_value());
  ASSERT_EQ(lines.anchor_p_m.size(), 2u);
  EXPECT_EQ(lines.anchor_p_m[1], Eigen::Vector3d(10.5, -2.0, 10.0));
  EXPECT_EQ(ParseDownloadRoute("anchor " + anchor.ToString() + "; 0 0 0; 10.5 -2 10"), lines);
}

TEST(DownloadRouteParse, RefusesEachMalformedRouteSayingWhat) {
  const std::string anchor = NumberedUuid(1).ToString();
  const std::string outing = NumberedUuid(803).ToString();
  const std::pair<std::string, std::string> cases[] = {
      {"", "empty"},
      {" \n# nothing but a comment\n;", "empty"},
      {"not-a-uuid", "\"not-a-uuid\" is not an outing's UUID"},
      {"00000000-0000-0000-0000-000000000000", "nil"},
      {outing + "\n1 2 3", "stands alone, but line 2 follows"},
      {"route " + outing, "expected an outing's UUID or \"anchor UUID\" first"},
      {"anchor", "expected an outing's UUID or \"anchor UUID\" first"},
      {"anchor " + anchor + " 1 2 3", "expected an outing's UUID or \"anchor UUID\" first"},
      {"anchor nope\n1 2 3", "\"nope\" is not an anchor node's UUID"},
      {"anchor " + anchor, "has no positions"},
      {"anchor " + anchor + "\n# a comment\n", "has no positions"},
      {"anchor " + anchor + "\n0 0 0\n1 2", "line 3: expected \"x y z\""},
      {"anchor " + anchor + "\n1 2 3 4", "line 2: expected \"x y z\""},
      {"anchor " + anchor + ";1 2 x", "line 2: expected \"x y z\""},
      {"anchor " + anchor + "\n1 2 3m", "line 2: expected \"x y z\""},
      {"anchor " + anchor + "\nnan 0 0", "line 2: expected \"x y z\""},
      {"anchor " + anchor + "\n0 inf 0", "line 2: expected \"x y z\""},
      {"anchor " + anchor + "\n0 0 1e999", "line 2: expected \"x y z\""},
      {"anchor " + anchor + "\n0 0 0\n2e6 0 0", "more than"},
  };
  for (const auto& [text, mention] : cases) {
    SCOPED_TRACE(text);
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { ParseDownloadRoute(text); }, mention);
  }
}

TEST(DownloadRouteValidate, NamesWhatIsWrong) {
  DownloadRoute neither;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadRoute(neither); },
      "give an outing's UUID, or an anchor node with positions");
  DownloadRoute both = AnchoredRoute(1, {{0, 0, 0}});
  both.outing = NumberedUuid(803);
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadRoute(both); }, "not both");
  DownloadRoute outing_with_positions;
  outing_with_positions.outing = NumberedUuid(803);
  outing_with_positions.anchor_p_m = {{0, 0, 0}};
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadRoute(outing_with_positions); },
      "takes no positions");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadRoute(AnchoredRoute(1, {})); },
      "has no positions");
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] {
        ValidateDownloadRoute(AnchoredRoute(1, {{0, 0, 0}, {0, kRouteNaN, 0}}));
      },
      "position 2 is not finite");
  for (const double radius : {0.0, -1.0, kRouteNaN, kRouteInfinity}) {
    SCOPED_TRACE(radius);
    ExpectError(
        ErrorCode::kInvalidArgument,
        [&] {
          ValidateDownloadRoute(AnchoredRoute(1, {{0, 0, 0}}, radius));
        },
        "radius_m");
  }
  EXPECT_NO_THROW(ValidateDownloadRoute(AnchoredRoute(1, {{0, 0, 0}})));
}

// ---------------------------------------------------------------------------------------
// The policy's name and validation

TEST(DownloadRoutePolicy, RouteJoinsTheNameFirstAndParsesBack) {
  DownloadPolicy policy = ParseDownloadPolicy("cover+route+tod");
  ASSERT_TRUE(policy.route.has_value());
  EXPECT_EQ(policy.Name(), "route+tod+cover");
  EXPECT_EQ(ParseDownloadPolicy(policy.Name()).Name(), "route+tod+cover");
  // The name asks for a route; the caller gives it.
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadPolicy(policy); },
      "download policy: download route: give an outing's UUID");
  policy.route = ParseDownloadRoute(NumberedUuid(803).ToString());
  EXPECT_NO_THROW(ValidateDownloadPolicy(policy));
  policy.route->radius_m = 0.0;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { ValidateDownloadPolicy(policy); }, "radius_m");

  EXPECT_EQ(ParseDownloadPolicy("route").Name(), "route");
  EXPECT_EQ(ParseDownloadPolicy("budget+route").Name(), "route+budget");
  DownloadPolicy tod = ParseDownloadPolicy("tod");
  tod.route = AnchoredRoute(1, {{0, 0, 0}});
  EXPECT_EQ(tod.Name(), "route+tod");  // a route set is named whatever the parsed name said
  ExpectError(
      ErrorCode::kInvalidArgument, [] { ParseDownloadPolicy("copy+route"); }, "stands alone");
  ExpectError(
      ErrorCode::kInvalidArgument, [] { ParseDownloadPolicy("route+tod+route"); }, "repeated");
  ExpectError(
      ErrorCode::kInvalidArgument, [] { ParseDownloadPolicy("roads"); },
      "expected copy, route, tod, paths, cover or budget");
}

// ---------------------------------------------------------------------------------------
// The corridor

// The segment from x = 40 to 60 on A's line, given in node 11's frame (A at x = 20): A's nodes
// within 10 m are x = 30 … 70; B's, 4 m aside, those within √(10² − 4²) = 9.2 m along, x = 32
// … 68; C (30 m aside) and D (another component) none. Wider, C joins.
TEST(RouteCorridorTest, PositionsInTheAnchorsFrameReachNodesWithinTheRadius) {
  const RoutePlan plan;
  const DownloadRoute route = AnchoredRoute(LineA(20), {{20, 0, 0}, {40, 0, 0}});
  EXPECT_EQ(CorridorIds(plan, route), Ids({{LineA, {30, 70}}, {LineB, {32, 68}}}));
  // 30 m reaches C's nodes within √(30² − 30²) = 0 m along: x = 40 … 60, and B's within 29.7.
  EXPECT_EQ(CorridorIds(plan, AnchoredRoute(LineA(20), {{20, 0, 0}, {40, 0, 0}}, 30.0)),
            Ids({{LineA, {10, 90}}, {LineB, {12, 88}}, {LineC, {40, 60}}}));
  // One position is a ball: x = 40 ± 10 on A, ± 9.2 on B.
  EXPECT_EQ(CorridorIds(plan, AnchoredRoute(LineA(20), {{20, 0, 0}})),
            Ids({{LineA, {30, 50}}, {LineB, {32, 48}}}));
  // D's frame is its own: the same positions anchored at D's first node reach D alone.
  std::set<Uuid> d;
  for (int n = 301; n <= 305; ++n) d.insert(NumberedUuid(n));
  EXPECT_EQ(CorridorIds(plan, AnchoredRoute(301, {{0, 0, 0}, {4, 0, 0}})), d);
}

// The anchor's rotation counts: node 2's frame turned 90° about z puts its x axis along the
// layout's y, so (0, -4, 0) in it is (2 + 4, 0, 0)… in the layout: (6, 0, 0).
TEST(RouteCorridorTest, TheAnchorsRotationPlacesThePositions) {
  RoutePlan plan;
  for (Edge& edge : plan.edges) {
    if (edge.kind != EdgeKind::kMetric) continue;
    Se3 turn = Se3::Identity();
    turn.linear() = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    // Node 2 (A at x = 2) is turned: edges into it end turned, edges out of it start turned.
    if (edge.to == NumberedUuid(2)) edge.from_T_to = edge.from_T_to * turn;
    if (edge.from == NumberedUuid(2)) edge.from_T_to = turn.inverse() * edge.from_T_to;
  }
  const std::vector<const Node*> nodes = NodePointers(plan.nodes);
  const MapLayout layout = LayOutMap(nodes, plan.edges);
  const RouteCorridor corridor = RouteCorridor::Place(layout, nodes, plan.edges, plan.paths,
                                                      AnchoredRoute(2, {{0, -4, 0}, {0, -8, 0}}));
  ASSERT_EQ(corridor.pieces().size(), 1u);
  EXPECT_TRUE(corridor.pieces()[0].p_m[0].isApprox(Eigen::Vector3d(6, 0, 0), 1e-9))
      << corridor.pieces()[0].p_m[0].transpose();
  EXPECT_TRUE(corridor.pieces()[0].p_m[1].isApprox(Eigen::Vector3d(10, 0, 0), 1e-9));
  EXPECT_NEAR(corridor.length_m(), 4.0, 1e-9);
}

// Outing 804 drove from x = 20 to 60 on A's line, localising in A's nodes, except at x = 41
// and 43 where it made two nodes of its own (1 m aside); at the end it made one more at x = 80
// (on no path edge: a map whose path memory lost it). Its path edges are stored out of order.
// Its corridor (10 m): within 10 m of the line x = 20 … 60 and of the point (80, 1).
TEST(RouteCorridorTest, AnOutingIsThePlacesItVisitedInTheOrderItVisitedThem) {
  RoutePlan plan;
  plan.AddNode(501, {41, 1, 0}, 804, At(9, 0, 1));
  plan.AddNode(502, {43, 1, 0}, 804, At(9, 1, 1));
  plan.AddNode(503, {80, 1, 0}, 804, At(9, 9, 1));
  plan.Metric(LineA(40), 501);
  plan.Metric(501, 502);
  plan.Metric(502, LineA(44));
  plan.Metric(LineA(80), 503);
  plan.AddPath(704, 804, At(9, 0, 1));
  std::vector<int> visited;
  for (int x = 20; x <= 40; x += 2) visited.push_back(LineA(x));
  visited.push_back(501);
  visited.push_back(502);
  for (int x = 44; x <= 60; x += 2) visited.push_back(LineA(x));
  for (std::size_t i = 1; i < visited.size(); ++i) plan.Step(704, visited[i - 1], visited[i]);
  std::mt19937 rng(3);
  std::shuffle(plan.edges.begin(), plan.edges.end(), rng);

  const std::vector<const Node*> nodes = NodePointers(plan.nodes);
  const MapLayout layout = LayOutMap(nodes, plan.edges);
  DownloadRoute route;
  route.outing = NumberedUuid(804);
  const RouteCorridor corridor = RouteCorridor::Place(layout, nodes, plan.edges, plan.paths, route);
  ASSERT_EQ(corridor.pieces().size(), 2u);
  std::vector<int> first;
  for (const std::size_t node : corridor.pieces()[0].nodes) {
    first.push_back(nodes[node]->id.bytes()[14] * 256 + nodes[node]->id.bytes()[15]);
  }
  EXPECT_EQ(first, visited);
  ASSERT_EQ(corridor.pieces()[1].nodes.size(), 1u);
  EXPECT_EQ(nodes[corridor.pieces()[1].nodes[0]]->id, NumberedUuid(503));
  // 20 … 40, then the detour (√2 + 2 + √2), then 44 … 60; the last piece is a point.
  EXPECT_NEAR(corridor.length_m(), 20.0 + 2 * std::sqrt(2.0) + 2.0 + 16.0, 1e-9);
  const std::set<Uuid> members = [&] {
    std::set<Uuid> ids;
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      if (corridor.members()[i]) ids.insert(nodes[i]->id);
    }
    return ids;
  }();
  // A: x = 10 … 70 by the line, 72 … 88 by the point (√(10² − 1²) = 9.95 m along). B, 4 m
  // aside: 12 … 68 (9.17 m along), and 3 m from the point: 72 … 88 (9.54 m); B 70 is √116 m
  // from (60, 0) and √109 m from (80, 1).
  std::set<Uuid> expected = Ids({{LineA, {10, 88}}, {LineB, {12, 68}}, {LineB, {72, 88}}});
  for (const int n : {501, 502, 503}) expected.insert(NumberedUuid(n));
  EXPECT_EQ(members, expected);
}

// A path that leaves the component and comes back is cut into pieces, each in its own frame:
// A 10 → A 12 → D 301 → D 302 → A 14.
TEST(RouteCorridorTest, AnOutingAcrossComponentsIsCutIntoPieces) {
  RoutePlan plan;
  plan.AddPath(705, 805, At(9, 0, 2));
  const int visited[] = {LineA(10), LineA(12), 301, 302, LineA(14)};
  for (std::size_t i = 1; i < std::size(visited); ++i) {
    plan.Step(705, visited[i - 1], visited[i]);
  }
  const std::vector<const Node*> nodes = NodePointers(plan.nodes);
  const MapLayout layout = LayOutMap(nodes, plan.edges);
  DownloadRoute route;
  route.outing = NumberedUuid(805);
  route.radius_m = 1.0;
  const RouteCorridor corridor = RouteCorridor::Place(layout, nodes, plan.edges, plan.paths, route);
  ASSERT_EQ(corridor.pieces().size(), 3u);
  EXPECT_EQ(corridor.pieces()[0].nodes.size(), 2u);
  EXPECT_EQ(corridor.pieces()[1].nodes.size(), 2u);
  EXPECT_NE(corridor.pieces()[1].component, corridor.pieces()[0].component);
  EXPECT_EQ(corridor.pieces()[2].component, corridor.pieces()[0].component);
  EXPECT_NEAR(corridor.length_m(), 4.0, 1e-9);  // 2 m on A, 2 m on D, A 14 a point
  EXPECT_EQ(corridor.size(), 5u);
}

// The route x = 0 … 100 on A's line; kept: A's node at x = 40 only (the route within 5 m of it
// is x = 35 … 45: 10 m), B's at x = 60 (4 m aside: within 5 m for 3 m either way, 6 m), and D's
// first node, which sits at the layout's origin of another component (none).
TEST(RouteCorridorTest, LengthNearCountsTheRouteWithinReachOfAKeptNode) {
  const RoutePlan plan;
  const std::vector<const Node*> nodes = NodePointers(plan.nodes);
  const MapLayout layout = LayOutMap(nodes, plan.edges);
  const RouteCorridor corridor = RouteCorridor::Place(layout, nodes, plan.edges, plan.paths,
                                                      AnchoredRoute(1, {{0, 0, 0}, {100, 0, 0}}));
  EXPECT_DOUBLE_EQ(corridor.length_m(), 100.0);
  std::vector<char> kept(nodes.size(), 0);
  const auto keep = [&](int n) {
    for (std::size_t i = 0; i < nodes.size(); ++i)
      kept[i] = kept[i] || nodes[i]->id == NumberedUuid(n);
  };
  keep(LineA(40));
  EXPECT_NEAR(corridor.LengthNear(kept), 10.0, 1e-9);
  keep(LineB(60));
  EXPECT_NEAR(corridor.LengthNear(kept), 16.0, 1e-9);
  keep(301);
  EXPECT_NEAR(corridor.LengthNear(kept), 16.0, 1e-9);
  EXPECT_NEAR(corridor.LengthNear(kept, 1.0), 2.0, 1e-9);
  std::fill(kept.begin(), kept.end(), 1);
  EXPECT_NEAR(corridor.LengthNear(kept), 100.0, 1e-9);
}

// A route's cost is the map near it: a route a million metres long over this 100 m map is
// refused before any walk (it is far longer than the map), one nowhere near the map is refused,
// and one that leaves the map for kilometres costs what its part near the map costs (counted
// as grid cells looked up, the same whether it runs 5 or 12 km beyond the map).
TEST(RouteCorridorTest, ARouteFarBeyondTheMapIsRefusedOrCostsOnlyTheMapNearIt) {
  const RoutePlan plan;
  DownloadPolicy policy = ParseDownloadPolicy("route");
  // The map around node 1: x -10 … 110, y -10 … 40, z -10 … 10 (widened by the 10 m radius),
  // 132 m across, so a route may run 13.2 km.
  policy.route = AnchoredRoute(1, {{0, 0, 0}, {1e6, 0, 0}});
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { plan.Select(policy); }, "times the extent of the map");
  policy.route = AnchoredRoute(1, {{5e3, 5e3, 0}, {5e3 + 100, 5e3, 0}});
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { plan.Select(policy); }, "of no node of the map");

  std::vector<std::size_t> probed;
  for (const double far_m : {5e3, 12e3}) {
    policy.route = AnchoredRoute(1, {{50, 0, 0}, {far_m, 0, 0}});
    const DownloadReport report = plan.Select(policy).report;
    // A from x = 40 (10 m short of the route's start), B from x = 42 (4 m aside).
    EXPECT_EQ(report.corridor_nodes, 31u + 30u);
    EXPECT_NEAR(report.route_covered_m, 55.0, 0.5);  // x = 50 … 105: 5 m past A's last node
    // The corridor: about 60 m of the route within the map's box in 10 m steps, each looking
    // up 4 x 3 x 3 cells; the coverage: about 55 m in 0.25 m steps, each 3 x 3 x 3 cells.
    // A walk of the whole route made (far_m / 10) x 36 + (far_m / 0.25) x 27 lookups.
    EXPECT_LE(report.route_cells_probed, (60 / 10 + 4) * 36 + (55 * 4 + 4) * 27);
    std::printf("a route from x = 50 m to %.0f m over the 100 m map: %zu grid cells looked up\n",
                far_m, report.route_cells_probed);
    probed.push_back(report.route_cells_probed);
  }
  EXPECT_EQ(probed[0], probed[1]);
}

TEST(RouteCorridorTest, AnUnknownAnchorOrOutingIsNotFound) {
  const RoutePlan plan;
  DownloadPolicy policy = ParseDownloadPolicy("route");
  policy.route = AnchoredRoute(999, {{0, 0, 0}});
  ExpectError(
      ErrorCode::kNotFound, [&] { plan.Select(policy); },
      "anchor node " + NumberedUuid(999).ToString() + " is not in the map");
  policy.route = DownloadRoute{};
  policy.route->outing = NumberedUuid(999);
  ExpectError(
      ErrorCode::kNotFound, [&] { plan.Select(policy); },
      "outing " + NumberedUuid(999).ToString() + " is not in the map");
}

// ---------------------------------------------------------------------------------------
// The route among DOWNLOAD's parts

std::set<Uuid> Downloaded(const DownloadSelection& selection) {
  return std::set<Uuid>(selection.nodes.begin(), selection.nodes.end());
}

// "route" alone is the corridor (A 30 … 70, B 32 … 68 for x = 40 … 60), which falls apart in
// the graph: B is joined to A only at x = 0 and 100, outside it. The download is the map within
// the route's radius, so it is not bridged round the map (31 nodes either way): A and B come as
// two components. A node to include is kept.
TEST(DownloadRouteSelect, RouteAloneIsTheCorridorNotBridgedBeyondIt) {
  const RoutePlan plan;
  DownloadPolicy policy = ParseDownloadPolicy("route");
  policy.route = AnchoredRoute(1, {{40, 0, 0}, {60, 0, 0}});
  const DownloadSelection download = plan.Select(policy);
  const std::set<Uuid> corridor = Ids({{LineA, {30, 70}}, {LineB, {32, 68}}});
  EXPECT_EQ(download.report.policy, "route");
  EXPECT_EQ(download.report.corridor_nodes, corridor.size());
  EXPECT_EQ(download.report.picked_nodes, corridor.size());
  EXPECT_EQ(download.report.integrity.fragments_before, 2u);
  EXPECT_EQ(download.report.integrity.components_after, 2u);
  EXPECT_EQ(download.report.integrity.bridging_nodes, 0u);
  const std::set<Uuid> sent = Downloaded(download);
  EXPECT_EQ(sent, corridor);
  EXPECT_EQ(download.report.bytes, static_cast<std::int64_t>(sent.size()) * kRouteNodeBytes);
  EXPECT_DOUBLE_EQ(download.report.route_length_m, 20.0);
  EXPECT_DOUBLE_EQ(download.report.route_covered_m, 20.0);

  policy.include = {NumberedUuid(LineC(100))};
  const DownloadSelection with_dock = plan.Select(policy);
  EXPECT_TRUE(Downloaded(with_dock).contains(NumberedUuid(LineC(100))));
  EXPECT_EQ(with_dock.report.picked_nodes, corridor.size() + 1);

  // Without a route the report's route figures stay 0.
  const DownloadSelection copy = plan.Select(ParseDownloadPolicy("copy"));
  EXPECT_EQ(copy.report.corridor_nodes, 0u);
  EXPECT_EQ(copy.report.route_length_m, 0.0);
  EXPECT_EQ(copy.report.route_covered_m, 0.0);
}

// route+tod+cover for a 20:00 mission (T_w = 60 min, k = 1, 10 m stretches): B (driven at
// 20:00) is each stretch's best experience, so the corridor keeps B 32 … 68 (19 nodes). In the
// stretch x = 70 … 80 the corridor holds A 70 alone, so it is that stretch's experience there;
// without the route B would hold it, and every stretch of the map would keep one.
TEST(DownloadRouteSelect, TodAndCoverNarrowWithinTheCorridor) {
  const RoutePlan plan;
  DownloadPolicy policy = ParseDownloadPolicy("route+tod+cover");
  policy.mission_start_min = 20 * 60;
  policy.window_min = 60;
  policy.coverage.experiences = 1;
  policy.route = AnchoredRoute(1, {{40, 0, 0}, {60, 0, 0}});
  const DownloadSelection download = plan.Select(policy);
  EXPECT_EQ(download.report.policy, "route+tod+cover");
  std::set<Uuid> picked = Ids({{LineB, {32, 68}}});
  picked.insert(NumberedUuid(LineA(70)));
  EXPECT_EQ(download.report.picked_nodes, picked.size());
  const std::set<Uuid> sent = Downloaded(download);
  EXPECT_TRUE(std::includes(sent.begin(), sent.end(), picked.begin(), picked.end()));
  EXPECT_EQ(sent.size(), picked.size() + download.report.integrity.bridging_nodes);
  EXPECT_DOUBLE_EQ(download.report.route_covered_m, download.report.route_length_m);

  policy.route.reset();
  const DownloadSelection whole = plan.Select(policy);
  const std::set<Uuid> corridor = Ids({{LineA, {30, 70}}, {LineB, {32, 68}}});
  std::set<Uuid> whole_in_corridor;
  for (const Uuid& id : whole.nodes) {
    if (corridor.contains(id)) whole_in_corridor.insert(id);
  }
  EXPECT_EQ(whole_in_corridor, Ids({{LineB, {32, 68}}}));
  EXPECT_GT(whole.nodes.size(), sent.size());
}

// route+paths for a noon mission ending at 13:00 (p = 50 %): C's path, through C and on into
// D (56 nodes captured at noon), outweighs A's (51) over the whole map, so "paths" alone keeps
// C and D. Along the route only A's counts (21 corridor nodes, C's none), so route+paths keeps
// A 30 … 70.
TEST(DownloadRouteSelect, PathsAreChosenByTheirUseAlongTheRoute) {
  RoutePlan plan;
  plan.AddPath(702, 802, At(12, 0));
  for (int x = 2; x <= 100; x += 2) plan.Step(702, LineC(x - 2), LineC(x));
  plan.Step(702, LineC(100), 301);
  for (int n = 302; n <= 305; ++n) plan.Step(702, n - 1, n);
  DownloadPolicy policy = ParseDownloadPolicy("paths");
  policy.mission_start_min = 12 * 60;
  policy.mission_end_min = 13 * 60;
  const DownloadSelection whole = plan.Select(policy);
  EXPECT_EQ(whole.report.paths_chosen, 1u);
  EXPECT_EQ(whole.report.picked_nodes, 56u);
  EXPECT_FALSE(Downloaded(whole).contains(NumberedUuid(LineA(40))));

  policy.route = AnchoredRoute(1, {{40, 0, 0}, {60, 0, 0}});
  const DownloadSelection along = plan.Select(policy);
  EXPECT_EQ(along.report.policy, "route+paths");
  EXPECT_EQ(along.report.paths_chosen, 1u);
  EXPECT_EQ(along.report.nodes_on_chosen_paths, 51u);  // P* = A's path, all of it
  EXPECT_EQ(Downloaded(along), Ids({{LineA, {30, 70}}}));
  EXPECT_DOUBLE_EQ(along.report.route_covered_m, 20.0);
}

// route+budget weighs only the corridor's nodes of each path; what it sends beyond the corridor
// is bridging (a budget keeps its selection integral as it grows, over the whole map). A budget
// the whole map fits in sends what "route" alone sends, and those bridges.
TEST(DownloadRouteSelect, BudgetFillsWithinTheCorridor) {
  const RoutePlan plan;
  DownloadPolicy policy = ParseDownloadPolicy("route+budget");
  policy.route = AnchoredRoute(1, {{40, 0, 0}, {60, 0, 0}});
  const std::set<Uuid> corridor = Ids({{LineA, {30, 70}}, {LineB, {32, 68}}});
  for (const std::int64_t budget : {1000, 2500, 4000, 8000}) {
    SCOPED_TRACE(budget);
    policy.budget_bytes = budget;
    const DownloadSelection download = plan.Select(policy);
    EXPECT_EQ(download.report.policy, "route+budget");
    EXPECT_LE(download.report.bytes, budget);
    std::size_t outside = 0;
    for (const Uuid& id : download.nodes) outside += corridor.contains(id) ? 0 : 1;
    EXPECT_LE(outside, download.report.integrity.bridging_nodes);
    EXPECT_LE(download.report.route_covered_m, download.report.route_length_m);
  }
  policy.budget_bytes = static_cast<std::int64_t>(plan.nodes.size()) * kRouteNodeBytes;
  DownloadPolicy alone = ParseDownloadPolicy("route");
  alone.route = policy.route;
  const std::set<Uuid> budgeted = Downloaded(plan.Select(policy));
  const std::set<Uuid> route_alone = Downloaded(plan.Select(alone));
  EXPECT_TRUE(
      std::includes(budgeted.begin(), budgeted.end(), route_alone.begin(), route_alone.end()));
  EXPECT_EQ(budgeted.size(), route_alone.size() + 31);  // joined round the shorter way
}

// Incremental downloads (fleetmapd's download_stream.cc) select again at the robot's base
// revision with the same policy and send the difference: the selection must be a function of
// the map, whatever order it comes in. Revision 2 adds outing 806 beside A, at 06:00: ten nodes
// in the corridor (x = 41 … 59, 2 m aside) and five beyond it (x = 81 … 89). "route" and a
// budget that holds everything add the ten; for a 20:00 mission tod+cover (k = 2) keeps A and B
// in each stretch as before, 806 coming third, and adds nothing; none removes anything.
TEST(DownloadRouteSelect, IncrementalDownloadsDiffAsBefore) {
  const RoutePlan base;
  RoutePlan head = base;
  for (int i = 0; i < 10; ++i) {
    head.AddNode(601 + i, {41.0 + 2 * i, 2, 0}, 806, At(6, i, 3));
    head.Metric(i == 0 ? LineA(40) : 600 + i, 601 + i);
  }
  for (int i = 0; i < 5; ++i) {
    head.AddNode(621 + i, {81.0 + 2 * i, 2, 0}, 806, At(6, 30 + i, 3));
    head.Metric(i == 0 ? LineA(80) : 620 + i, 621 + i);
  }
  for (const char* name : {"route", "route+tod+cover", "route+budget"}) {
    SCOPED_TRACE(name);
    DownloadPolicy policy = ParseDownloadPolicy(name);
    policy.mission_start_min = 20 * 60;
    policy.route = AnchoredRoute(LineA(20), {{20, 0, 0}, {40, 0, 0}});
    if (policy.budget_bytes) policy.budget_bytes = 100'000;
    const DownloadSelection at_base = base.Select(policy);
    const DownloadSelection at_head = head.Select(policy);
    const std::set<Uuid> was = Downloaded(at_base), is = Downloaded(at_head);
    std::set<Uuid> added, removed;
    std::set_difference(is.begin(), is.end(), was.begin(), was.end(),
                        std::inserter(added, added.end()));
    std::set_difference(was.begin(), was.end(), is.begin(), is.end(),
                        std::inserter(removed, removed.end()));
    std::set<Uuid> new_in_corridor;
    if (!policy.cover) {
      for (int n = 601; n <= 610; ++n) new_in_corridor.insert(NumberedUuid(n));
    }
    EXPECT_EQ(added, new_in_corridor);
    EXPECT_TRUE(removed.empty());

    RoutePlan shuffled = head;
    std::mt19937 rng(11);
    std::shuffle(shuffled.nodes.begin(), shuffled.nodes.end(), rng);
    std::shuffle(shuffled.paths.begin(), shuffled.paths.end(), rng);
    const DownloadSelection again = shuffled.Select(policy);
    EXPECT_EQ(again.nodes, at_head.nodes);
    EXPECT_EQ(again.edges, at_head.edges);
    EXPECT_EQ(again.paths, at_head.paths);
    EXPECT_EQ(again.report.route_covered_m, at_head.report.route_covered_m);
  }
  // A route by an outing the base revision does not hold yet cannot be selected there: the
  // server must then send the head's selection whole. At the head, 806 made its nodes (no path
  // memory), joined in stamp order: x = 41 … 59 then 81 … 89, 2 m aside from A and from B, whose
  // nodes within √96 = 9.8 m along (x = 32 … 98) join its own 15.
  DownloadPolicy by_outing = ParseDownloadPolicy("route");
  by_outing.route = DownloadRoute{};
  by_outing.route->outing = NumberedUuid(806);
  EXPECT_EQ(head.Select(by_outing).report.corridor_nodes,
            Ids({{LineA, {32, 98}}, {LineB, {32, 98}}}).size() + 15);
  ExpectError(
      ErrorCode::kNotFound, [&] { base.Select(by_outing); }, "outing");
}

}  // namespace
}  // namespace fleetmap
