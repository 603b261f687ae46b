#include "postgres/element_rows.h"

#include <cstdlib>

#include "edge_covariance_blob.h"
#include "fleetmap/core/error.h"

namespace fleetmap::internal {

std::string Cat(std::initializer_list<std::string_view> parts) {
  std::string s;
  for (std::string_view p : parts) s += p;
  return s;
}

std::string UuidArray(std::span<const Uuid> ids) {
  std::string out = "{";
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (i) out += ',';
    out += ids[i].ToString();
  }
  out += '}';
  return out;
}

Uuid UuidField(const pqxx::field& f) {
  if (f.is_null()) return Uuid();
  try {
    return Uuid::Parse(std::string_view(f.c_str(), f.size()));
  } catch (const Error&) {
    throw Error(ErrorCode::kCorrupt,
                std::string("stored uuid '") + f.c_str() + "' in column " + f.name());
  }
}

std::string BytesField(const pqxx::field& f) {
  if (f.is_null()) return std::string();
  return pqxx::binarystring(f).str();
}

double DoubleField(const pqxx::field& f) {
  return std::strtod(f.c_str(), nullptr);
}

Node ReadNode(const pqxx::row& r, bool with_landmarks) {
  Node n;
  n.id = UuidField(r[0]);
  n.stamp_ns = r[1].as<std::int64_t>();
  n.robot = UuidField(r[2]);
  n.outing = UuidField(r[3]);
  if (with_landmarks) n.landmarks_blob = BytesField(r[4]);
  return n;
}

Edge ReadEdge(const pqxx::row& r, pqxx::row::size_type first) {
  Edge e;
  e.id = UuidField(r[first]);
  e.from = UuidField(r[first + 1]);
  e.to = UuidField(r[first + 2]);
  e.kind = static_cast<EdgeKind>(r[first + 3].as<int>());
  try {
    e.from_T_to = Se3FromTranslationQuaternion(
        Eigen::Vector3d(DoubleField(r[first + 4]), DoubleField(r[first + 5]),
                        DoubleField(r[first + 6])),
        Eigen::Quaterniond(DoubleField(r[first + 7]), DoubleField(r[first + 8]),
                           DoubleField(r[first + 9]), DoubleField(r[first + 10])));
  } catch (const Error& error) {
    throw Error(
        ErrorCode::kCorrupt,
        "edge " + e.id.ToString() + " has a stored pose that is not SE(3): " + error.message());
  }
  e.path = UuidField(r[first + 11]);
  if (!r[first + 12].is_null()) {
    if (e.kind != EdgeKind::kMetric) {
      throw Error(ErrorCode::kCorrupt,
                  "edge " + e.id.ToString() + " is stored as a path edge with a covariance");
    }
    e.covariance = DecodeCovarianceBlob(BytesField(r[first + 12]), e.id);
  }
  return e;
}

Path ReadPath(const pqxx::row& r) {
  return Path{UuidField(r[0]), UuidField(r[1]), UuidField(r[2]), r[3].as<std::int64_t>(),
              r[4].as<std::int64_t>()};
}

Annotation ReadAnnotation(const pqxx::row& r) {
  Annotation a;
  a.id = UuidField(r[0]);
  if (!r[1].is_null()) {
    a.target_kind = AnnotationTarget::kNode;
    a.target = UuidField(r[1]);
  } else if (!r[2].is_null()) {
    a.target_kind = AnnotationTarget::kEdge;
    a.target = UuidField(r[2]);
  } else if (!r[6].is_null()) {
    a.target_kind = AnnotationTarget::kDatum;
    a.data_id = r[6].as<std::int64_t>();
  } else {
    a.parent = UuidField(r[3]);
  }
  a.type = r[4].c_str();
  a.payload = BytesField(r[5]);
  return a;
}

}  // namespace fleetmap::internal
