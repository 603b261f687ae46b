#include "fleetmap/core/graph.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "fleetmap/core/error.h"
#include "fleetmap/map.pb.h"

namespace fleetmap {

bool SameEdgeContent(const Edge& a, const Edge& b) {
  // 1e-9 m / rad: far below any physical meaning, far above the rounding of a pose rebuilt
  // from its stored quaternion.
  if (a.covariance.has_value() != b.covariance.has_value()) return false;
  if (a.covariance && (*a.covariance - *b.covariance).cwiseAbs().maxCoeff() >
                          1e-6 * std::max(1e-30, a.covariance->cwiseAbs().maxCoeff())) {
    return false;
  }
  return a.id == b.id && a.from == b.from && a.to == b.to && a.kind == b.kind && a.path == b.path &&
         Se3ApproxEqual(a.from_T_to, b.from_T_to, 1e-9, 1e-9);
}

namespace {

void RequireId(const Uuid& id, const char* what, const Uuid& owner) {
  if (id.IsNil()) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string(what) + " must be set (element " + owner.ToString() + ")");
  }
}

}  // namespace

void Validate(const Node& node) {
  RequireId(node.id, "node id", node.id);
}

void Validate(const Edge& edge) {
  RequireId(edge.id, "edge id", edge.id);
  RequireId(edge.from, "edge from-node", edge.id);
  RequireId(edge.to, "edge to-node", edge.id);
  switch (edge.kind) {
    case EdgeKind::kMetric:
      if (!edge.path.IsNil()) {
        throw Error(ErrorCode::kInvalidArgument,
                    "metric edge " + edge.id.ToString() + " must not name a path");
      }
      break;
    case EdgeKind::kPath:
      RequireId(edge.path, "path edge's path", edge.id);
      break;
    default:
      throw Error(ErrorCode::kInvalidArgument, "edge " + edge.id.ToString() + " has unknown kind " +
                                                   std::to_string(static_cast<int>(edge.kind)));
  }
  if (!edge.from_T_to.matrix().allFinite()) {
    throw Error(ErrorCode::kInvalidArgument, "edge " + edge.id.ToString() + " pose is not finite");
  }
  if (edge.covariance) {
    if (edge.kind != EdgeKind::kMetric) {
      throw Error(ErrorCode::kInvalidArgument,
                  "path edge " + edge.id.ToString() + " must not carry a pose covariance");
    }
    if (!IsValidPoseCovariance(*edge.covariance)) {
      throw Error(ErrorCode::kInvalidArgument,
                  "edge " + edge.id.ToString() +
                      " has a pose covariance that is not finite, symmetric and positive "
                      "semi-definite");
    }
  }
}

void Validate(const Path& path) {
  RequireId(path.id, "path id", path.id);
}

void Validate(const Annotation& annotation) {
  RequireId(annotation.id, "annotation id", annotation.id);
  const AnnotationTarget kind = annotation.target_kind;
  if (kind != AnnotationTarget::kNone && kind != AnnotationTarget::kNode &&
      kind != AnnotationTarget::kEdge && kind != AnnotationTarget::kDatum) {
    throw Error(ErrorCode::kInvalidArgument,
                "annotation " + annotation.id.ToString() + " has an unknown target kind");
  }
  const bool on_element = kind == AnnotationTarget::kNode || kind == AnnotationTarget::kEdge;
  const bool on_datum = kind == AnnotationTarget::kDatum;
  const bool on_parent = kind == AnnotationTarget::kNone;
  // Seed 000 §4.2: exactly one of "what it annotates" and "its parent annotation"; the
  // fields of the other targets stay empty.
  if (on_parent == annotation.parent.IsNil() || on_element == annotation.target.IsNil() ||
      on_datum != (annotation.data_id != 0)) {
    throw Error(ErrorCode::kInvalidArgument,
                "annotation " + annotation.id.ToString() +
                    " must be on exactly one of a node, an edge, a datum or a parent annotation");
  }
  if (on_datum && annotation.data_id < 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "annotation " + annotation.id.ToString() + " names datum " +
                    std::to_string(annotation.data_id) + ": data ids are positive");
  }
  if (annotation.type.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "annotation " + annotation.id.ToString() + " needs a type name");
  }
}

namespace {

// What is wrong with a stereo camera description, or empty when nothing is.
std::string StereoCameraFault(float focal_px, float baseline_m, const float* q, int q_size,
                              float level_scale) {
  if (!(std::isfinite(focal_px) && focal_px > 0)) return "focal length must be positive";
  if (!(std::isfinite(baseline_m) && baseline_m > 0)) return "baseline must be positive";
  if (!(level_scale >= 1 && level_scale <= 4)) return "pyramid scale must be in [1, 4]";
  if (q_size != 4) return "rotation needs 4 quaternion terms, has " + std::to_string(q_size);
  double norm_sq = 0;
  for (int k = 0; k < 4; ++k) {
    if (!std::isfinite(q[k])) return "rotation is not finite";
    norm_sq += static_cast<double>(q[k]) * q[k];
  }
  if (std::abs(norm_sq - 1.0) > 1e-3) return "rotation is not a unit quaternion";
  return {};
}

// What is wrong with the landmarks' pyramid levels, or empty when nothing is.
std::string LevelsFault(std::size_t levels, std::size_t points, std::uint8_t highest) {
  if (levels != 0 && levels != points) {
    return std::to_string(levels) + " pyramid levels for " + std::to_string(points) + " points";
  }
  if (highest > Landmarks::kMaxLevel) {
    return "pyramid level " + std::to_string(highest) + " above " +
           std::to_string(Landmarks::kMaxLevel);
  }
  return {};
}

std::uint8_t Highest(const std::uint8_t* levels, std::size_t n) {
  std::uint8_t highest = 0;
  for (std::size_t i = 0; i < n; ++i) highest = std::max(highest, levels[i]);
  return highest;
}

}  // namespace

std::string EncodeLandmarks(const Landmarks& landmarks) {
  if (landmarks.points_camera.size() != landmarks.descriptors.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "landmarks: " + std::to_string(landmarks.points_camera.size()) + " points but " +
                    std::to_string(landmarks.descriptors.size()) + " descriptors");
  }
  v1::Landmarks proto;
  proto.mutable_xyz()->Reserve(static_cast<int>(3 * landmarks.size()));
  for (const Eigen::Vector3f& p : landmarks.points_camera) {
    proto.add_xyz(p.x());
    proto.add_xyz(p.y());
    proto.add_xyz(p.z());
  }
  std::string* descriptors = proto.mutable_descriptors();
  descriptors->resize(landmarks.size() * sizeof(Descriptor256));
  for (std::size_t i = 0; i < landmarks.size(); ++i) {
    std::memcpy(descriptors->data() + i * sizeof(Descriptor256), landmarks.descriptors[i].data(),
                sizeof(Descriptor256));
  }
  if (landmarks.stereo) {
    const StereoCamera& camera = *landmarks.stereo;
    const std::string fault = StereoCameraFault(camera.focal_px, camera.baseline_m,
                                                camera.rect_q_camera.data(), 4, camera.level_scale);
    if (!fault.empty())
      throw Error(ErrorCode::kInvalidArgument, "landmarks' stereo camera: " + fault);
    v1::StereoCamera* stereo = proto.mutable_stereo();
    stereo->set_focal_px(camera.focal_px);
    stereo->set_baseline_m(camera.baseline_m);
    for (float q : camera.rect_q_camera) stereo->add_rect_q_camera(q);
    // 1 is "unknown" and stays absent, so blobs without levels are byte for byte as before.
    if (camera.level_scale != 1) stereo->set_level_scale(camera.level_scale);
  }
  const std::string levels_fault =
      LevelsFault(landmarks.levels.size(), landmarks.size(),
                  Highest(landmarks.levels.data(), landmarks.levels.size()));
  if (!levels_fault.empty()) throw Error(ErrorCode::kInvalidArgument, "landmarks: " + levels_fault);
  if (!landmarks.levels.empty()) {
    proto.set_levels(landmarks.levels.data(), landmarks.levels.size());
  }
  return proto.SerializeAsString();
}

Landmarks DecodeLandmarks(const std::string& blob) {
  v1::Landmarks proto;
  if (!proto.ParseFromString(blob)) {
    throw Error(ErrorCode::kCorrupt, "landmark blob does not parse as fleetmap.v1.Landmarks");
  }
  if (proto.xyz_size() % 3 != 0 ||
      proto.descriptors().size() != (proto.xyz_size() / 3) * sizeof(Descriptor256)) {
    throw Error(ErrorCode::kCorrupt, "landmark blob: " + std::to_string(proto.xyz_size()) +
                                         " coordinates do not match " +
                                         std::to_string(proto.descriptors().size()) +
                                         " descriptor bytes");
  }
  Landmarks landmarks;
  const std::size_t n = static_cast<std::size_t>(proto.xyz_size() / 3);
  landmarks.points_camera.reserve(n);
  landmarks.descriptors.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const int k = static_cast<int>(3 * i);
    landmarks.points_camera.emplace_back(proto.xyz(k), proto.xyz(k + 1), proto.xyz(k + 2));
    std::memcpy(landmarks.descriptors[i].data(),
                proto.descriptors().data() + i * sizeof(Descriptor256), sizeof(Descriptor256));
  }
  if (proto.has_stereo()) {
    const v1::StereoCamera& stereo = proto.stereo();
    // Absent (0) in blobs written before levels existed: unknown, 1.
    const float level_scale = stereo.level_scale() == 0 ? 1.0f : stereo.level_scale();
    const std::string fault =
        StereoCameraFault(stereo.focal_px(), stereo.baseline_m(), stereo.rect_q_camera().data(),
                          stereo.rect_q_camera_size(), level_scale);
    if (!fault.empty()) throw Error(ErrorCode::kCorrupt, "landmark blob's stereo camera: " + fault);
    StereoCamera camera;
    camera.focal_px = stereo.focal_px();
    camera.baseline_m = stereo.baseline_m();
    camera.level_scale = level_scale;
    for (int k = 0; k < 4; ++k)
      camera.rect_q_camera[static_cast<std::size_t>(k)] = stereo.rect_q_camera(k);
    landmarks.stereo = camera;
  }
  const auto* levels = reinterpret_cast<const std::uint8_t*>(proto.levels().data());
  const std::string levels_fault =
      LevelsFault(proto.levels().size(), n, Highest(levels, proto.levels().size()));
  if (!levels_fault.empty()) throw Error(ErrorCode::kCorrupt, "landmark blob: " + levels_fault);
  landmarks.levels.assign(levels, levels + proto.levels().size());
  return landmarks;
}

// Out of line, so each interface's vtable has one home.
GraphReader::~GraphReader() = default;
GraphWriter::~GraphWriter() = default;

}  // namespace fleetmap
