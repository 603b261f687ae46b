#include "scale_workload.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "fleetmap/core/error.h"

namespace fleetmap::bench {
namespace {

constexpr std::int64_t kSecondNs = 1'000'000'000;
constexpr std::int64_t kDayNs = 86'400 * kSecondNs;
// 2026-01-01T00:00:00Z: the first day of every generated map.
constexpr std::int64_t kFirstDayNs = 1'767'225'600 * kSecondNs;
constexpr std::int64_t kNodeSpacingNs = kSecondNs / 2;

// The time of day outing k starts at: k times the golden ratio, modulo a day, fills the day
// evenly for any number of outings.
std::int64_t OutingStartNs(std::size_t outing, int day) {
  const double golden = 0.6180339887498949;
  const double fraction = std::fmod(static_cast<double>(outing) * golden, 1.0);
  return kFirstDayNs + (static_cast<std::int64_t>(outing) / 4) * kDayNs + day * kDayNs +
         static_cast<std::int64_t>(fraction * static_cast<double>(kDayNs - 1000 * kSecondNs));
}

std::string LandmarksOf(const ScaleMapSpec& spec, std::size_t outing, std::size_t node) {
  std::seed_seq seed{spec.seed, static_cast<std::uint32_t>(outing),
                     static_cast<std::uint32_t>(node)};
  std::mt19937 random(seed);
  std::uniform_real_distribution<float> coordinate(-4.0f, 4.0f);
  Landmarks view;
  view.points_camera.reserve(static_cast<std::size_t>(spec.landmarks_per_node));
  view.descriptors.reserve(static_cast<std::size_t>(spec.landmarks_per_node));
  for (int l = 0; l < spec.landmarks_per_node; ++l) {
    view.points_camera.emplace_back(coordinate(random), coordinate(random),
                                    3.0f + std::abs(coordinate(random)));
    Descriptor256 descriptor;
    for (std::size_t b = 0; b < descriptor.size(); b += 4) {
      const std::uint32_t word = random();
      for (std::size_t k = 0; k < 4; ++k)
        descriptor[b + k] = static_cast<std::uint8_t>(word >> (8 * k));
    }
    view.descriptors.push_back(descriptor);
  }
  return EncodeLandmarks(view);
}

// Nodes (with the landmarks of `outing`'s first `count` places), chained, as one outing.
GraphBatch Chain(const ScaleMapSpec& spec, std::size_t outing, std::size_t count, const Uuid& robot,
                 int day) {
  const Uuid outing_id = Uuid::Generate();
  const std::int64_t t0 = OutingStartNs(outing, day);
  GraphBatch map;
  map.paths.push_back(Path{Uuid::Generate(), robot, outing_id, t0,
                           t0 + static_cast<std::int64_t>(count) * kNodeSpacingNs});
  map.nodes.reserve(count);
  for (std::size_t i = 0; i < count; ++i) {
    map.nodes.push_back(Node{Uuid::Generate(), t0 + static_cast<std::int64_t>(i) * kNodeSpacingNs,
                             robot, outing_id, LandmarksOf(spec, outing, i)});
  }
  Se3 step = Se3::Identity();
  step.translation() = Eigen::Vector3d(0.0, 0.0, 1.0);
  for (std::size_t i = 0; i + 1 < count; ++i) {
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kMetric, step, Uuid()});
    map.edges.push_back(Edge{Uuid::Generate(), map.nodes[i].id, map.nodes[i + 1].id,
                             EdgeKind::kPath, Se3::Identity(), map.paths[0].id});
  }
  return map;
}

}  // namespace

std::size_t ScaleMapSpec::OutingSize(std::size_t outing) const {
  return std::min(kOutingNodes, nodes - outing * kOutingNodes);
}

GraphBatch ScaleOuting(const ScaleMapSpec& spec, std::size_t outing, const Uuid& robot, int day) {
  return Chain(spec, outing, spec.OutingSize(outing), robot, day);
}

void WriteScaleMap(Repository& repository, const ScaleMapSpec& spec,
                   const std::function<void(std::size_t, std::size_t)>& progress) {
  if (repository.Head() != 0) {
    throw Error(ErrorCode::kConflict, "bench scale writes its map into an empty repository; " +
                                          repository.uri() + " has revisions");
  }
  // A handful of robots, as a fleet would have.
  std::vector<Uuid> robots;
  for (int r = 0; r < 8; ++r) robots.push_back(Uuid::Generate());
  for (std::size_t outing = 0; outing < spec.outings(); ++outing) {
    const GraphBatch map = ScaleOuting(spec, outing, robots[outing % robots.size()]);
    Revision revision;
    revision.number = static_cast<RevisionNumber>(outing + 1);
    revision.created_ns = OutingStartNs(outing, 0);
    revision.author = "fleetmap bench scale";
    revision.kind = RevisionKind::kMerge;
    revision.report = "generated outing " + std::to_string(outing);
    repository.AppendUnmergedRevision(revision, map);
    // As fleetmapd keeps it after each merge: the next merge indexes only what is new.
    repository.UpdateAppearanceIndex();
    if (progress) progress(outing + 1, spec.outings());
  }
}

GraphBatch RevisitSubmission(const ScaleMapSpec& spec, std::size_t nodes, const Uuid& robot) {
  const std::size_t middle = spec.outings() / 2;
  return Chain(spec, middle, std::min(nodes, spec.OutingSize(middle)), robot, 1);
}

double RevisitTimeOfDayMin(const ScaleMapSpec& spec) {
  const std::int64_t of_day = OutingStartNs(spec.outings() / 2, 0) % kDayNs;
  return static_cast<double>(of_day) / (60.0 * kSecondNs);
}

}  // namespace fleetmap::bench
