#include "fleetmap/map_management/download_route.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <unordered_map>
#include <utility>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// A route given as positions is at most this long, whatever the map: a bound checked before
// the map is read (ValidateDownloadRoute); the map's own bound (kMaxRouteLengthPerMapExtent)
// is the one that holds the work down.
constexpr double kMaxRouteLength_m = 1e6;
// A route given as positions is at most this many times the extent of the map it is placed in
// (download_route.h). A lap of a map's perimeter is under 3 of its diagonals, so this allows
// some 30 laps: more than a mission drives through one map, and far less than a route in the
// wrong frame or units, or one made to keep the server busy.
constexpr double kMaxRouteLengthPerMapExtent = 100.0;
// Boxes are widened by this beyond their reach, and a clipped step range by a step either way,
// so that rounding in the clipping never drops a step the exact test would keep.
constexpr double kRouteBoxSlack_m = 0.01;
// The grids' cells are never smaller than this, so a thin corridor is not walked in
// vanishing steps.
constexpr double kMinRouteCell_m = 1.0;

[[noreturn]] void InvalidRoute(const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, "download route: " + message);
}

std::string RouteNumber(double value) {
  std::ostringstream text;
  text << value;
  return text.str();
}

std::string_view TrimRouteLine(std::string_view line) {
  const auto space = [](char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; };
  while (!line.empty() && space(line.front())) line.remove_prefix(1);
  while (!line.empty() && space(line.back())) line.remove_suffix(1);
  return line;
}

std::vector<std::string_view> RouteTokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t at = 0;
  while (at < line.size()) {
    while (at < line.size() && (line[at] == ' ' || line[at] == '\t')) ++at;
    const std::size_t begin = at;
    while (at < line.size() && line[at] != ' ' && line[at] != '\t') ++at;
    if (at > begin) tokens.push_back(line.substr(begin, at - begin));
  }
  return tokens;
}

double PolylineLength(std::span<const Eigen::Vector3d> p_m) {
  double length = 0.0;
  for (std::size_t i = 1; i < p_m.size(); ++i) length += (p_m[i] - p_m[i - 1]).norm();
  return length;
}

double DistanceToSegment(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                         const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double squared = ab.squaredNorm();
  if (squared == 0.0) return (p - a).norm();
  const double t = std::clamp((p - a).dot(ab) / squared, 0.0, 1.0);
  return (p - (a + t * ab)).norm();
}

// An axis-aligned box, empty until a point is added.
struct RouteBox {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());

  bool empty() const { return !(lo.array() <= hi.array()).all(); }
  void Add(const Eigen::Vector3d& p) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  RouteBox Widened(double by_m) const {
    if (empty()) return *this;
    return RouteBox{(lo.array() - by_m).matrix(), (hi.array() + by_m).matrix()};
  }
  double diagonal_m() const { return empty() ? 0.0 : (hi - lo).norm(); }
};

// The boxes of the nodes flagged in `flags` (all when empty) by component, widened by `by_m`.
std::vector<RouteBox> ComponentBoxes(std::span<const std::size_t> component,
                                     std::span<const Eigen::Vector3d> p_m,
                                     std::span<const char> flags, double by_m) {
  std::vector<RouteBox> boxes;
  for (std::size_t i = 0; i < p_m.size(); ++i) {
    if (!flags.empty() && !flags[i]) continue;
    if (component[i] >= boxes.size()) boxes.resize(component[i] + 1);
    boxes[component[i]].Add(p_m[i]);
  }
  for (RouteBox& box : boxes) box = box.Widened(by_m);
  return boxes;
}

// The parameters [t0, t1] within [0, 1] where a + t (b - a) is inside `box` (the slab method);
// false when the segment misses it.
bool ClipToBox(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const RouteBox& box, double& t0,
               double& t1) {
  t0 = 0.0;
  t1 = 1.0;
  if (box.empty()) return false;
  for (int k = 0; k < 3; ++k) {
    const double d = b[k] - a[k];
    if (d == 0.0) {
      if (a[k] < box.lo[k] || a[k] > box.hi[k]) return false;
      continue;
    }
    double enter = (box.lo[k] - a[k]) / d, leave = (box.hi[k] - a[k]) / d;
    if (enter > leave) std::swap(enter, leave);
    t0 = std::max(t0, enter);
    t1 = std::min(t1, leave);
    if (t0 > t1) return false;
  }
  return true;
}

// Nodes by (component, cube of `cell_m`), to find those near a point or a short segment without
// walking the whole map.
class RouteNodeGrid {
 public:
  explicit RouteNodeGrid(double cell_m) : cell_m_(std::max(cell_m, kMinRouteCell_m)) {}

  double cell_m() const { return cell_m_; }

  void Add(std::size_t component, const Eigen::Vector3d& p_m, std::size_t node) {
    cells_[KeyOf(component, p_m)].push_back(node);
  }

  // Calls visit(node) for every node in the cells that the box [lo, hi] touches.
  // Counts the cells looked up in `cells_probed`.
  template <typename Visit>
  void ForEachNear(std::size_t component, const Eigen::Vector3d& lo, const Eigen::Vector3d& hi,
                   std::size_t& cells_probed, Visit&& visit) const {
    const Key from = KeyOf(component, lo), to = KeyOf(component, hi);
    for (long x = from.x; x <= to.x; ++x) {
      for (long y = from.y; y <= to.y; ++y) {
        for (long z = from.z; z <= to.z; ++z) {
          ++cells_probed;
          const auto it = cells_.find(Key{component, x, y, z});
          if (it == cells_.end()) continue;
          for (const std::size_t node : it->second) visit(node);
        }
      }
    }
  }

 private:
  struct Key {
    std::size_t component;
    long x, y, z;
    friend bool operator==(const Key&, const Key&) = default;
  };
  struct KeyHash {
    std::size_t operator()(const Key& key) const noexcept {
      std::size_t h = std::hash<std::size_t>{}(key.component);
      for (const long v : {key.x, key.y, key.z}) {
        h = h * 0x9E3779B97F4A7C15ULL + std::hash<long>{}(v);
      }
      return h;
    }
  };

  Key KeyOf(std::size_t component, const Eigen::Vector3d& p_m) const {
    // Clamped (monotone, so a box's cells still hold everything in it) far from any real map,
    // so a wild layout cannot overflow the cast.
    const auto cell = [this](double v) {
      return static_cast<long>(std::clamp(std::floor(v / cell_m_), -1e12, 1e12));
    };
    return Key{component, cell(p_m.x()), cell(p_m.y()), cell(p_m.z())};
  }

  double cell_m_;
  std::unordered_map<Key, std::vector<std::size_t>, KeyHash> cells_;
};

// Calls visit(a, b) for consecutive sub-segments of a piece's polyline at most `step_m` long
// (a piece of one place: once, with a == b), but only for those that may touch `box`: a
// segment is cut into the same steps as a walk of all of it would cut it, and the steps
// outside the box are skipped without being made. So what a walk costs is the route's length
// within the box (the map near the route), not its length.
template <typename Visit>
void ForEachStepIn(std::span<const Eigen::Vector3d> p_m, double step_m, const RouteBox& box,
                   Visit&& visit) {
  if (p_m.size() == 1) visit(p_m[0], p_m[0]);
  for (std::size_t i = 1; i < p_m.size(); ++i) {
    const Eigen::Vector3d& a = p_m[i - 1];
    const Eigen::Vector3d& b = p_m[i];
    double t0 = 0.0, t1 = 1.0;
    if (!ClipToBox(a, b, box, t0, t1)) continue;
    const double length = (b - a).norm();
    const auto steps =
        std::max<std::size_t>(1, static_cast<std::size_t>(std::ceil(length / step_m)));
    const double last = static_cast<double>(steps - 1);
    // Step s spans [s, s + 1] / steps; it may touch [t0, t1] when s is in [t0 steps - 1,
    // t1 steps], widened by a step for rounding.
    const auto from = static_cast<std::size_t>(
        std::clamp(std::floor(t0 * static_cast<double>(steps)) - 2.0, 0.0, last));
    const auto to = static_cast<std::size_t>(
        std::clamp(std::floor(t1 * static_cast<double>(steps)) + 1.0, 0.0, last));
    for (std::size_t s = from; s <= to; ++s) {
      visit(a + (b - a) * (static_cast<double>(s) / static_cast<double>(steps)),
            a + (b - a) * (static_cast<double>(s + 1) / static_cast<double>(steps)));
    }
  }
}

// An outing's places (node positions) in the order it visited them: chains of its path edges,
// then the nodes it made that are on none of them (download_route.h).
std::vector<std::vector<std::size_t>> OutingPlaces(
    const Uuid& outing, std::span<const Node* const> nodes, std::span<const Edge> edges,
    std::span<const Path> paths, const std::unordered_map<Uuid, std::size_t>& position) {
  std::vector<const Path*> outing_paths;
  for (const Path& path : paths) {
    if (path.outing == outing) outing_paths.push_back(&path);
  }
  std::sort(outing_paths.begin(), outing_paths.end(), [](const Path* a, const Path* b) {
    return std::pair(a->start_ns, a->id) < std::pair(b->start_ns, b->id);
  });
  std::unordered_map<Uuid, std::size_t> path_rank;
  for (std::size_t r = 0; r < outing_paths.size(); ++r) path_rank.emplace(outing_paths[r]->id, r);

  std::vector<const Edge*> steps;
  for (const Edge& edge : edges) {
    if (edge.kind == EdgeKind::kPath && path_rank.contains(edge.path)) steps.push_back(&edge);
  }
  std::sort(steps.begin(), steps.end(), [&](const Edge* a, const Edge* b) {
    return std::pair(path_rank.at(a->path), a->id) < std::pair(path_rank.at(b->path), b->id);
  });

  std::vector<std::vector<std::size_t>> chains;
  std::vector<char> on_path(nodes.size(), 0);
  const Uuid* chain_path = nullptr;
  for (const Edge* step : steps) {
    std::size_t ends[2];
    for (int e = 0; e < 2; ++e) {
      const Uuid& end = e == 0 ? step->from : step->to;
      const auto it = position.find(end);
      if (it == position.end()) {
        throw Error(ErrorCode::kIntegrity, "download route: path edge " + step->id.ToString() +
                                               " of outing " + outing.ToString() + " ends at " +
                                               end.ToString() + ", which is not among the nodes");
      }
      ends[e] = it->second;
      on_path[it->second] = 1;
    }
    if (chains.empty() || *chain_path != step->path || chains.back().back() != ends[0]) {
      chains.push_back({ends[0]});
      chain_path = &step->path;
    }
    chains.back().push_back(ends[1]);
  }

  std::vector<std::size_t> made;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i]->outing == outing && !on_path[i]) made.push_back(i);
  }
  std::sort(made.begin(), made.end(), [&](std::size_t a, std::size_t b) {
    return std::pair(nodes[a]->stamp_ns, nodes[a]->id) <
           std::pair(nodes[b]->stamp_ns, nodes[b]->id);
  });
  if (!made.empty()) chains.push_back(std::move(made));
  if (chains.empty()) {
    throw Error(ErrorCode::kNotFound, "download route: outing " + outing.ToString() +
                                          " is not in the map (no node made by it, none on a "
                                          "path of it)");
  }
  return chains;
}

}  // namespace

void ValidateDownloadRoute(const DownloadRoute& route) {
  if (route.outing.has_value() == route.anchor.has_value()) {
    InvalidRoute(route.outing ? "give an outing or an anchor, not both"
                              : "give an outing's UUID, or an anchor node with positions (a "
                                "policy name with \"route\" only asks for one)");
  }
  if (route.outing) {
    if (route.outing->IsNil()) InvalidRoute("the outing is the nil UUID");
    if (!route.anchor_p_m.empty()) {
      InvalidRoute("an outing's route takes no positions (they belong to an anchor)");
    }
  } else {
    if (route.anchor->IsNil()) InvalidRoute("the anchor is the nil UUID");
    if (route.anchor_p_m.empty()) {
      InvalidRoute("anchor " + route.anchor->ToString() + " has no positions");
    }
    for (std::size_t i = 0; i < route.anchor_p_m.size(); ++i) {
      if (!route.anchor_p_m[i].allFinite()) {
        InvalidRoute("position " + std::to_string(i + 1) + " is not finite");
      }
    }
    const double length = PolylineLength(route.anchor_p_m);
    if (!(length <= kMaxRouteLength_m)) {
      InvalidRoute("the positions run " + RouteNumber(length) + " m, more than " +
                   RouteNumber(kMaxRouteLength_m) + " m");
    }
  }
  if (!(route.radius_m > 0.0 && std::isfinite(route.radius_m))) {
    InvalidRoute("radius_m must be finite and > 0, not " + RouteNumber(route.radius_m));
  }
}

DownloadRoute ParseDownloadRoute(std::string_view text) {
  std::vector<std::pair<std::size_t, std::string_view>> lines;  // (line number, text)
  std::size_t number = 0;
  for (std::size_t begin = 0; begin <= text.size();) {
    const std::size_t end = std::min(text.find_first_of("\n;", begin), text.size());
    ++number;
    const std::string_view line = TrimRouteLine(text.substr(begin, end - begin));
    if (!line.empty() && line.front() != '#') lines.emplace_back(number, line);
    begin = end + 1;
  }
  if (lines.empty()) {
    InvalidRoute("empty; expected an outing's UUID, or \"anchor UUID\" then lines of \"x y z\"");
  }
  const auto parse_uuid = [](std::string_view token, const std::string& what) {
    try {
      return Uuid::Parse(token);
    } catch (const Error&) {
      InvalidRoute("\"" + std::string(token) + "\" is not " + what + "'s UUID");
    }
  };

  DownloadRoute route;
  const std::vector<std::string_view> first = RouteTokens(lines.front().second);
  if (first.size() == 1 && first[0] != "anchor") {
    route.outing = parse_uuid(first[0], "an outing");
    if (lines.size() > 1) {
      InvalidRoute("an outing's UUID stands alone, but line " + std::to_string(lines[1].first) +
                   " follows: \"" + std::string(lines[1].second) + "\"");
    }
    ValidateDownloadRoute(route);
    return route;
  }
  if (first.empty() || first[0] != "anchor" || first.size() != 2) {
    InvalidRoute("expected an outing's UUID or \"anchor UUID\" first, not \"" +
                 std::string(lines.front().second) + "\"");
  }
  route.anchor = parse_uuid(first[1], "an anchor node");
  for (std::size_t l = 1; l < lines.size(); ++l) {
    const auto& [line_number, line] = lines[l];
    const std::vector<std::string_view> tokens = RouteTokens(line);
    Eigen::Vector3d p_m;
    bool good = tokens.size() == 3;
    for (std::size_t k = 0; good && k < 3; ++k) {
      const char* begin = tokens[k].data();
      const char* end = begin + tokens[k].size();
      const auto [stop, error] = std::from_chars(begin, end, p_m[static_cast<Eigen::Index>(k)]);
      good =
          error == std::errc() && stop == end && std::isfinite(p_m[static_cast<Eigen::Index>(k)]);
    }
    if (!good) {
      InvalidRoute("line " + std::to_string(line_number) +
                   ": expected \"x y z\" (three finite numbers, metres), not \"" +
                   std::string(line) + "\"");
    }
    route.anchor_p_m.push_back(p_m);
  }
  if (route.anchor_p_m.empty()) {
    InvalidRoute("anchor " + route.anchor->ToString() +
                 " has no positions; give lines of \"x y z\" after it");
  }
  ValidateDownloadRoute(route);
  return route;
}

RouteCorridor RouteCorridor::Place(const MapLayout& layout, std::span<const Node* const> nodes,
                                   std::span<const Edge> edges, std::span<const Path> paths,
                                   const DownloadRoute& route) {
  ValidateDownloadRoute(route);
  std::unordered_map<Uuid, std::size_t> position;
  position.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) position.emplace(nodes[i]->id, i);

  RouteCorridor corridor;
  corridor.component_ = layout.component;
  corridor.root_p_node_m_.reserve(nodes.size());
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    corridor.root_p_node_m_.push_back(layout.position_m(i));
  }

  if (route.anchor) {
    const auto it = position.find(*route.anchor);
    if (it == position.end()) {
      throw Error(ErrorCode::kNotFound,
                  "download route: anchor node " + route.anchor->ToString() + " is not in the map");
    }
    Piece& piece = corridor.pieces_.emplace_back();
    piece.component = layout.component[it->second];
    const Se3& root_T_anchor = layout.root_T_node[it->second];
    for (const Eigen::Vector3d& anchor_p : route.anchor_p_m) {
      piece.p_m.push_back(root_T_anchor * anchor_p);
    }
  } else {
    for (const std::vector<std::size_t>& chain :
         OutingPlaces(*route.outing, nodes, edges, paths, position)) {
      for (std::size_t i = 0; i < chain.size(); ++i) {
        const std::size_t node = chain[i];
        if (i == 0 || layout.component[node] != layout.component[chain[i - 1]]) {
          corridor.pieces_.emplace_back().component = layout.component[node];
        }
        corridor.pieces_.back().nodes.push_back(node);
        corridor.pieces_.back().p_m.push_back(layout.position_m(node));
      }
    }
  }

  // The map near each component: what the corridor can reach there. Steps of the route
  // outside it are never made (ForEachStepIn).
  const std::vector<RouteBox> near_map = ComponentBoxes(layout.component, corridor.root_p_node_m_,
                                                        {}, route.radius_m + kRouteBoxSlack_m);
  const auto box_of = [&near_map](std::size_t component) {
    return component < near_map.size() ? near_map[component] : RouteBox{};
  };
  if (route.anchor) {
    // A route given as positions is judged against the map it is placed in (download_route.h):
    // far longer than that map it is refused before any walk (near none of its nodes, after).
    const Piece& piece = corridor.pieces_.front();
    const double length_m = PolylineLength(piece.p_m);
    const double extent_m = box_of(piece.component).diagonal_m();
    if (length_m > kMaxRouteLengthPerMapExtent * extent_m) {
      InvalidRoute("the positions run " + RouteNumber(length_m) + " m, more than " +
                   RouteNumber(kMaxRouteLengthPerMapExtent) + " times the extent of the map " +
                   "around anchor " + route.anchor->ToString() + " (" + RouteNumber(extent_m) +
                   " m: the diagonal of its component's box, widened by radius_m); a route is " +
                   "driven through the map it downloads (are the positions in the anchor's " +
                   "camera frame, in metres?)");
    }
  }

  RouteNodeGrid grid(route.radius_m);
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    grid.Add(layout.component[i], layout.position_m(i), i);
  }
  corridor.members_.assign(nodes.size(), 0);
  const Eigen::Vector3d reach = Eigen::Vector3d::Constant(route.radius_m);
  for (const Piece& piece : corridor.pieces_) {
    corridor.length_m_ += PolylineLength(piece.p_m);
    ForEachStepIn(piece.p_m, grid.cell_m(), box_of(piece.component),
                  [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
                    grid.ForEachNear(piece.component, a.cwiseMin(b) - reach, a.cwiseMax(b) + reach,
                                     corridor.cells_probed_, [&](std::size_t node) {
                                       if (!corridor.members_[node] &&
                                           DistanceToSegment(corridor.root_p_node_m_[node], a, b) <=
                                               route.radius_m) {
                                         corridor.members_[node] = 1;
                                         ++corridor.size_;
                                       }
                                     });
                  });
  }
  if (route.anchor && corridor.size_ == 0) {
    InvalidRoute("the positions come within radius_m = " + RouteNumber(route.radius_m) +
                 " m of no node of the map (are they in anchor " + route.anchor->ToString() +
                 "'s camera frame, in metres?)");
  }
  return corridor;
}

double RouteCorridor::LengthNear(std::span<const char> kept, double reach_m,
                                 std::size_t* cells_probed) const {
  RouteNodeGrid grid(reach_m);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    if (kept[i]) grid.Add(component_[i], root_p_node_m_[i], i);
  }
  // A sample farther than reach_m from every kept node's box is near none: never made.
  const std::vector<RouteBox> near_kept =
      ComponentBoxes(component_, root_p_node_m_, kept, reach_m + kRouteBoxSlack_m);
  const Eigen::Vector3d reach = Eigen::Vector3d::Constant(reach_m);
  std::size_t probed = 0;
  double near_m = 0.0;
  for (const Piece& piece : pieces_) {
    if (piece.p_m.size() < 2) continue;  // a place alone has no length
    if (piece.component >= near_kept.size()) continue;
    ForEachStepIn(piece.p_m, kRouteSampleStep_m, near_kept[piece.component],
                  [&](const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
                    const Eigen::Vector3d middle = 0.5 * (a + b);
                    bool near = false;
                    grid.ForEachNear(piece.component, middle - reach, middle + reach, probed,
                                     [&](std::size_t node) {
                                       near = near ||
                                              (root_p_node_m_[node] - middle).norm() <= reach_m;
                                     });
                    if (near) near_m += (b - a).norm();
                  });
  }
  if (cells_probed) *cells_probed += probed;
  return near_m;
}

DownloadRoute RouteOfArgument(const std::string& argument, double radius_m) {
  std::string text = argument;
  std::error_code error;
  if (std::filesystem::is_regular_file(argument, error)) {
    std::ifstream in(argument);
    std::stringstream content;
    content << in.rdbuf();
    if (!in) throw Error(ErrorCode::kNotFound, "--route " + argument + ": cannot be read");
    text = content.str();
  }
  DownloadRoute route;
  try {
    route = ParseDownloadRoute(text);
  } catch (const Error& e) {
    throw Error(e.code(), "--route " + argument + ": " + e.message());
  }
  if (radius_m != 0.0) route.radius_m = radius_m;
  ValidateDownloadRoute(route);
  return route;
}

}  // namespace fleetmap
