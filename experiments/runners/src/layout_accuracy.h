// How near a map's layout (fleetmap/relaxation/relaxed_layout.h) puts its nodes to where they
// were captured: the largest metric component's nodes with a known true place, their layout
// positions moved onto the true ones by the rigid motion that fits best (Umeyama, no scale:
// stereo measures it), then the root mean square and the largest of the remaining distances.
// The other components are in frames of their own, unrelated to the world's.
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <functional>
#include <optional>

#include "fleetmap/interchange/graph_layout.h"

namespace fleetmap {

struct LayoutAccuracy {
  std::size_t nodes = 0;  // measured: fewer than 3 measure nothing (the other fields 0)
  double rmse_m = 0.0;
  double max_m = 0.0;
};

// `true_place` gives a node's true position in any fixed world frame, or nullopt when unknown.
LayoutAccuracy MeasureLayoutAccuracy(
    const GraphLayout& layout,
    const std::function<std::optional<Eigen::Vector3d>(const LaidOutNode&)>& true_place);

}  // namespace fleetmap
