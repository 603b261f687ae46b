#include <gtest/gtest.h>

#include "fleetmap/common/error.h"
#include "fleetmap/common/graph.h"
#include "fleetmap/common/proto_convert.h"

namespace fleetmap {
namespace {

Landmarks SomeLandmarks(int n) {
  Landmarks l;
  for (int i = 0; i < n; ++i) {
    l.points_camera.emplace_back(0.5f * i, -1.0f * i, 3.0f + i);
    Descriptor256 d{};
    for (int b = 0; b < 32; ++b) d[b] = static_cast<std::uint8_t>(i * 7 + b);
    l.descriptors.push_back(d);
  }
  return l;
}

TEST(Landmarks, EncodeDecodeRoundTrip) {
  const Landmarks l = SomeLandmarks(17);
  EXPECT_EQ(DecodeLandmarks(EncodeLandmarks(l)), l);
  EXPECT_EQ(DecodeLandmarks(EncodeLandmarks(Landmarks{})).size(), 0u);
}

TEST(Landmarks, MismatchedCountsAreRefused) {
  Landmarks l = SomeLandmarks(3);
  l.descriptors.pop_back();
  EXPECT_THROW(EncodeLandmarks(l), Error);
  v1::Landmarks bad;
  bad.add_xyz(1);
  bad.add_xyz(2);
  bad.add_xyz(3);
  bad.set_descriptors(std::string(31, 'x'));
  try {
    DecodeLandmarks(bad.SerializeAsString());
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCorrupt);
  }
  EXPECT_THROW(DecodeLandmarks(std::string("\xff\xff\xff\xff garbage", 12)), Error);
}

TEST(ProtoConvert, NodeEdgePathAnnotationRoundTrip) {
  const Node node{Uuid::Generate(), 123456789, Uuid::Generate(), Uuid::Generate(),
                  EncodeLandmarks(SomeLandmarks(4))};
  EXPECT_EQ(FromProto(ToProto(node)), node);

  Edge edge{Uuid::Generate(),  node.id,         Uuid::Generate(),
            EdgeKind::kMetric, Se3::Identity(), Uuid()};
  edge.from_T_to.translation() = Eigen::Vector3d(1, 2, 3);
  edge.from_T_to.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  EXPECT_TRUE(SameEdgeContent(FromProto(ToProto(edge)), edge));
  const Edge path_edge{Uuid::Generate(), node.id,         edge.to,
                       EdgeKind::kPath,  Se3::Identity(), Uuid::Generate()};
  EXPECT_TRUE(SameEdgeContent(FromProto(ToProto(path_edge)), path_edge));

  const Path path{Uuid::Generate(), node.robot, node.outing, 5, 10};
  EXPECT_EQ(FromProto(ToProto(path)), path);

  const Annotation on_node{Uuid::Generate(), AnnotationTarget::kNode, node.id, Uuid(), "t", "p"};
  EXPECT_EQ(FromProto(ToProto(on_node)), on_node);
  const Annotation child{Uuid::Generate(), AnnotationTarget::kNone, Uuid(), on_node.id, "t2", ""};
  EXPECT_EQ(FromProto(ToProto(child)), child);
}

TEST(ProtoConvert, MalformedMessagesAreCorrupt) {
  v1::Node node;
  node.set_uuid("0123456789");  // 10 bytes
  try {
    FromProto(node);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_EQ(e.code(), ErrorCode::kCorrupt);
    EXPECT_NE(std::string(e.what()).find("Node.uuid"), std::string::npos);
  }
  v1::Edge edge;
  edge.set_kind(static_cast<v1::EdgeKind>(9));
  EXPECT_THROW(FromProto(edge), Error);
  v1::Annotation both;
  both.set_uuid(Uuid::Generate().ToBytesString());
  both.set_target_kind(v1::ANNOTATION_TARGET_NODE);
  both.set_target(Uuid::Generate().ToBytesString());
  both.set_parent(Uuid::Generate().ToBytesString());
  EXPECT_THROW(FromProto(both), Error);
}

TEST(Validate, RulesOfTheModel) {
  EXPECT_THROW(Validate(Node{}), Error);
  Edge metric_with_path{Uuid::Generate(),  Uuid::Generate(), Uuid::Generate(),
                        EdgeKind::kMetric, Se3::Identity(),  Uuid::Generate()};
  EXPECT_THROW(Validate(metric_with_path), Error);
  Edge path_without_path = metric_with_path;
  path_without_path.kind = EdgeKind::kPath;
  path_without_path.path = Uuid();
  EXPECT_THROW(Validate(path_without_path), Error);
  Annotation neither{Uuid::Generate(), AnnotationTarget::kNone, Uuid(), Uuid(), "t", ""};
  EXPECT_THROW(Validate(neither), Error);
  Annotation untyped{Uuid::Generate(), AnnotationTarget::kNode, Uuid::Generate(), Uuid(), "", ""};
  EXPECT_THROW(Validate(untyped), Error);
}

}  // namespace
}  // namespace fleetmap
