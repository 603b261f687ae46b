#include "fleetmap/core/proto_convert.h"

#include <utility>

#include "fleetmap/core/error.h"

namespace fleetmap {

namespace {

// A UUID field of a message: empty means nil; anything but 16 bytes is corrupt.
Uuid UuidField(const std::string& raw, const char* field) {
  if (raw.empty()) return Uuid();
  if (raw.size() != Uuid::kSize) {
    throw Error(ErrorCode::kCorrupt, std::string("field '") + field + "' holds " +
                                         std::to_string(raw.size()) + " bytes, a UUID needs 16");
  }
  return Uuid::FromBytes(raw);
}

std::string UuidBytes(const Uuid& id) {
  return id.IsNil() ? std::string() : id.ToBytesString();
}

// The upper triangle of a 6 x 6 matrix, row by row (map.proto PoseCovariance).
constexpr int kCovarianceUpperSize = 21;

v1::PoseCovariance CovarianceToProto(const PoseCovariance& covariance) {
  v1::PoseCovariance proto;
  proto.mutable_upper()->Reserve(kCovarianceUpperSize);
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) proto.add_upper(covariance(row, column));
  }
  return proto;
}

PoseCovariance CovarianceFromProto(const v1::PoseCovariance& proto, const std::string& edge) {
  if (proto.upper_size() != kCovarianceUpperSize) {
    throw Error(ErrorCode::kCorrupt, "Edge " + edge + " covariance holds " +
                                         std::to_string(proto.upper_size()) +
                                         " values, the upper triangle of a 6 x 6 matrix is 21");
  }
  PoseCovariance covariance;
  int i = 0;
  for (int row = 0; row < 6; ++row) {
    for (int column = row; column < 6; ++column) {
      covariance(row, column) = covariance(column, row) = proto.upper(i++);
    }
  }
  if (!IsValidPoseCovariance(covariance)) {
    throw Error(ErrorCode::kCorrupt,
                "Edge " + edge + " covariance is not a finite, positive semi-definite matrix");
  }
  return covariance;
}

}  // namespace

v1::Se3 ToProto(const Se3& a_T_b) {
  v1::Se3 proto;
  const Eigen::Quaterniond q = RotationQuaternion(a_T_b);
  proto.set_tx(a_T_b.translation().x());
  proto.set_ty(a_T_b.translation().y());
  proto.set_tz(a_T_b.translation().z());
  proto.set_qw(q.w());
  proto.set_qx(q.x());
  proto.set_qy(q.y());
  proto.set_qz(q.z());
  return proto;
}

Se3 FromProto(const v1::Se3& proto) {
  try {
    return Se3FromTranslationQuaternion(
        Eigen::Vector3d(proto.tx(), proto.ty(), proto.tz()),
        Eigen::Quaterniond(proto.qw(), proto.qx(), proto.qy(), proto.qz()));
  } catch (const Error& e) {
    throw Error(ErrorCode::kCorrupt, "Se3 message: " + e.message());
  }
}

namespace {

// A node's message or model but for its landmarks, which the callers copy or move.
v1::Node NodeHeaderToProto(const Node& node) {
  v1::Node proto;
  proto.set_uuid(UuidBytes(node.id));
  proto.set_stamp_ns(node.stamp_ns);
  proto.set_robot(UuidBytes(node.robot));
  proto.set_outing(UuidBytes(node.outing));
  return proto;
}
Node NodeHeaderFromProto(const v1::Node& proto) {
  Node node;
  node.id = UuidField(proto.uuid(), "Node.uuid");
  node.stamp_ns = proto.stamp_ns();
  node.robot = UuidField(proto.robot(), "Node.robot");
  node.outing = UuidField(proto.outing(), "Node.outing");
  return node;
}

}  // namespace

v1::Node ToProto(const Node& node) {
  v1::Node proto = NodeHeaderToProto(node);
  proto.set_landmarks(node.landmarks_blob);
  return proto;
}

v1::Node ToProto(Node&& node) {
  v1::Node proto = NodeHeaderToProto(node);
  proto.set_landmarks(std::move(node.landmarks_blob));
  return proto;
}

Node FromProto(const v1::Node& proto) {
  Node node = NodeHeaderFromProto(proto);
  node.landmarks_blob = proto.landmarks();
  return node;
}

Node FromProto(v1::Node&& proto) {
  Node node = NodeHeaderFromProto(proto);
  node.landmarks_blob = std::move(*proto.mutable_landmarks());
  return node;
}

v1::Edge ToProto(const Edge& edge) {
  v1::Edge proto;
  proto.set_uuid(UuidBytes(edge.id));
  proto.set_from(UuidBytes(edge.from));
  proto.set_to(UuidBytes(edge.to));
  proto.set_kind(edge.kind == EdgeKind::kPath ? v1::EDGE_KIND_PATH : v1::EDGE_KIND_METRIC);
  *proto.mutable_from_t_to() = ToProto(edge.from_T_to);
  proto.set_path(UuidBytes(edge.path));
  // Unset when absent, so an edge without one encodes to the bytes it always did.
  if (edge.covariance) *proto.mutable_covariance() = CovarianceToProto(*edge.covariance);
  return proto;
}

Edge FromProto(const v1::Edge& proto) {
  Edge edge;
  edge.id = UuidField(proto.uuid(), "Edge.uuid");
  edge.from = UuidField(proto.from(), "Edge.from");
  edge.to = UuidField(proto.to(), "Edge.to");
  switch (proto.kind()) {
    case v1::EDGE_KIND_METRIC:
      edge.kind = EdgeKind::kMetric;
      break;
    case v1::EDGE_KIND_PATH:
      edge.kind = EdgeKind::kPath;
      break;
    default:
      throw Error(ErrorCode::kCorrupt,
                  "Edge.kind " + std::to_string(proto.kind()) + " is not metric or path");
  }
  edge.from_T_to = proto.has_from_t_to() ? FromProto(proto.from_t_to()) : Se3::Identity();
  edge.path = UuidField(proto.path(), "Edge.path");
  if (proto.has_covariance()) {
    if (edge.kind != EdgeKind::kMetric) {
      throw Error(ErrorCode::kCorrupt,
                  "Edge " + edge.id.ToString() + " is a path edge and carries a covariance");
    }
    edge.covariance = CovarianceFromProto(proto.covariance(), edge.id.ToString());
  }
  return edge;
}

v1::Path ToProto(const Path& path) {
  v1::Path proto;
  proto.set_uuid(UuidBytes(path.id));
  proto.set_robot(UuidBytes(path.robot));
  proto.set_outing(UuidBytes(path.outing));
  proto.set_start_ns(path.start_ns);
  proto.set_end_ns(path.end_ns);
  return proto;
}

Path FromProto(const v1::Path& proto) {
  Path path;
  path.id = UuidField(proto.uuid(), "Path.uuid");
  path.robot = UuidField(proto.robot(), "Path.robot");
  path.outing = UuidField(proto.outing(), "Path.outing");
  path.start_ns = proto.start_ns();
  path.end_ns = proto.end_ns();
  return path;
}

v1::Annotation ToProto(const Annotation& annotation) {
  v1::Annotation proto;
  proto.set_uuid(UuidBytes(annotation.id));
  switch (annotation.target_kind) {
    case AnnotationTarget::kNode:
      proto.set_target_kind(v1::ANNOTATION_TARGET_NODE);
      break;
    case AnnotationTarget::kEdge:
      proto.set_target_kind(v1::ANNOTATION_TARGET_EDGE);
      break;
    case AnnotationTarget::kNone:
      proto.set_target_kind(v1::ANNOTATION_TARGET_UNSPECIFIED);
      break;
    case AnnotationTarget::kDatum:
      // Data ids are local to the repository that indexes the data: not part of a map.
      throw Error(ErrorCode::kInvalidArgument,
                  "annotation " + annotation.id.ToString() +
                      " is on a datum of the sensor index; such annotations are not synced");
  }
  proto.set_target(UuidBytes(annotation.target));
  proto.set_parent(UuidBytes(annotation.parent));
  proto.set_type(annotation.type);
  proto.set_payload(annotation.payload);
  return proto;
}

Annotation FromProto(const v1::Annotation& proto) {
  Annotation annotation;
  annotation.id = UuidField(proto.uuid(), "Annotation.uuid");
  switch (proto.target_kind()) {
    case v1::ANNOTATION_TARGET_NODE:
      annotation.target_kind = AnnotationTarget::kNode;
      break;
    case v1::ANNOTATION_TARGET_EDGE:
      annotation.target_kind = AnnotationTarget::kEdge;
      break;
    case v1::ANNOTATION_TARGET_UNSPECIFIED:
      annotation.target_kind = AnnotationTarget::kNone;
      break;
    default:
      throw Error(ErrorCode::kCorrupt,
                  "Annotation.target_kind " + std::to_string(proto.target_kind()) + " is unknown");
  }
  annotation.target = UuidField(proto.target(), "Annotation.target");
  annotation.parent = UuidField(proto.parent(), "Annotation.parent");
  annotation.type = proto.type();
  annotation.payload = proto.payload();
  // Seed 000 §4.2: exactly one of target and parent.
  if ((annotation.target_kind != AnnotationTarget::kNone) == !annotation.parent.IsNil() ||
      (annotation.target_kind != AnnotationTarget::kNone) == annotation.target.IsNil()) {
    throw Error(ErrorCode::kCorrupt, "Annotation " + annotation.id.ToString() +
                                         " must name exactly one of target and parent");
  }
  return annotation;
}

}  // namespace fleetmap
