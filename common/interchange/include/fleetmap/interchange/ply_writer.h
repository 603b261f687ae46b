// A map's landmarks as a PLY point cloud in the frames of graph_layout.h, for point-cloud tools
// (CloudCompare, MeshLab, Open3D, PCL).
//
// The file: the header lines
//   ply / format binary_little_endian 1.0 / comment TEXT (when a description is given) /
//   element vertex N / property float x / property float y / property float z /
//   property int component / end_header
// each ended by "\n", then N records of 16 bytes: x, y, z as IEEE-754 float32 and component as
// int32, little-endian whatever the host. Binary because a map holds millions of points: 16
// bytes each instead of about 40 as text, and no rounding through decimal.
//
// A vertex is one landmark, p_layout = layout_T_node * p_camera (metres) in its node's
// component frame, with that component's number. Vertices come node by node in layout order
// (GraphLayout::nodes()), each node's landmarks in their stored order.
#pragma once

#include <cstddef>
#include <ostream>
#include <string_view>

#include "fleetmap/core/graph.h"
#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

// Writes the point cloud of `map` to `out` and returns the number of vertices. `description`,
// when not empty, becomes one `comment` line (line breaks become spaces).
// REQUIRES: `layout` is GraphLayout::Compute(map.nodes, map.edges); a node missing from it
// throws Error(kInvalidArgument). Landmarks that do not decode throw Error(kCorrupt) naming the
// node, before anything is written. Stream failures are the caller's to check.
std::size_t WritePlyPointCloud(const GraphBatch& map, const GraphLayout& layout,
                               std::string_view description, std::ostream& out);

}  // namespace fleetmap
