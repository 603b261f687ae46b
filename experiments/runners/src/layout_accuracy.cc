#include "layout_accuracy.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <vector>

namespace fleetmap {

LayoutAccuracy MeasureLayoutAccuracy(
    const GraphLayout& layout,
    const std::function<std::optional<Eigen::Vector3d>(const LaidOutNode&)>& true_place) {
  LayoutAccuracy accuracy;
  std::vector<std::size_t> sizes(layout.component_count(), 0);
  for (const LaidOutNode& node : layout.nodes()) ++sizes[static_cast<std::size_t>(node.component)];
  if (sizes.empty()) return accuracy;
  const int largest =
      static_cast<int>(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  std::vector<Eigen::Vector3d> laid_out, truth;
  for (const LaidOutNode& node : layout.nodes()) {
    if (node.component != largest) continue;
    const std::optional<Eigen::Vector3d> place = true_place(node);
    if (!place) continue;
    laid_out.push_back(node.layout_T_node.translation());
    truth.push_back(*place);
  }
  if (laid_out.size() < 3) return accuracy;
  Eigen::Matrix3Xd from(3, static_cast<Eigen::Index>(laid_out.size()));
  Eigen::Matrix3Xd to(3, from.cols());
  for (Eigen::Index i = 0; i < from.cols(); ++i) {
    from.col(i) = laid_out[static_cast<std::size_t>(i)];
    to.col(i) = truth[static_cast<std::size_t>(i)];
  }
  const Eigen::Matrix4d truth_T_layout = Eigen::umeyama(from, to, /*with_scaling=*/false);
  double squares = 0.0;
  for (Eigen::Index i = 0; i < from.cols(); ++i) {
    const Eigen::Vector3d aligned =
        truth_T_layout.topLeftCorner<3, 3>() * from.col(i) + truth_T_layout.topRightCorner<3, 1>();
    const double e = (aligned - to.col(i)).norm();
    squares += e * e;
    accuracy.max_m = std::max(accuracy.max_m, e);
  }
  accuracy.nodes = static_cast<std::size_t>(from.cols());
  accuracy.rmse_m = std::sqrt(squares / static_cast<double>(from.cols()));
  return accuracy;
}

}  // namespace fleetmap
