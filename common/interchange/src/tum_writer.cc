#include "fleetmap/interchange/tum_writer.h"

#include <algorithm>
#include <cstdio>
#include <map>
#include <set>
#include <string>
#include <tuple>

#include "export_inputs.h"
#include "export_text.h"
#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

// Seconds with all nine digits of the nanoseconds, from the integer: a double holds a
// present-day stamp in seconds only to about 0.2 microseconds.
std::string SecondsText(std::int64_t stamp_ns) {
  // Unsigned, so that the magnitude of the most negative stamp does not overflow.
  const std::uint64_t magnitude = stamp_ns < 0 ? 0 - static_cast<std::uint64_t>(stamp_ns)
                                               : static_cast<std::uint64_t>(stamp_ns);
  char text[40];
  std::snprintf(text, sizeof text, "%s%llu.%09llu", stamp_ns < 0 ? "-" : "",
                static_cast<unsigned long long>(magnitude / 1'000'000'000ULL),
                static_cast<unsigned long long>(magnitude % 1'000'000'000ULL));
  return text;
}

}  // namespace

std::vector<OutingSummary> OutingsOf(const std::vector<Node>& nodes) {
  std::map<Uuid, OutingSummary> by_outing;
  for (const Node& node : nodes) {
    auto [entry, added] = by_outing.try_emplace(node.outing);
    OutingSummary& summary = entry->second;
    if (added || node.stamp_ns < summary.first_ns) {
      summary.robot = node.robot;
      summary.first_ns = node.stamp_ns;
    }
    if (added || node.stamp_ns > summary.last_ns) summary.last_ns = node.stamp_ns;
    summary.outing = node.outing;
    ++summary.nodes;
  }
  std::vector<OutingSummary> outings;
  for (const auto& [outing, summary] : by_outing) outings.push_back(summary);
  std::sort(outings.begin(), outings.end(), [](const OutingSummary& a, const OutingSummary& b) {
    return std::tie(a.first_ns, a.outing) < std::tie(b.first_ns, b.outing);
  });
  return outings;
}

TumCounts WriteTumTrajectory(const GraphBatch& map, const GraphLayout& layout, const Uuid& outing,
                             std::string_view description, std::ostream& out) {
  const std::vector<const Node*> nodes = interchange_internal::NodesInLayoutOrder(map, layout);
  std::vector<std::size_t> poses;  // layout indices, hence in (stamp_ns, UUID) order
  std::set<int> components;
  for (std::size_t i = 0; i < nodes.size(); ++i) {
    if (nodes[i]->outing != outing) continue;
    poses.push_back(i);
    components.insert(layout.nodes()[i].component);
  }
  if (poses.empty()) {
    throw Error(ErrorCode::kNotFound, "no node of the map is on outing " + outing.ToString());
  }

  std::string text;
  if (!description.empty()) text += "# " + interchange_internal::OneLine(description) + "\n";
  text += "# outing " + outing.ToString() + " of robot " + nodes[poses.front()]->robot.ToString() +
          ": " + std::to_string(poses.size()) + " poses\n";
  if (components.size() > 1) {
    text += "# its poses lie in " + std::to_string(components.size()) +
            " unconnected components of the map, each in its own frame: poses of different "
            "components cannot be compared\n";
  }
  text += "# timestamp tx ty tz qx qy qz qw\n";
  out << text;
  for (const std::size_t i : poses) {
    const Se3& layout_T_node = layout.nodes()[i].layout_T_node;
    const Eigen::Vector3d& t = layout_T_node.translation();
    const Eigen::Quaterniond q = RotationQuaternion(layout_T_node);
    text = SecondsText(layout.nodes()[i].stamp_ns);
    for (const double value : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) {
      text += ' ';
      interchange_internal::AppendNumber(text, value);
    }
    out << text << '\n';
  }
  return TumCounts{poses.size(), components.size()};
}

}  // namespace fleetmap
