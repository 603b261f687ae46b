// The experience-graph model (docs/data-model.md; seed 000 §4.3.1 GraphDB).
// Plain value types: what the stores put and get, and what the EBN core works with.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/core/se3.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

// A 256-bit binary feature descriptor (ORB-like), compared by Hamming distance.
using Descriptor256 = std::array<std::uint8_t, 32>;

// The rectified stereo pair a set of landmarks was triangulated from (seed 002 §III-A). With it
// every point can be projected back to the pixels it was measured at, (u_left, v, u_right) =
// f (x, y, x - b) / z + (cx, cy, cx) in the rectified left frame, which is where stereo noise is
// even: a pixel of disparity error is centimetres at 5 m but metres at 40 m. The localiser
// judges and refines residuals there when the landmarks carry it (localiser.h). The principal
// point is not needed: it cancels in every residual.
struct StereoCamera {
  float focal_px = 0;    // rectified focal length, both axes, > 0
  float baseline_m = 0;  // the right camera at (+baseline_m, 0, 0) in the rectified left frame, > 0
  // The rotation from the frame the points are expressed in (the left camera's own) into the
  // rectified left frame, as a unit quaternion w, x, y, z; identity for pre-rectified images.
  std::array<float, 4> rect_q_camera{1, 0, 0, 0};
  // The image pyramid's scale factor between levels, in [1, 4]: a keypoint detected at level
  // l was measured in an image shrunk by level_scale^l, so its pixel noise is that many times
  // larger (Landmarks::levels). 1 when unknown.
  float level_scale = 1;

  friend bool operator==(const StereoCamera&, const StereoCamera&) = default;
};

// The landmarks of one experience: 3-D points in the node's camera frame (metres, float32)
// with one descriptor each. INVARIANT: points_camera.size() == descriptors.size().
// `stereo` is set for landmarks triangulated by a stereo camera; landmarks without it (the
// synthetic world, maps made before it existed) are localised by 3-D residuals.
// `levels` is the pyramid level each point's keypoint was detected at (its pixel noise is
// stereo->level_scale^level pixels of the full image); empty when unknown, which means level 0
// for every point. INVARIANT: levels is empty or levels.size() == size(), each <= kMaxLevel.
struct Landmarks {
  static constexpr std::uint8_t kMaxLevel = 31;

  std::vector<Eigen::Vector3f> points_camera;
  std::vector<Descriptor256> descriptors;
  std::optional<StereoCamera> stereo;
  std::vector<std::uint8_t> levels;

  std::size_t size() const { return points_camera.size(); }
  friend bool operator==(const Landmarks&, const Landmarks&) = default;
};

// An experience: a remembered view of a place. The landmarks travel as one serialised blob
// (fleetmap.v1.Landmarks, see EncodeLandmarks) so stores never parse them.
struct Node {
  Uuid id;
  std::int64_t stamp_ns = 0;  // capture time, UTC
  Uuid robot;
  Uuid outing;
  std::string landmarks_blob;

  friend bool operator==(const Node&, const Node&) = default;
};

enum class EdgeKind : int {
  kMetric = 1,  // 6-DoF relative pose from_T_to
  kPath = 2,    // non-metric path-memory link of one path (seed 002 §IV)
};

// An edge's covariance, when it has one. Held apart from the edge and shared by its copies
// (it never changes once made): most edges carry none, and a 6 x 6 matrix inline would make
// every Edge in a plan, a download or a merge 300 bytes larger. Reads like std::optional.
class EdgeCovariance {
 public:
  EdgeCovariance() = default;
  EdgeCovariance(std::nullopt_t) {}  // NOLINT(google-explicit-constructor): as std::optional
  EdgeCovariance(const PoseCovariance& covariance)  // NOLINT(google-explicit-constructor)
      : value_(std::make_shared<const PoseCovariance>(covariance)) {}
  EdgeCovariance(const std::optional<PoseCovariance>& covariance) {  // NOLINT
    if (covariance) value_ = std::make_shared<const PoseCovariance>(*covariance);
  }

  bool has_value() const { return value_ != nullptr; }
  explicit operator bool() const { return has_value(); }
  const PoseCovariance& operator*() const { return *value_; }
  const PoseCovariance* operator->() const { return value_.get(); }
  PoseCovariance value_or(const PoseCovariance& otherwise) const {
    return value_ ? *value_ : otherwise;
  }
  std::optional<PoseCovariance> optional() const {
    return value_ ? std::optional<PoseCovariance>(*value_) : std::nullopt;
  }
  void reset() { value_.reset(); }

 private:
  std::shared_ptr<const PoseCovariance> value_;
};

struct Edge {
  Uuid id;
  Uuid from;
  Uuid to;
  EdgeKind kind = EdgeKind::kMetric;
  Se3 from_T_to = Se3::Identity();  // meaningful for metric edges
  Uuid path;                        // set for path edges, nil otherwise
  // How far from_T_to can be trusted (se3.h), where whoever made the edge knew: MERGE's links
  // carry their registration's or their composition's. Metric edges only.
  EdgeCovariance covariance = {};
};

// Same identity and endpoints, poses equal within tolerance (a pose that went through a
// database and back is rebuilt from a quaternion, so exact equality is too strict), and both
// covariances absent or equal within a relative 1e-6 (they are stored as floats).
bool SameEdgeContent(const Edge& a, const Edge& b);

// One outing's sequence of localisations (path memory, seed 002 §IV).
struct Path {
  Uuid id;
  Uuid robot;
  Uuid outing;
  std::int64_t start_ns = 0;
  std::int64_t end_ns = 0;

  friend bool operator==(const Path&, const Path&) = default;
};

enum class AnnotationTarget : int {
  kNone = 0,  // the annotation hangs off a parent annotation instead
  kNode = 1,
  kEdge = 2,
  kDatum = 3,  // a datum of the sensor index (seed 000 §4.1 Data relation), by data_id
};

// Seed 000 §4.2 and §4.3.1: an annotation is on exactly one thing, either a graph element
// (target_kind + target), a datum of the sensor index (kDatum + data_id) or a lower-level
// annotation (parent). Annotations on data stay in the repository that indexes the data:
// they are not synced (proto conversion refuses them).
struct Annotation {
  Uuid id;
  AnnotationTarget target_kind = AnnotationTarget::kNone;
  Uuid target;  // node or edge UUID when target_kind is kNode or kEdge, nil otherwise
  Uuid parent;  // parent annotation when target_kind == kNone
  std::string type;
  std::string payload;
  std::int64_t data_id = 0;  // the datum when target_kind == kDatum, 0 otherwise

  friend bool operator==(const Annotation&, const Annotation&) = default;
};

// Everything one atomic write may carry. Stores apply paths, nodes, edges, then annotations,
// so a batch may reference its own members.
struct GraphBatch {
  std::vector<Path> paths;
  std::vector<Node> nodes;
  std::vector<Edge> edges;
  std::vector<Annotation> annotations;
};

// A connected piece of the graph as read back by one query.
struct Subgraph {
  std::vector<Node> nodes;
  std::vector<Edge> edges;
};

// The model-level rules every store enforces before writing: non-nil ids, an edge's path set
// iff it is a path edge, an annotation on exactly one thing (seed 000 §4.2). Throw
// Error(kInvalidArgument) naming the offending UUID.
void Validate(const Node& node);
void Validate(const Edge& edge);
void Validate(const Path& path);
void Validate(const Annotation& annotation);

// Landmark blob codec (fleetmap.v1.Landmarks). Decode throws Error(kCorrupt) on bytes that do
// not parse, whose point and descriptor counts disagree, or whose stereo camera is malformed
// (focal length or baseline not positive and finite, a rotation that is not a unit quaternion).
// Encode throws Error(kInvalidArgument) for the same stereo camera faults.
std::string EncodeLandmarks(const Landmarks& landmarks);
Landmarks DecodeLandmarks(const std::string& blob);

// Where a whole experience graph is read from and where new parts of one are written: the two
// things the EBN core asks of a store (seed 002 §III-B: load the map, then write each outing's
// experiences). They live here, beside the graph model, so the EBN core needs no store library;
// GraphStore (fleetmap/store/graph_store.h) is the implementation every program uses.
class GraphReader {
 public:
  virtual ~GraphReader();
  // Every node (with landmarks), every edge touching them and every path.
  virtual GraphBatch ReadMap() = 0;
};

class GraphWriter {
 public:
  virtual ~GraphWriter();
  // Writes the batch all together or not at all.
  virtual void Put(const GraphBatch& batch) = 0;
};

}  // namespace fleetmap
