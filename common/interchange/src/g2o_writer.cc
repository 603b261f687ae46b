#include "fleetmap/interchange/g2o_writer.h"

#include <algorithm>
#include <string>
#include <vector>

#include "export_inputs.h"
#include "export_text.h"

namespace fleetmap {
namespace {

using interchange_internal::AppendNumber;

// " x y z qx qy qz qw": g2o puts the quaternion's w last.
void AppendPose(std::string& line, const Se3& a_T_b) {
  const Eigen::Vector3d& t = a_T_b.translation();
  const Eigen::Quaterniond q = RotationQuaternion(a_T_b);
  for (const double value : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
    line += ' ';
    AppendNumber(line, value);
  }
}

}  // namespace

G2oCounts WriteG2oPoseGraph(const GraphBatch& map, const GraphLayout& layout, std::ostream& out,
                            const std::string& comment) {
  interchange_internal::NodesInLayoutOrder(map, layout);  // only to check they agree
  const std::vector<interchange_internal::OrderedEdge> edges =
      interchange_internal::EdgesInLayoutOrder(map, layout, /*metric_only=*/true);
  // The upper triangle of the 6x6 information matrix, row by row: the same for every edge.
  std::string information;
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) {
      information += ' ';
      AppendNumber(information, row == column ? kG2oEdgeInformation : 0.0);
    }
  }

  G2oCounts counts;
  std::string line;
  if (!comment.empty()) {
    line = "# " + comment;
    std::replace(line.begin(), line.end(), '\n', ' ');
    std::replace(line.begin(), line.end(), '\r', ' ');
    out << line << '\n';
  }
  for (std::size_t i = 0; i < layout.nodes().size(); ++i) {
    line = "VERTEX_SE3:QUAT " + std::to_string(i);
    AppendPose(line, layout.nodes()[i].layout_T_node);
    out << line << '\n';
    ++counts.vertices;
  }
  for (const std::size_t reference : layout.references()) {
    out << "FIX " << reference << '\n';
    ++counts.fixed;
  }
  for (const interchange_internal::OrderedEdge& edge : edges) {
    line = "EDGE_SE3:QUAT " + std::to_string(edge.from) + " " + std::to_string(edge.to);
    AppendPose(line, edge.edge->from_T_to);
    out << line << information << '\n';
    ++counts.edges;
  }
  return counts;
}

}  // namespace fleetmap
