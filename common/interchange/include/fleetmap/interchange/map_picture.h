// A picture of an experience map seen from above (`fleetmap render`, fleetmapd's status page):
// the graph layout (graph_layout.h) projected onto a plane, each connected component in its
// own box, the boxes side by side in rows so none overlaps; nodes as discs coloured by the
// time of day they were captured (a cyclic colour map) or by the revision that added them;
// metric edges as lines, path-memory edges (seed 002 §IV) faintly; a title, a legend and a
// scale bar. The picture describes itself once, as calls on a Canvas (canvas.h), so the SVG
// and PNG back ends draw the same thing.
//
// Conventions:
// - The plane is x/z of each component's layout frame, seen from -y: x to the right, z up the
//   picture. Layout frames are camera frames (OpenCV's: x right, y down, z forward; the
//   synthetic world and the stereo front end both use it), so for a camera that looks ahead
//   from a ground robot x/z is the ground, and a view from -y (above) with x right and z up is
//   not mirrored (x cross z = -y points at the viewer). A fixed plane rather than the two
//   axes of largest spread: those would change from map to map and component to component
//   (a straight route has only one large axis, and the second would be height noise), and
//   one map's pictures should be comparable.
// - One scale (pixels per metre) for every component; the scale bar shows a round length
//   (1, 2 or 5 times a power of ten metres). Frames of different components are unrelated
//   (nothing measured joins them), so the boxes' places relative to each other mean nothing.
// - Times of day are UTC, of the node's capture stamp.
// - The picture is at least wide enough for its legend, and for its title and subtitle as either
//   back end's font draws them (a long store path or reason is not cut at the right edge).
// - Groups (SVG ids): "components" (one frame per component, in component order), "path-edges",
//   "metric-edges", "nodes" (one disc per node, in node number order), "stand-ins" (kChange: a
//   square around each node that stands in for an omitted one), "legend", "scale-bar", "title".
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <unordered_map>
#include <unordered_set>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"
#include "fleetmap/interchange/canvas.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

enum class NodeColouring {
  kTimeOfDay,  // the UTC time of day of the node's stamp, on a colour wheel (00:00 = 24:00)
  kRevision,   // the revision that added the node, from the earliest shown to the latest
  kChange,     // what one revision range changed (NodeChange): added, hidden or neither
};

// What a range of revisions A..B did to a node (NodeColouring::kChange).
enum class NodeChange {
  kUnchanged,  // at A and at B: grey
  kAdded,      // at B, not at A: coloured
  kHidden,     // at A, not at B: faded
};

struct MapPictureOptions {
  NodeColouring colouring = NodeColouring::kTimeOfDay;
  // kRevision: the revision that added each node; a node not listed counts as revision 0
  // (written outside version control).
  std::unordered_map<Uuid, std::int64_t> node_revision;
  // kChange: what the range did to each node (a node not listed is kUnchanged), the nodes that
  // stand in for nodes the range's merges omitted (marked), how many omitted nodes they stand
  // in for, and the range's name for the legend ("r6" or "r3..r6").
  std::unordered_map<Uuid, NodeChange> node_change;
  std::unordered_set<Uuid> stand_ins;
  std::size_t omitted_nodes = 0;
  std::string change_range;
  std::string title;            // the first line, e.g. "revision 7 of sqlite:fleet.db"
  int max_map_width_px = 1200;  // the components' rows are at most this wide
  int max_map_height_px = 800;  // the scale is reduced until they fit this high (if it can)
};

// What a node's disc stands for (MapPicture::drawn_nodes), for a reader that explains a disc.
struct DrawnNode {
  Uuid id;
  Uuid robot;
  Uuid outing;
  std::int64_t stamp_ns = 0;  // capture time, UTC
};

// A box in picture pixels.
struct PictureBox {
  double left = 0.0, top = 0.0, width = 0.0, height = 0.0;
};

class MapPicture {
 public:
  // Composes the picture of a graph as `layout` places its nodes; `edges` are the graph's
  // (metric ones drawn as lines, path edges faintly). A graph without nodes gives the "empty"
  // picture: the title and a line saying there are no nodes.
  // REQUIRES: layout is GraphLayout::Compute(nodes, edges) of the graph.
  static MapPicture Compose(const GraphLayout& layout, const std::vector<Edge>& edges,
                            const MapPictureOptions& options);

  // Draws the whole picture: Begin, the groups above, End.
  void Draw(Canvas& canvas) const;

  int width_px() const { return width_px_; }
  int height_px() const { return height_px_; }
  bool empty() const { return node_xy_.empty(); }
  // Where node i of the layout (layout.nodes()[i]) is drawn, and its colour.
  const std::vector<CanvasPoint>& node_positions() const { return node_xy_; }
  const std::vector<Rgb>& node_colours() const { return node_colour_; }
  // The node each disc is, in the same order ("nodes" group's order).
  const std::vector<DrawnNode>& drawn_nodes() const { return drawn_; }
  // The box of each component c (its frame; its nodes lie inside).
  const std::vector<PictureBox>& component_boxes() const { return component_box_; }
  double pixels_per_metre() const { return pixels_per_metre_; }
  // The length the scale bar shows, in metres (0 for the empty picture).
  double scale_bar_m() const { return scale_bar_m_; }

  // The radius of a node's disc and the colour behind everything, for readers of the pixels.
  static constexpr double kNodeRadiusPx = 3.5;
  static constexpr Rgb kBackground{255, 255, 255};
  // kChange's node fills, for readers of the pictures (each is unlike every other colour of a
  // kChange picture) and the square around a stand-in.
  static constexpr Rgb kAddedNode{217, 72, 1};
  static constexpr Rgb kUnchangedNode{163, 170, 178};
  static constexpr Rgb kHiddenNode{234, 237, 240};
  static constexpr Rgb kStandInMark{33, 102, 172};
  // The nodes of each NodeChange (kChange; all kUnchanged otherwise), and the stand-ins marked.
  std::size_t nodes_with(NodeChange change) const;
  std::size_t stand_ins_marked() const { return stand_in_nodes_.size(); }

 private:
  struct EdgeLine {
    std::size_t from, to;  // node numbers
  };
  struct LegendStop {
    double at;  // 0..1 along the colour bar
    std::string label;
  };

  void DrawLegend(Canvas& canvas) const;
  void DrawChangeLegend(Canvas& canvas) const;
  void DrawScaleBar(Canvas& canvas) const;

  int width_px_ = 0, height_px_ = 0;
  std::string title_, subtitle_;
  std::vector<CanvasPoint> node_xy_;
  std::vector<Rgb> node_colour_;
  std::vector<DrawnNode> drawn_;
  std::vector<NodeChange> node_change_;
  std::vector<std::size_t> stand_in_nodes_;  // node numbers, ascending
  std::size_t omitted_nodes_ = 0;
  std::string change_range_;
  std::vector<PictureBox> component_box_;
  std::vector<EdgeLine> metric_, path_;
  double pixels_per_metre_ = 0.0;
  double scale_bar_m_ = 0.0;
  double footer_top_ = 0.0;
  NodeColouring colouring_ = NodeColouring::kTimeOfDay;
  std::int64_t first_revision_ = 0, last_revision_ = 0;
};

// The colour of a UTC time of day (hours in [0, 24); taken modulo 24) on the cyclic colour
// map: a hue wheel, midnight blue, 04:00 magenta, 08:00 red, noon yellow, 16:00 green, 20:00
// cyan, and back to blue.
Rgb TimeOfDayColour(double hours);
// The colour of `t` in [0, 1] (clamped) on the sequential map of revisions: dark violet for the
// earliest, through blue and green, to yellow for the latest (viridis' anchors).
Rgb RevisionColour(double t);

}  // namespace fleetmap
