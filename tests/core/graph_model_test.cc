#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <limits>
#include <string>
#include <vector>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/graph.h"
#include "fleetmap/core/proto_convert.h"
#include "graph_elements.h"

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

// A KITTI-like rectified pair whose points are expressed in the unrectified left camera (a
// rotation of a few degrees, as a float quaternion whose norm is 1 only up to rounding).
StereoCamera SomeStereoCamera() {
  const Eigen::Quaternionf q(
      Eigen::AngleAxisf(0.03f, Eigen::Vector3f(0.2f, -1.0f, 0.1f).normalized()));
  return {.focal_px = 718.856f,
          .baseline_m = 0.5371657f,
          .rect_q_camera = {q.w(), q.x(), q.y(), q.z()}};
}

TEST(Landmarks, StereoCameraRoundTripsExactly) {
  Landmarks l = SomeLandmarks(9);
  l.stereo = SomeStereoCamera();
  const Landmarks back = DecodeLandmarks(EncodeLandmarks(l));
  ASSERT_TRUE(back.stereo.has_value());
  EXPECT_EQ(*back.stereo, *l.stereo);  // every float bit for bit
  EXPECT_EQ(back, l);
  // Extreme but valid values survive too: a tiny focal length, a long baseline, the identity
  // with the other sign.
  l.stereo = StereoCamera{.focal_px = std::numeric_limits<float>::min(),
                          .baseline_m = 1e6f,
                          .rect_q_camera = {-1.f, 0.f, 0.f, 0.f}};
  EXPECT_EQ(DecodeLandmarks(EncodeLandmarks(l)), l);
  // No points at all, only the camera.
  Landmarks empty;
  empty.stereo = SomeStereoCamera();
  EXPECT_EQ(DecodeLandmarks(EncodeLandmarks(empty)), empty);
}

// A blob of before the stereo field existed, written byte by byte from the wire format
// (field 1 packed floats, field 2 bytes): it decodes with no camera, and landmarks without one
// still encode to exactly those bytes, so old and new blobs of the same landmarks are equal.
TEST(Landmarks, BlobWithoutStereoDecodesWithoutCamera) {
  std::string old_blob(
      "\x0a\x0c"          // field 1, length-delimited, 12 bytes
      "\x00\x00\x80\x3f"  // 1.0f
      "\x00\x00\x00\x40"  // 2.0f
      "\x00\x00\x40\x40"  // 3.0f
      "\x12\x20",         // field 2, length-delimited, 32 bytes
      16);
  for (int b = 0; b < 32; ++b) old_blob.push_back(static_cast<char>(b * 5));
  const Landmarks decoded = DecodeLandmarks(old_blob);
  ASSERT_EQ(decoded.size(), 1u);
  EXPECT_EQ(decoded.points_camera[0], Eigen::Vector3f(1.f, 2.f, 3.f));
  EXPECT_EQ(decoded.descriptors[0][31], 155);
  EXPECT_EQ(decoded.stereo, std::nullopt);
  EXPECT_EQ(EncodeLandmarks(decoded), old_blob);

  const Landmarks plain = SomeLandmarks(5);
  EXPECT_EQ(DecodeLandmarks(EncodeLandmarks(plain)).stereo, std::nullopt);
}

// Pyramid levels and the scale factor survive the blob; landmarks without levels still write
// no levels field (old and new blobs of the same landmarks are equal, as above).
TEST(Landmarks, PyramidLevelsRoundTrip) {
  Landmarks l = SomeLandmarks(6);
  l.stereo = SomeStereoCamera();
  l.stereo->level_scale = 1.2f;
  l.levels = {0, 1, 7, 3, Landmarks::kMaxLevel, 0};
  const Landmarks back = DecodeLandmarks(EncodeLandmarks(l));
  EXPECT_EQ(back.levels, l.levels);
  EXPECT_EQ(back.stereo->level_scale, 1.2f);
  EXPECT_EQ(back, l);
  Landmarks unknown = SomeLandmarks(6);
  unknown.stereo = SomeStereoCamera();
  const std::string blob = EncodeLandmarks(unknown);
  v1::Landmarks proto;
  ASSERT_TRUE(proto.ParseFromString(blob));
  EXPECT_TRUE(proto.levels().empty());
  EXPECT_EQ(proto.stereo().level_scale(), 0.f);  // absent: unknown, decoded as 1
  EXPECT_EQ(DecodeLandmarks(blob).stereo->level_scale, 1.f);
  EXPECT_TRUE(DecodeLandmarks(blob).levels.empty());
}

// Levels that do not fit the points, or out of range, or a scale out of [1, 4]: refused by Encode
// as invalid, and decoded as corrupt when a blob carries them.
TEST(Landmarks, MalformedPyramidLevelsAreRefused) {
  Landmarks l = SomeLandmarks(4);
  l.stereo = SomeStereoCamera();
  l.levels = {0, 1, 2};
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeLandmarks(l); }, "3 pyramid levels for 4");
  l.levels = {0, 1, 2, 32};
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeLandmarks(l); }, "pyramid level 32");
  l.levels = {0, 1, 2, 3};
  l.stereo->level_scale = 0.5f;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { EncodeLandmarks(l); }, "pyramid scale");

  l.stereo->level_scale = 1.2f;
  v1::Landmarks proto;
  ASSERT_TRUE(proto.ParseFromString(EncodeLandmarks(l)));
  for (const std::string& levels :
       {std::string("\x00\x01\x02", 3), std::string("\x00\x01\x02\x21", 4)}) {
    proto.set_levels(levels);
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeLandmarks(proto.SerializeAsString()); }, "landmark blob");
  }
  proto.set_levels(std::string("\x00\x01\x02\x03", 4));
  proto.mutable_stereo()->set_level_scale(9.f);
  ExpectError(
      ErrorCode::kCorrupt, [&] { DecodeLandmarks(proto.SerializeAsString()); }, "pyramid scale");
}

// Each fault of a stereo camera: refused by Encode as an invalid argument, and the same values
// written into a blob by hand (as another writer or a damaged file might) decode as corrupt.
TEST(Landmarks, MalformedStereoCameraIsRefused) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const float inf = std::numeric_limits<float>::infinity();
  struct Case {
    const char* what;
    float focal_px, baseline_m;
    std::vector<float> q;
  };
  const std::vector<Case> cases = {
      {"zero focal length", 0.f, 0.5f, {1, 0, 0, 0}},
      {"negative focal length", -700.f, 0.5f, {1, 0, 0, 0}},
      {"NaN focal length", nan, 0.5f, {1, 0, 0, 0}},
      {"infinite focal length", inf, 0.5f, {1, 0, 0, 0}},
      {"zero baseline", 700.f, 0.f, {1, 0, 0, 0}},
      {"negative baseline", 700.f, -0.5f, {1, 0, 0, 0}},
      {"NaN baseline", 700.f, nan, {1, 0, 0, 0}},
      {"non-unit quaternion", 700.f, 0.5f, {1, 1, 0, 0}},
      {"zero quaternion", 700.f, 0.5f, {0, 0, 0, 0}},
      {"NaN in the quaternion", 700.f, 0.5f, {nan, 0, 0, 0}},
      {"3-term quaternion", 700.f, 0.5f, {1, 0, 0}},
      {"5-term quaternion", 700.f, 0.5f, {1, 0, 0, 0, 0}},
      {"no quaternion", 700.f, 0.5f, {}},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    if (c.q.size() == 4) {  // the model's array holds four terms; other counts are wire-only
      Landmarks l = SomeLandmarks(2);
      l.stereo = StereoCamera{.focal_px = c.focal_px,
                              .baseline_m = c.baseline_m,
                              .rect_q_camera = {c.q[0], c.q[1], c.q[2], c.q[3]}};
      ExpectError(
          ErrorCode::kInvalidArgument, [&] { EncodeLandmarks(l); }, "stereo camera");
    }
    v1::Landmarks proto;
    proto.ParseFromString(EncodeLandmarks(SomeLandmarks(2)));
    v1::StereoCamera* stereo = proto.mutable_stereo();
    stereo->set_focal_px(c.focal_px);
    stereo->set_baseline_m(c.baseline_m);
    for (float term : c.q) stereo->add_rect_q_camera(term);
    ExpectError(
        ErrorCode::kCorrupt, [&] { DecodeLandmarks(proto.SerializeAsString()); }, "stereo camera");
  }
  // A stereo message present with every field at its default is a camera with no focal length,
  // not an absent camera: corrupt too.
  v1::Landmarks empty_camera;
  empty_camera.mutable_stereo();
  ExpectError(ErrorCode::kCorrupt, [&] { DecodeLandmarks(empty_camera.SerializeAsString()); });
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

Edge MetricEdgeWithCovariance() {
  Edge edge{Uuid::Generate(), Uuid::Generate(), Uuid::Generate(),   EdgeKind::kMetric,
            Se3::Identity(),  Uuid(),           SomeCovariance(2.5)};
  edge.from_T_to.translation() = Eigen::Vector3d(0.5, -2, 1);
  return edge;
}

TEST(ProtoConvert, EdgeCovarianceRoundTripsExactly) {
  const Edge edge = MetricEdgeWithCovariance();
  v1::Edge message;
  ASSERT_TRUE(message.ParseFromString(ToProto(edge).SerializeAsString()));
  const Edge decoded = FromProto(message);
  ASSERT_TRUE(decoded.covariance.has_value());
  EXPECT_TRUE(*decoded.covariance == *edge.covariance) << *decoded.covariance;
  EXPECT_TRUE(SameEdgeContent(decoded, edge));
  // The upper triangle, row by row (map.proto).
  ASSERT_EQ(message.covariance().upper_size(), 21);
  EXPECT_EQ(message.covariance().upper(1), (*edge.covariance)(0, 1));
  EXPECT_EQ(message.covariance().upper(6), (*edge.covariance)(1, 1));
  EXPECT_EQ(message.covariance().upper(20), (*edge.covariance)(5, 5));
}

// An edge without a covariance is the message it always was, byte for byte, and a message
// from before the field decodes to an edge without one.
TEST(ProtoConvert, EdgeWithoutCovarianceKeepsItsBytes) {
  const Uuid id = Uuid::FromBytes(std::string(16, '\x01'));
  const Uuid from = Uuid::FromBytes(std::string(16, '\x02'));
  const Uuid to = Uuid::FromBytes(std::string(16, '\x03'));
  Edge edge{id, from, to, EdgeKind::kMetric, Se3::Identity(), Uuid(), std::nullopt};
  // uuid, from, to (16 bytes each), kind 1, from_T_to {qw = 1.0}.
  const std::string before = std::string("\x0a\x10") + std::string(16, '\x01') + "\x12\x10" +
                             std::string(16, '\x02') + "\x1a\x10" + std::string(16, '\x03') +
                             std::string("\x20\x01\x2a\x09\x21\0\0\0\0\0\0\xf0\x3f", 13);
  EXPECT_EQ(ToProto(edge).SerializeAsString(), before);
  v1::Edge old;
  ASSERT_TRUE(old.ParseFromString(before));
  const Edge decoded = FromProto(old);
  EXPECT_FALSE(decoded.covariance.has_value());
  EXPECT_TRUE(SameEdgeContent(decoded, edge));
  // With a covariance, the same bytes and field 7 after them.
  edge.covariance = SomeCovariance();
  const std::string with = ToProto(edge).SerializeAsString();
  EXPECT_EQ(with.substr(0, before.size()), before);
  EXPECT_EQ(with.substr(before.size(), 6), std::string("\x3a\xab\x01\x0a\xa8\x01"));
  EXPECT_EQ(with.size(), before.size() + 6 + 21 * 8);
}

TEST(ProtoConvert, MalformedCovarianceIsCorrupt) {
  const v1::Edge good = ToProto(MetricEdgeWithCovariance());
  const auto expect_corrupt = [](const v1::Edge& message, const std::string& mention) {
    ExpectError(
        ErrorCode::kCorrupt, [&] { FromProto(message); }, mention);
  };
  v1::Edge short_one = good;
  short_one.mutable_covariance()->mutable_upper()->RemoveLast();
  expect_corrupt(short_one, "holds 20 values");
  v1::Edge long_one = good;
  long_one.mutable_covariance()->add_upper(1.0);
  expect_corrupt(long_one, "holds 22 values");
  v1::Edge empty = good;
  empty.mutable_covariance()->clear_upper();  // present but empty is not absent
  expect_corrupt(empty, "holds 0 values");
  v1::Edge nan = good;
  nan.mutable_covariance()->set_upper(4, std::numeric_limits<double>::quiet_NaN());
  expect_corrupt(nan, "not a finite, positive semi-definite");
  v1::Edge infinite = good;
  infinite.mutable_covariance()->set_upper(0, std::numeric_limits<double>::infinity());
  expect_corrupt(infinite, "not a finite, positive semi-definite");
  // The upper triangle makes the matrix symmetric whatever it holds; negative definite is
  // what is left to refuse.
  Edge negative = MetricEdgeWithCovariance();
  negative.covariance = PoseCovariance(-*negative.covariance);
  expect_corrupt(ToProto(negative), "not a finite, positive semi-definite");
  v1::Edge on_path = good;
  on_path.set_kind(v1::EDGE_KIND_PATH);
  on_path.set_path(Uuid::Generate().ToBytesString());
  expect_corrupt(on_path, "path edge");
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

// Most edges carry no covariance: an Edge must not hold a 6 x 6 matrix inline (plans and merges
// keep every edge of a map in memory, and the copy plan's cache cap counts sizeof(Edge)).
TEST(EdgeCovarianceTest, AnEdgeHoldsItsCovarianceApartAndCopiesShareIt) {
  EXPECT_LE(sizeof(EdgeCovariance), 2 * sizeof(void*));
  EXPECT_LT(sizeof(Edge), sizeof(PoseCovariance));
  Edge edge;
  EXPECT_FALSE(edge.covariance.has_value());
  EXPECT_EQ(edge.covariance.optional(), std::nullopt);
  const PoseCovariance identity = PoseCovariance::Identity();
  edge.covariance = identity;
  const Edge copy = edge;
  ASSERT_TRUE(copy.covariance.has_value());
  EXPECT_EQ(&*copy.covariance, &*edge.covariance) << "copies share the one value";
  EXPECT_TRUE(copy.covariance.value_or(PoseCovariance::Zero()).isIdentity());
  edge.covariance.reset();
  EXPECT_FALSE(edge.covariance);
  EXPECT_TRUE(copy.covariance->isIdentity()) << "a reset leaves the copies' value";
}

}  // namespace
}  // namespace fleetmap
