#include "fleetmap/interchange/map_picture.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <set>
#include <string_view>
#include <utility>

namespace fleetmap {
namespace {

// The picture's furniture, in pixels.
constexpr double kMargin = 16.0;
constexpr double kHeaderHeight = 58.0;        // title and subtitle above the map
constexpr double kFooterHeight = 72.0;        // scale bar and legend below it
constexpr double kBoxPadding = 10.0;          // from a component's frame to its outermost node
constexpr double kBoxGap = 20.0;              // between components' frames
constexpr double kMaxPixelsPerMetre = 100.0;  // a map of a few metres is not blown up further
constexpr int kMinWidth = 800;                // room for the legend
constexpr double kTitleHeight = 14.0, kTextHeight = 9.0;

constexpr Rgb kText{29, 39, 51};
constexpr Rgb kQuietText{91, 107, 124};
constexpr Rgb kFrameFill{247, 249, 251};
constexpr Rgb kFrameOutline{213, 220, 228};
constexpr Rgb kMetricEdge{91, 103, 115};
constexpr Rgb kPathEdge{196, 204, 212};       // faint: path memory has no pose, only an order
constexpr Rgb kHiddenOutline{206, 211, 217};  // a hidden node is faded, outline and all
constexpr double kMetricEdgeWidth = 1.3, kPathEdgeWidth = 1.0;

constexpr double kNsPerHour = 3600.0 * 1e9;

struct Extent {
  double min_u = std::numeric_limits<double>::infinity();
  double max_u = -std::numeric_limits<double>::infinity();
  double min_v = std::numeric_limits<double>::infinity();
  double max_v = -std::numeric_limits<double>::infinity();
  double width_m() const { return max_u - min_u; }
  double height_m() const { return max_v - min_v; }
};

struct Packing {
  std::vector<PictureBox> boxes;  // relative to the map area's top left
  double width = 0.0, height = 0.0;
};

// Shelf packing: components in their order, left to right, a new row when the next would make
// the row wider than `max_width` (a box wider than that gets a row of its own).
Packing Pack(const std::vector<Extent>& extents, double pixels_per_metre, double max_width) {
  Packing packing;
  double x = 0.0, row_top = 0.0, row_height = 0.0;
  for (const Extent& extent : extents) {
    const double w = extent.width_m() * pixels_per_metre + 2 * kBoxPadding;
    const double h = extent.height_m() * pixels_per_metre + 2 * kBoxPadding;
    if (x > 0.0 && x + w > max_width) {
      row_top += row_height + kBoxGap;
      x = 0.0;
      row_height = 0.0;
    }
    packing.boxes.push_back(PictureBox{x, row_top, w, h});
    x += w + kBoxGap;
    row_height = std::max(row_height, h);
    packing.width = std::max(packing.width, x - kBoxGap);
  }
  packing.height = row_top + row_height;
  return packing;
}

// 1, 2 or 5 times a power of ten: the longest such length at most `most_m`.
double RoundLength(double most_m) {
  const double power = std::pow(10.0, std::floor(std::log10(most_m)));
  for (const double step : {5.0, 2.0, 1.0}) {
    if (step * power <= most_m * (1 + 1e-9)) return step * power;
  }
  return power;
}

std::string MetresText(double metres) {
  char text[32];
  std::snprintf(text, sizeof text, metres >= 1.0 ? "%.0f m" : "%g m", metres);
  return text;
}

Rgb Darker(Rgb colour) {
  const auto scale = [](std::uint8_t c) { return static_cast<std::uint8_t>(c * 0.55); };
  return Rgb{scale(colour.r), scale(colour.g), scale(colour.b)};
}

std::string Count(std::size_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// At least the width of a line of text on either canvas, whose fonts this file cannot measure:
// the PNG canvas's Hershey simplex and the SVG's sans-serif (DejaVu Sans, or a narrower Arial).
// Each character class advances by the wider of the two fonts, in capital heights, rounded up.
double TextWidthBound(std::string_view text, double cap_height_px) {
  const auto in = [](std::string_view set, char c) { return set.find(c) != set.npos; };
  double advances = 0.0;
  for (const char c : text) {
    if (in("il.,:;'|Ij", c)) {
      advances += 0.5;
    } else if (in("!ftr()[]", c)) {
      advances += 0.65;
    } else if (in(" \"*`", c)) {
      advances += 0.7;
    } else if (in("mwMW@%&", c)) {
      advances += 1.4;
    } else if (in("-+=<>~#^", c)) {
      advances += 1.2;
    } else if (in("/\\", c) || (c >= 'A' && c <= 'Z')) {
      advances += 1.1;
    } else {
      advances += 0.9;  // other letters, digits, braces, a byte of UTF-8
    }
  }
  return advances * cap_height_px;
}

// The picture's width: at least `least_px`, and room for its title and subtitle.
int WidthForText(int least_px, std::string_view title, std::string_view subtitle,
                 double subtitle_height) {
  const double text =
      std::max(TextWidthBound(title, kTitleHeight), TextWidthBound(subtitle, subtitle_height));
  return std::max(least_px, static_cast<int>(std::ceil(text + 2 * kMargin)));
}

}  // namespace

Rgb TimeOfDayColour(double hours) {
  double h = std::fmod(hours, 24.0);
  if (h < 0) h += 24.0;
  // Hue 240 (blue) at midnight, a full turn a day: noon is 60 (yellow).
  const double hue = std::fmod(240.0 + 360.0 * h / 24.0, 360.0) / 60.0;
  const double value = 0.9, saturation = 0.85;
  const double chroma = value * saturation;
  const double x = chroma * (1 - std::abs(std::fmod(hue, 2.0) - 1));
  double r = 0, g = 0, b = 0;
  switch (static_cast<int>(hue)) {
    case 0:
      r = chroma, g = x;
      break;
    case 1:
      r = x, g = chroma;
      break;
    case 2:
      g = chroma, b = x;
      break;
    case 3:
      g = x, b = chroma;
      break;
    case 4:
      r = x, b = chroma;
      break;
    default:
      r = chroma, b = x;
  }
  const double m = value - chroma;
  const auto byte = [m](double c) { return static_cast<std::uint8_t>(std::lround((c + m) * 255)); };
  return Rgb{byte(r), byte(g), byte(b)};
}

Rgb RevisionColour(double t) {
  // viridis at 0, 1/4, 1/2, 3/4 and 1.
  static constexpr std::array<Rgb, 5> kAnchors = {
      Rgb{68, 1, 84}, Rgb{59, 82, 139}, Rgb{33, 145, 140}, Rgb{94, 201, 98}, Rgb{253, 231, 37}};
  const double at = std::clamp(t, 0.0, 1.0) * (kAnchors.size() - 1);
  const std::size_t i = std::min<std::size_t>(static_cast<std::size_t>(at), kAnchors.size() - 2);
  const double f = at - static_cast<double>(i);
  const auto mix = [f](std::uint8_t a, std::uint8_t b) {
    return static_cast<std::uint8_t>(std::lround(a + (b - a) * f));
  };
  return Rgb{mix(kAnchors[i].r, kAnchors[i + 1].r), mix(kAnchors[i].g, kAnchors[i + 1].g),
             mix(kAnchors[i].b, kAnchors[i + 1].b)};
}

namespace {

// Each component's extent on the plane (u = x, v = z; see the header).
std::vector<Extent> ComponentExtents(const GraphLayout& layout) {
  std::vector<Extent> extents(layout.component_count());
  for (const LaidOutNode& node : layout.nodes()) {
    const Eigen::Vector3d p = node.layout_T_node.translation();
    Extent& e = extents[static_cast<std::size_t>(node.component)];
    e.min_u = std::min(e.min_u, p.x());
    e.max_u = std::max(e.max_u, p.x());
    e.min_v = std::min(e.min_v, p.z());
    e.max_v = std::max(e.max_v, p.z());
  }
  return extents;
}

// The scale the components are drawn at, and their boxes packed at it.
struct Fit {
  double pixels_per_metre;
  Packing packing;
};

// The scale: as large as kMaxPixelsPerMetre allows with the widest component within the
// width, then smaller until the rows fit the height. Frames and gaps are in pixels, so a map
// of many small components may never fit: then it stops shrinking once that no longer helps
// and the picture grows taller instead.
Fit FitToSize(const std::vector<Extent>& extents, const MapPictureOptions& options) {
  const double max_width = std::max(options.max_map_width_px, 100);
  const double max_height = std::max(options.max_map_height_px, 100);
  double ppm = kMaxPixelsPerMetre;
  for (const Extent& e : extents) {
    if (e.width_m() > 0) ppm = std::min(ppm, (max_width - 2 * kBoxPadding) / e.width_m());
    if (e.height_m() > 0) ppm = std::min(ppm, (max_height - 2 * kBoxPadding) / e.height_m());
  }
  Packing packing = Pack(extents, ppm, max_width);
  for (int attempt = 0; attempt < 80 && packing.height > max_height; ++attempt) {
    const Packing smaller = Pack(extents, ppm * 0.85, max_width);
    if (smaller.height > packing.height * 0.995) break;  // frames and gaps dominate now
    ppm *= 0.85;
    packing = smaller;
  }
  return Fit{ppm, std::move(packing)};
}

// Each node's colour: by the revision that added it (setting `first_revision` and
// `last_revision` to the range seen) or by its time of day.
std::vector<Rgb> NodeColours(const std::vector<LaidOutNode>& laid_out,
                             const MapPictureOptions& options, std::int64_t& first_revision,
                             std::int64_t& last_revision) {
  std::vector<Rgb> colours;
  if (options.colouring == NodeColouring::kRevision) {
    first_revision = std::numeric_limits<std::int64_t>::max();
    last_revision = std::numeric_limits<std::int64_t>::min();
  }
  if (options.colouring == NodeColouring::kChange) {
    for (const LaidOutNode& node : laid_out) {
      const auto found = options.node_change.find(node.id);
      const NodeChange change =
          found == options.node_change.end() ? NodeChange::kUnchanged : found->second;
      colours.push_back(change == NodeChange::kAdded    ? MapPicture::kAddedNode
                        : change == NodeChange::kHidden ? MapPicture::kHiddenNode
                                                        : MapPicture::kUnchangedNode);
    }
    return colours;
  }
  std::vector<std::int64_t> revision(laid_out.size(), 0);
  for (std::size_t i = 0; i < laid_out.size(); ++i) {
    if (options.colouring == NodeColouring::kRevision) {
      const auto found = options.node_revision.find(laid_out[i].id);
      revision[i] = found == options.node_revision.end() ? 0 : found->second;
      first_revision = std::min(first_revision, revision[i]);
      last_revision = std::max(last_revision, revision[i]);
    }
  }
  for (std::size_t i = 0; i < laid_out.size(); ++i) {
    if (options.colouring == NodeColouring::kRevision) {
      const std::int64_t span = last_revision - first_revision;
      colours.push_back(RevisionColour(span == 0
                                           ? 0.5
                                           : static_cast<double>(revision[i] - first_revision) /
                                                 static_cast<double>(span)));
    } else {
      // Floor division, so a stamp before 1970 still has its hour of the day.
      const std::int64_t day_ns = 24 * static_cast<std::int64_t>(kNsPerHour);
      const std::int64_t of_day = ((laid_out[i].stamp_ns % day_ns) + day_ns) % day_ns;
      colours.push_back(TimeOfDayColour(static_cast<double>(of_day) / kNsPerHour));
    }
  }
  return colours;
}

}  // namespace

MapPicture MapPicture::Compose(const GraphLayout& layout, const std::vector<Edge>& edges,
                               const MapPictureOptions& options) {
  MapPicture picture;
  picture.title_ = options.title.empty() ? "experience map" : options.title;
  picture.colouring_ = options.colouring;
  const std::vector<LaidOutNode>& laid_out = layout.nodes();
  if (laid_out.empty()) {
    picture.subtitle_ = "no nodes: nothing to draw";
    picture.width_px_ = WidthForText(640, picture.title_, picture.subtitle_, kTitleHeight);
    picture.height_px_ = 140;
    return picture;
  }

  const std::vector<Extent> extents = ComponentExtents(layout);
  const Fit fit = FitToSize(extents, options);
  const double ppm = fit.pixels_per_metre;
  const Packing& packing = fit.packing;
  picture.pixels_per_metre_ = ppm;

  const double map_left = kMargin, map_top = kHeaderHeight;
  for (PictureBox box : packing.boxes) {
    box.left += map_left;
    box.top += map_top;
    picture.component_box_.push_back(box);
  }
  picture.width_px_ = std::max(kMinWidth, static_cast<int>(std::ceil(packing.width + 2 * kMargin)));
  picture.footer_top_ = map_top + packing.height + 12.0;
  picture.height_px_ = static_cast<int>(std::ceil(picture.footer_top_ + kFooterHeight));

  // Nodes: positions and colours.
  for (const LaidOutNode& node : laid_out) {
    const auto c = static_cast<std::size_t>(node.component);
    const Extent& e = extents[c];
    const PictureBox& box = picture.component_box_[c];
    const Eigen::Vector3d p = node.layout_T_node.translation();
    picture.node_xy_.push_back(CanvasPoint{box.left + kBoxPadding + (p.x() - e.min_u) * ppm,
                                           box.top + kBoxPadding + (e.max_v - p.z()) * ppm});
    picture.drawn_.push_back(DrawnNode{node.id, node.robot, node.outing, node.stamp_ns});
  }
  picture.node_colour_ =
      NodeColours(laid_out, options, picture.first_revision_, picture.last_revision_);
  picture.node_change_.assign(laid_out.size(), NodeChange::kUnchanged);
  if (options.colouring == NodeColouring::kChange) {
    for (std::size_t i = 0; i < laid_out.size(); ++i) {
      const auto found = options.node_change.find(laid_out[i].id);
      if (found != options.node_change.end()) picture.node_change_[i] = found->second;
      if (options.stand_ins.contains(laid_out[i].id)) picture.stand_in_nodes_.push_back(i);
    }
    picture.omitted_nodes_ = options.omitted_nodes;
    picture.change_range_ = options.change_range;
  }

  // Edges. A path edge between two nodes a metric edge joins would lie hidden under it.
  std::set<std::pair<std::size_t, std::size_t>> joined;
  for (const Edge& edge : edges) {
    const auto from = layout.IndexOf(edge.from), to = layout.IndexOf(edge.to);
    if (!from || !to) continue;  // Compute refused such a graph; nothing to draw
    if (edge.kind == EdgeKind::kMetric) {
      picture.metric_.push_back(EdgeLine{*from, *to});
      joined.insert(std::minmax(*from, *to));
    }
  }
  for (const Edge& edge : edges) {
    if (edge.kind != EdgeKind::kPath) continue;
    const auto from = layout.IndexOf(edge.from), to = layout.IndexOf(edge.to);
    if (!from || !to || joined.contains(std::minmax(*from, *to))) continue;
    picture.path_.push_back(EdgeLine{*from, *to});
  }
  std::size_t path_edges = 0;
  for (const Edge& edge : edges) path_edges += edge.kind == EdgeKind::kPath ? 1 : 0;

  picture.subtitle_ = Count(laid_out.size(), "node", "nodes") + ", " +
                      Count(picture.metric_.size(), "metric edge", "metric edges") + ", " +
                      Count(path_edges, "path edge", "path edges") + ", " +
                      Count(layout.component_count(), "component", "components") +
                      " (each in its own frame); seen from above: x right, z up";
  picture.width_px_ =
      WidthForText(picture.width_px_, picture.title_, picture.subtitle_, kTextHeight);
  picture.scale_bar_m_ = RoundLength(160.0 / ppm);
  return picture;
}

void MapPicture::Draw(Canvas& canvas) const {
  canvas.Begin(width_px_, height_px_, kBackground);
  canvas.BeginGroup("title");
  canvas.Text({kMargin, 26.0}, title_, kTitleHeight, kText, TextAnchor::kStart);
  if (empty()) {
    canvas.Text({width_px_ / 2.0, 90.0}, subtitle_, kTitleHeight, kQuietText, TextAnchor::kMiddle);
  } else {
    canvas.Text({kMargin, 46.0}, subtitle_, kTextHeight, kQuietText, TextAnchor::kStart);
  }
  canvas.EndGroup();
  canvas.BeginGroup("components");
  for (const PictureBox& box : component_box_) {
    canvas.Rectangle({box.left, box.top}, box.width, box.height, kFrameFill, kFrameOutline);
  }
  canvas.EndGroup();
  canvas.BeginGroup("path-edges");
  for (const EdgeLine& edge : path_) {
    canvas.Line(node_xy_[edge.from], node_xy_[edge.to], kPathEdgeWidth, kPathEdge);
  }
  canvas.EndGroup();
  canvas.BeginGroup("metric-edges");
  for (const EdgeLine& edge : metric_) {
    canvas.Line(node_xy_[edge.from], node_xy_[edge.to], kMetricEdgeWidth, kMetricEdge);
  }
  canvas.EndGroup();
  canvas.BeginGroup("nodes");
  for (std::size_t i = 0; i < node_xy_.size(); ++i) {
    canvas.Disc(node_xy_[i], kNodeRadiusPx, node_colour_[i],
                node_change_[i] == NodeChange::kHidden ? kHiddenOutline : Darker(node_colour_[i]));
  }
  canvas.EndGroup();
  if (colouring_ == NodeColouring::kChange) {
    canvas.BeginGroup("stand-ins");
    constexpr double kHalf = 2.0 * kNodeRadiusPx;
    for (const std::size_t i : stand_in_nodes_) {
      canvas.Rectangle({node_xy_[i].x - kHalf, node_xy_[i].y - kHalf}, 2 * kHalf, 2 * kHalf,
                       std::nullopt, kStandInMark);
    }
    canvas.EndGroup();
  }
  if (!empty()) {
    DrawScaleBar(canvas);
    DrawLegend(canvas);
  }
  canvas.End();
}

void MapPicture::DrawScaleBar(Canvas& canvas) const {
  canvas.BeginGroup("scale-bar");
  const double length_px = scale_bar_m_ * pixels_per_metre_;
  const double y = footer_top_ + 34.0;
  canvas.Text({kMargin, footer_top_ + 18.0}, "scale", kTextHeight, kQuietText, TextAnchor::kStart);
  canvas.Line({kMargin, y}, {kMargin + length_px, y}, 2.0, kText);
  canvas.Line({kMargin, y - 5}, {kMargin, y + 5}, 1.5, kText);
  canvas.Line({kMargin + length_px, y - 5}, {kMargin + length_px, y + 5}, 1.5, kText);
  canvas.Text({kMargin + length_px / 2, y + 20}, MetresText(scale_bar_m_), kTextHeight, kText,
              TextAnchor::kMiddle);
  canvas.EndGroup();
}

std::size_t MapPicture::nodes_with(NodeChange change) const {
  return static_cast<std::size_t>(std::count(node_change_.begin(), node_change_.end(), change));
}

void MapPicture::DrawChangeLegend(Canvas& canvas) const {
  const double left = kMargin + 200.0, top = footer_top_ + 16.0;
  canvas.Text({left, top}, "nodes: what " + change_range_ + " changed", kTextHeight, kText,
              TextAnchor::kStart);
  struct Entry {
    Rgb fill, outline;
    std::string label;
  };
  const std::vector<Entry> entries = {
      {kAddedNode, Darker(kAddedNode), Count(nodes_with(NodeChange::kAdded), "added", "added")},
      {kHiddenNode, kHiddenOutline,
       Count(nodes_with(NodeChange::kHidden), "hidden (faded)", "hidden (faded)")},
      {kUnchangedNode, Darker(kUnchangedNode),
       Count(nodes_with(NodeChange::kUnchanged), "unchanged", "unchanged")},
  };
  for (std::size_t k = 0; k < entries.size(); ++k) {
    const CanvasPoint at{left + 6.0 + 150.0 * static_cast<double>(k), top + 20.0};
    canvas.Disc(at, kNodeRadiusPx, entries[k].fill, entries[k].outline);
    canvas.Text({at.x + 10.0, at.y + 4.0}, entries[k].label, kTextHeight, kText,
                TextAnchor::kStart);
  }
  const CanvasPoint mark{left + 6.0, top + 44.0};
  canvas.Rectangle({mark.x - 2 * kNodeRadiusPx, mark.y - 2 * kNodeRadiusPx}, 4 * kNodeRadiusPx,
                   4 * kNodeRadiusPx, std::nullopt, kStandInMark);
  canvas.Text({mark.x + 10.0, mark.y + 4.0},
              Count(stand_in_nodes_.size(), "node stands", "nodes stand") + " in for " +
                  Count(omitted_nodes_, "omitted node", "omitted nodes") + " (squared)",
              kTextHeight, kText, TextAnchor::kStart);
}

void MapPicture::DrawLegend(Canvas& canvas) const {
  canvas.BeginGroup("legend");
  if (colouring_ == NodeColouring::kChange) {
    DrawChangeLegend(canvas);
    canvas.EndGroup();
    return;
  }
  // Node colours: a bar of the colour map with its stops labelled.
  const double bar_left = kMargin + 200.0, bar_width = 240.0, bar_top = footer_top_ + 24.0;
  const double bar_height = 12.0;
  const bool one_revision =
      colouring_ == NodeColouring::kRevision && first_revision_ == last_revision_;
  const double shown_width = one_revision ? 40.0 : bar_width;
  std::vector<LegendStop> stops;
  if (colouring_ == NodeColouring::kTimeOfDay) {
    canvas.Text({bar_left, footer_top_ + 16.0}, "node colour: time of day captured (UTC)",
                kTextHeight, kText, TextAnchor::kStart);
    constexpr int kSteps = 48;
    for (int s = 0; s < kSteps; ++s) {
      canvas.Rectangle({bar_left + bar_width * s / kSteps, bar_top}, bar_width / kSteps + 0.5,
                       bar_height, TimeOfDayColour(24.0 * (s + 0.5) / kSteps), std::nullopt);
    }
    for (int hour = 0; hour <= 24; hour += 6) {
      char label[8];
      std::snprintf(label, sizeof label, "%02d:00", hour);
      stops.push_back({hour / 24.0, label});
    }
  } else {
    canvas.Text({bar_left, footer_top_ + 16.0}, "node colour: revision that added it", kTextHeight,
                kText, TextAnchor::kStart);
    if (one_revision) {
      canvas.Rectangle({bar_left, bar_top}, shown_width, bar_height, RevisionColour(0.5),
                       std::nullopt);
      stops.push_back({shown_width / bar_width / 2, "r" + std::to_string(first_revision_)});
    } else {
      constexpr int kSteps = 48;
      for (int s = 0; s < kSteps; ++s) {
        canvas.Rectangle({bar_left + bar_width * s / kSteps, bar_top}, bar_width / kSteps + 0.5,
                         bar_height, RevisionColour((s + 0.5) / kSteps), std::nullopt);
      }
      stops.push_back({0.0, "r" + std::to_string(first_revision_)});
      if (last_revision_ - first_revision_ >= 2) {
        const std::int64_t middle = (first_revision_ + last_revision_) / 2;
        stops.push_back({static_cast<double>(middle - first_revision_) /
                             static_cast<double>(last_revision_ - first_revision_),
                         "r" + std::to_string(middle)});
      }
      stops.push_back({1.0, "r" + std::to_string(last_revision_)});
    }
  }
  canvas.Rectangle({bar_left, bar_top}, shown_width, bar_height, std::nullopt, kFrameOutline);
  for (const LegendStop& stop : stops) {
    const double x = bar_left + bar_width * stop.at;
    canvas.Line({x, bar_top + bar_height}, {x, bar_top + bar_height + 4}, 1.0, kQuietText);
    canvas.Text({x, bar_top + bar_height + 18}, stop.label, kTextHeight, kText,
                TextAnchor::kMiddle);
  }

  // Edges.
  const double edges_left = bar_left + bar_width + 50.0;
  canvas.Line({edges_left, footer_top_ + 22}, {edges_left + 30, footer_top_ + 22}, kMetricEdgeWidth,
              kMetricEdge);
  canvas.Text({edges_left + 38, footer_top_ + 26}, "metric edge (measured pose)", kTextHeight,
              kText, TextAnchor::kStart);
  canvas.Line({edges_left, footer_top_ + 46}, {edges_left + 30, footer_top_ + 46}, kPathEdgeWidth,
              kPathEdge);
  canvas.Text({edges_left + 38, footer_top_ + 50}, "path memory edge (no pose)", kTextHeight, kText,
              TextAnchor::kStart);
  canvas.EndGroup();
}

}  // namespace fleetmap
