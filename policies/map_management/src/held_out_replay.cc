#include "fleetmap/map_management/held_out_replay.h"

#include <algorithm>
#include <map>
#include <optional>
#include <unordered_map>
#include <utility>

#include "fleetmap/core/error.h"
#include "fleetmap/ranking/distance_ranking.h"

namespace fleetmap {
namespace {

// The pose of `to` in `from`'s camera frame from the metric edge joining the two, either way.
class MetricEdgeIndex {
 public:
  explicit MetricEdgeIndex(const std::vector<Edge>& edges) {
    for (const Edge& edge : edges) {
      if (edge.kind != EdgeKind::kMetric) continue;
      auto [it, inserted] = by_pair_.emplace(Key(edge.from, edge.to), &edge);
      if (!inserted && edge.id < it->second->id) it->second = &edge;  // deterministic choice
    }
  }

  std::optional<Se3> FromTTo(const Uuid& from, const Uuid& to) const {
    const auto it = by_pair_.find(Key(from, to));
    if (it == by_pair_.end()) return std::nullopt;
    const Edge& edge = *it->second;
    return edge.from == from ? edge.from_T_to : edge.from_T_to.inverse();
  }

 private:
  static std::pair<Uuid, Uuid> Key(const Uuid& a, const Uuid& b) {
    return a < b ? std::pair(a, b) : std::pair(b, a);
  }
  std::map<std::pair<Uuid, Uuid>, const Edge*> by_pair_;
};

}  // namespace

std::vector<HeldOutOuting> HeldOutOutings(const GraphBatch& map) {
  std::unordered_map<Uuid, std::vector<const Node*>> by_outing;
  for (const Node& node : map.nodes) by_outing[node.outing].push_back(&node);
  const MetricEdgeIndex edges(map.edges);

  std::vector<HeldOutOuting> outings;
  outings.reserve(by_outing.size());
  for (auto& [outing, nodes] : by_outing) {
    std::sort(nodes.begin(), nodes.end(), [](const Node* a, const Node* b) {
      return std::pair(a->stamp_ns, a->id) < std::pair(b->stamp_ns, b->id);
    });
    HeldOutOuting held_out;
    held_out.robot = nodes.front()->robot;
    held_out.outing = outing;
    held_out.frames.reserve(nodes.size());
    for (std::size_t i = 0; i < nodes.size(); ++i) {
      Frame frame;
      frame.stamp_ns = nodes[i]->stamp_ns;
      try {
        frame.landmarks = DecodeLandmarks(nodes[i]->landmarks_blob);
      } catch (const Error& error) {
        throw Error(ErrorCode::kCorrupt, "held-out node " + nodes[i]->id.ToString() +
                                             ": landmarks do not decode: " + error.message());
      }
      if (i > 0) {
        frame.prev_T_this = edges.FromTTo(nodes[i - 1]->id, nodes[i]->id).value_or(Se3::Identity());
      }
      held_out.frames.push_back(std::move(frame));
    }
    outings.push_back(std::move(held_out));
  }
  std::sort(outings.begin(), outings.end(), [](const HeldOutOuting& a, const HeldOutOuting& b) {
    return std::pair(a.frames.front().stamp_ns, a.outing) <
           std::pair(b.frames.front().stamp_ns, b.outing);
  });
  return outings;
}

double HeldOutReplay::ProbabilityGapExceeds(double x_m) const {
  if (gaps_m.empty()) return 0.0;
  const auto beyond =
      std::count_if(gaps_m.begin(), gaps_m.end(), [&](double g) { return g > x_m; });
  return static_cast<double>(beyond) / static_cast<double>(gaps_m.size());
}

double HeldOutReplay::FractionNotLocalised() const {
  if (frames == 0) return 0.0;
  return static_cast<double>(frames - localised_frames) / static_cast<double>(frames);
}

HeldOutReplay ReplayHeldOut(const ExperienceMap& map, std::span<const HeldOutOuting> outings,
                            const BuilderOptions& options) {
  BuilderOptions localise_only = options;
  localise_only.localise_only = true;
  DistanceRanking ranking;
  // A localise-only builder never changes the map (experience_builder.h); its constructor takes
  // the map mutable only because a mapping builder writes to it.
  ExperienceBuilder localiser(nullptr, const_cast<ExperienceMap&>(map), ranking, localise_only);
  HeldOutReplay replay;
  for (const HeldOutOuting& outing : outings) {
    if (outing.frames.empty()) continue;
    OutingStart start;  // no start node: the outing starts lost
    start.robot = outing.robot;
    start.outing = outing.outing;
    localiser.StartOuting(start);
    for (const Frame& frame : outing.frames) {
      const FrameReport report = localiser.Process(frame);
      ++replay.frames;
      if (report.successes > 0) ++replay.localised_frames;
      replay.gaps_m.push_back(report.distance_since_success_m);
    }
    localiser.FinishOuting();
    ++replay.outings;
  }
  return replay;
}

double HeldOutScore(const HeldOutReplay& replay, double gap_m) {
  if (!(gap_m >= 0.0)) {
    throw Error(ErrorCode::kInvalidArgument, "held-out score: the gap must be >= 0 metres");
  }
  return replay.ProbabilityGapExceeds(gap_m) +
         replay.FractionNotLocalised() / static_cast<double>(replay.frames + 1);
}

}  // namespace fleetmap
