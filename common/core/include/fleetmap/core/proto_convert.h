// Conversions between the C++ model (graph.h) and the fleetmap.v1 protobuf messages.
// FromProto functions throw Error(kCorrupt) for malformed messages (UUID fields that are not
// 16 bytes, unknown enum values, an annotation with both or neither of target and parent, an
// edge covariance on a path edge, of other than 21 values or that is not a valid
// PoseCovariance).
#pragma once

#include "fleetmap/core/graph.h"
#include "fleetmap/map.pb.h"

namespace fleetmap {

v1::Node ToProto(const Node& node);
v1::Edge ToProto(const Edge& edge);
v1::Path ToProto(const Path& path);
v1::Annotation ToProto(const Annotation& annotation);
v1::Se3 ToProto(const Se3& a_T_b);

Node FromProto(const v1::Node& proto);
Edge FromProto(const v1::Edge& proto);
Path FromProto(const v1::Path& proto);
Annotation FromProto(const v1::Annotation& proto);
Se3 FromProto(const v1::Se3& proto);

// The same for a node that is not needed afterwards: its landmarks (nearly all of its bytes)
// are moved, not copied. `node` or `proto` is left without them.
v1::Node ToProto(Node&& node);
Node FromProto(v1::Node&& proto);

}  // namespace fleetmap
