#include "sqlite/element_rows.h"

#include "edge_covariance_blob.h"
#include "fleetmap/core/error.h"

namespace fleetmap::internal {

Node ReadNode(const Statement& s, bool with_landmarks) {
  Node n;
  n.id = s.UuidAt(0);
  n.stamp_ns = s.Int64(1);
  n.robot = s.UuidAt(2);
  n.outing = s.UuidAt(3);
  if (with_landmarks) n.landmarks_blob = std::string(s.Blob(4));
  return n;
}

Edge ReadEdge(const Statement& s, int first) {
  Edge e;
  e.id = s.UuidAt(first);
  e.from = s.UuidAt(first + 1);
  e.to = s.UuidAt(first + 2);
  e.kind = static_cast<EdgeKind>(s.Int64(first + 3));
  try {
    e.from_T_to = Se3FromTranslationQuaternion(
        Eigen::Vector3d(s.Double(first + 4), s.Double(first + 5), s.Double(first + 6)),
        Eigen::Quaterniond(s.Double(first + 7), s.Double(first + 8), s.Double(first + 9),
                           s.Double(first + 10)));
  } catch (const Error& error) {
    throw Error(
        ErrorCode::kCorrupt,
        "edge " + e.id.ToString() + " has a stored pose that is not SE(3): " + error.message());
  }
  e.path = s.UuidAt(first + 11);
  if (!s.IsNull(first + 12)) {
    if (e.kind != EdgeKind::kMetric) {
      throw Error(ErrorCode::kCorrupt,
                  "edge " + e.id.ToString() + " is stored as a path edge with a covariance");
    }
    e.covariance = DecodeCovarianceBlob(s.Blob(first + 12), e.id);
  }
  return e;
}

Path ReadPath(const Statement& s) {
  return Path{s.UuidAt(0), s.UuidAt(1), s.UuidAt(2), s.Int64(3), s.Int64(4)};
}

Annotation ReadAnnotation(const Statement& s) {
  Annotation a;
  a.id = s.UuidAt(0);
  if (!s.IsNull(1)) {
    a.target_kind = AnnotationTarget::kNode;
    a.target = s.UuidAt(1);
  } else if (!s.IsNull(2)) {
    a.target_kind = AnnotationTarget::kEdge;
    a.target = s.UuidAt(2);
  } else if (!s.IsNull(6)) {
    a.target_kind = AnnotationTarget::kDatum;
    a.data_id = s.Int64(6);
  } else {
    a.parent = s.UuidAt(3);
  }
  a.type = s.Text(4);
  a.payload = std::string(s.Blob(5));
  return a;
}

}  // namespace fleetmap::internal
