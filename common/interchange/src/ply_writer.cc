#include "fleetmap/interchange/ply_writer.h"

#include <bit>
#include <cstdint>
#include <string>
#include <vector>

#include "export_inputs.h"
#include "export_text.h"

namespace fleetmap {
namespace {

using interchange_internal::LandmarksOf;

// PLY's binary_little_endian fixes the byte order, not the host: write the bytes one by one.
void AppendLittleEndian(std::string& out, std::uint32_t bits) {
  for (int byte = 0; byte < 4; ++byte) {
    out.push_back(static_cast<char>((bits >> (8 * byte)) & 0xFF));
  }
}

}  // namespace

std::size_t WritePlyPointCloud(const GraphBatch& map, const GraphLayout& layout,
                               std::string_view description, std::ostream& out) {
  const std::vector<const Node*> nodes = interchange_internal::NodesInLayoutOrder(map, layout);
  // The header states the vertex count, so the body is made first; decoding each node's
  // landmarks once and keeping 16 bytes a point is cheaper than decoding them twice.
  constexpr std::size_t kVertexBytes = 16;
  std::string body;
  std::size_t vertices = 0;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    const Landmarks landmarks = LandmarksOf(*nodes[i]);
    const LaidOutNode& placed = layout.nodes()[i];
    body.reserve(body.size() + landmarks.size() * kVertexBytes);
    for (const Eigen::Vector3f& p_camera : landmarks.points_camera) {
      const Eigen::Vector3d p_layout = placed.layout_T_node * p_camera.cast<double>();
      for (int axis = 0; axis < 3; ++axis) {
        AppendLittleEndian(body, std::bit_cast<std::uint32_t>(static_cast<float>(p_layout[axis])));
      }
      AppendLittleEndian(body, std::bit_cast<std::uint32_t>(std::int32_t{placed.component}));
    }
    vertices += landmarks.size();
  }

  std::string header = "ply\nformat binary_little_endian 1.0\n";
  if (!description.empty()) {
    header += "comment " + interchange_internal::OneLine(description) + "\n";
  }
  header += "element vertex " + std::to_string(vertices) +
            "\nproperty float x\nproperty float y\nproperty float z\nproperty int component\n"
            "end_header\n";
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  out.write(body.data(), static_cast<std::streamsize>(body.size()));
  return vertices;
}

}  // namespace fleetmap
