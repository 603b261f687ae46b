// The AnnotationStore (annotation_store.h, seed 000 §4.2, §4.3.1) on both backends: bbox2d
// CRUD, the exactly-one-target rule, cascading deletes, compound queries and the links between
// the map and the raw data. Data rows go in through raw SQL so these tests depend only on the
// schema of the sensor index, not on its library.
#include "fleetmap/store/annotation_store.h"

#include <gtest/gtest.h>

#include <string>

#include "expect_error.h"
#include "fleetmap/core/error.h"
#include "fleetmap/store/graph_store.h"
#include "store_backends.h"

namespace fleetmap {
namespace {

using testing::BackendNames;
using testing::StoreBackends;

constexpr std::int64_t kRover = 1;   // platform ids of the fixture
constexpr std::int64_t kWalker = 2;  // another platform

BoundingBox2d Box(const std::string& label, double score = 0.9) {
  return BoundingBox2d{10, 20, 30.5, 40.25, label, score};
}

BoxAnnotation BoxOnDatum(std::int64_t data_id, const std::string& label, double score = 0.9) {
  Annotation a;
  a.id = Uuid::Generate();
  a.target_kind = AnnotationTarget::kDatum;
  a.data_id = data_id;
  a.type = "bbox2d";
  return BoxAnnotation{a, Box(label, score)};
}

BoxAnnotation BoxUnder(const Uuid& parent, const std::string& label) {
  Annotation a;
  a.id = Uuid::Generate();
  a.parent = parent;
  a.type = "bbox2d";
  return BoxAnnotation{a, Box(label)};
}

std::vector<std::int64_t> DataIds(const std::vector<AnnotatedDatum>& data) {
  std::vector<std::int64_t> ids;
  for (const AnnotatedDatum& d : data) ids.push_back(d.data_id);
  return ids;
}

template <typename Backend>
class AnnotationStoreTest : public ::testing::Test {
 protected:
  void SetUp() override {
    if (auto why = Backend::Unavailable()) GTEST_SKIP() << *why;
    backend_.emplace();
    store_ = GraphStore::Open(backend_->Uri());
    // Two platforms, one camera; data 1..4 on the rover at t = 100, 200, 300, 400 ns and
    // datum 5 on the walker at t = 200 ns.
    backend_->ExecRaw(
        "INSERT INTO platforms (platform_id, name) VALUES (1, 'rover'), (2, 'walker');"
        "INSERT INTO sensors (sensor_id, name, type) VALUES (7, 'cam', 'camera');"
        "INSERT INTO files (file_id, file) VALUES (1, 'f'), (2, 'g');"
        "INSERT INTO data (data_id, platform, sensor, stamp_ns, file_id, \"offset\", length,"
        " type)"
        " VALUES (1, 1, 7, 100, 1, 0, 10, 'img'), (2, 1, 7, 200, 1, 10, 10, 'img'),"
        " (3, 1, 7, 300, 1, 20, 10, 'img'), (4, 1, 7, 400, 1, 30, 10, 'img'),"
        " (5, 2, 7, 200, 2, 0, 10, 'img')");
  }

  AnnotationStore& annotations() { return store_->annotations(); }

  std::optional<Backend> backend_;
  std::unique_ptr<GraphStore> store_;
};

TYPED_TEST_SUITE(AnnotationStoreTest, StoreBackends, BackendNames);

TYPED_TEST(AnnotationStoreTest, RegistryHasTheShippedTypes) {
  const AnnotationType* box = FindAnnotationType("bbox2d");
  ASSERT_NE(box, nullptr);
  EXPECT_EQ(box->table, "annotation_bbox2d");
  EXPECT_EQ(box->label_column, "label");
  EXPECT_EQ(box->columns.size(), 6u);
  ASSERT_NE(FindAnnotationType("datum_link"), nullptr);
  EXPECT_EQ(FindAnnotationType("polygon"), nullptr);
}

TYPED_TEST(AnnotationStoreTest, BoxCreateReadUpdate) {
  const BoxAnnotation car = BoxOnDatum(2, "car", 0.75);
  this->annotations().PutBox(car);
  const BoxAnnotation read = this->annotations().GetBox(car.annotation.id);
  EXPECT_EQ(read.annotation, car.annotation);
  EXPECT_EQ(read.box, car.box);
  // The same again is a no-op; other content under the same id is a conflict.
  this->annotations().PutBox(car);
  BoxAnnotation other = car;
  other.box.label = "bus";
  ExpectError(
      ErrorCode::kConflict, [&] { this->annotations().PutBox(other); },
      car.annotation.id.ToString());

  this->annotations().UpdateBox(car.annotation.id, Box("truck", 0.5));
  EXPECT_EQ(this->annotations().GetBox(car.annotation.id).box, Box("truck", 0.5));
  ExpectError(ErrorCode::kNotFound, [&] { this->annotations().GetBox(Uuid::Generate()); });
  ExpectError(ErrorCode::kNotFound,
              [&] { this->annotations().UpdateBox(Uuid::Generate(), Box("x")); });

  // The datum's annotations, through both the AnnotationStore and the GraphStore.
  const std::vector<Annotation> on_datum = this->annotations().OnDatum(2);
  ASSERT_EQ(on_datum.size(), 1u);
  EXPECT_EQ(on_datum[0], car.annotation);
  EXPECT_EQ(this->store_->GetAnnotation(car.annotation.id), car.annotation);
  EXPECT_TRUE(this->annotations().OnDatum(3).empty());
}

TYPED_TEST(AnnotationStoreTest, BoxValidationNamesTheField) {
  BoxAnnotation bad = BoxOnDatum(1, "car");
  bad.box.score = 1.5;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(bad); }, "score");
  bad = BoxOnDatum(1, "car");
  bad.box.width_px = 0;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(bad); }, "width");
  bad = BoxOnDatum(1, "");
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(bad); }, "label");
  bad = BoxOnDatum(1, "car");
  bad.annotation.type = "polygon";
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(bad); }, "polygon");
  const BoxAnnotation good = BoxOnDatum(1, "car");
  this->annotations().PutBox(good);
  ExpectError(
      ErrorCode::kInvalidArgument,
      [&] { this->annotations().UpdateBox(good.annotation.id, Box("car", -0.1)); }, "score");
  EXPECT_EQ(this->store_->Stats().annotations, 1);
}

TYPED_TEST(AnnotationStoreTest, ExactlyOneTarget) {
  // Both a datum and a parent.
  const BoxAnnotation root = BoxOnDatum(1, "car");
  this->annotations().PutBox(root);
  BoxAnnotation both = BoxOnDatum(1, "wheel");
  both.annotation.parent = root.annotation.id;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(both); }, "exactly one");
  // Neither.
  BoxAnnotation neither = BoxOnDatum(1, "wheel");
  neither.annotation.target_kind = AnnotationTarget::kNone;
  neither.annotation.data_id = 0;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(neither); }, "exactly one");
  // A node id alongside a datum.
  BoxAnnotation datum_and_node = BoxOnDatum(1, "wheel");
  datum_and_node.annotation.target = Uuid::Generate();
  ExpectError(ErrorCode::kInvalidArgument, [&] { this->annotations().PutBox(datum_and_node); });
  // The same rule through the GraphStore.
  Annotation raw{Uuid::Generate(), AnnotationTarget::kDatum, Uuid(), root.annotation.id, "t", ""};
  raw.data_id = 1;
  ExpectError(ErrorCode::kInvalidArgument, [&] { this->store_->PutAnnotation(raw); });
  // A datum that is not in the index.
  ExpectError(
      ErrorCode::kIntegrity, [&] { this->annotations().PutBox(BoxOnDatum(99, "car")); }, "99");
  Annotation dangling{Uuid::Generate(), AnnotationTarget::kDatum, Uuid(), Uuid(), "t", "p"};
  dangling.data_id = 99;
  ExpectError(ErrorCode::kIntegrity, [&] { this->store_->PutAnnotation(dangling); });
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->store_->Put(GraphBatch{{}, {}, {}, {dangling}});
      },
      "99");
  // And the database itself refuses two targets behind the API's back.
  const std::string id = root.annotation.id.ToString();
  EXPECT_ANY_THROW(this->backend_->ExecRaw(
      "UPDATE annotations SET parent_id = (SELECT id FROM annotations LIMIT 1) WHERE data_id = 1"));
  EXPECT_EQ(this->store_->Stats().annotations, 1);
  // An opaque annotation on a datum through the GraphStore works and reads back.
  Annotation opaque{Uuid::Generate(), AnnotationTarget::kDatum, Uuid(), Uuid(), "note", "wet"};
  opaque.data_id = 3;
  this->store_->PutAnnotation(opaque);
  EXPECT_EQ(this->store_->GetAnnotation(opaque.id), opaque);
  this->store_->Put(GraphBatch{{}, {}, {}, {opaque}});  // identical again: a no-op
  EXPECT_EQ(this->annotations().OnDatum(3), std::vector<Annotation>{opaque});
}

TYPED_TEST(AnnotationStoreTest, DeleteCascadesToChildrenAndPayloads) {
  const BoxAnnotation car = BoxOnDatum(2, "car");
  const BoxAnnotation wheel = BoxUnder(car.annotation.id, "wheel");
  const BoxAnnotation bolt = BoxUnder(wheel.annotation.id, "bolt");
  const BoxAnnotation other = BoxOnDatum(2, "car");
  for (const BoxAnnotation& b : {car, wheel, bolt, other}) this->annotations().PutBox(b);
  EXPECT_EQ(this->store_->ChildAnnotations(car.annotation.id).size(), 1u);

  EXPECT_EQ(this->annotations().Delete(car.annotation.id), 3);
  ExpectError(ErrorCode::kNotFound, [&] { this->annotations().GetBox(wheel.annotation.id); });
  ExpectError(ErrorCode::kNotFound, [&] { this->annotations().GetBox(bolt.annotation.id); });
  EXPECT_EQ(this->annotations().GetBox(other.annotation.id).box, other.box);
  EXPECT_EQ(this->store_->Stats().annotations, 1);
  // No payload row outlives its annotation: only `other`'s box is left.
  const auto count = [&](const std::string& where) {
    const AnnotatedDataQuery q{kRover, 0, 1000, ParseLabelFilter(where)};
    return this->annotations().FindAnnotatedData(q).size();
  };
  EXPECT_EQ(count("label=car"), 1u);
  EXPECT_EQ(count("label=wheel"), 0u);
  EXPECT_ANY_THROW(this->backend_->ExecRaw(
      "INSERT INTO annotation_bbox2d (annotation_id, x_px, y_px, width_px, height_px, label,"
      " score) SELECT annotation_id, 0, 0, 1, 1, 'x', 0.5 FROM annotation_bbox2d"));  // duplicate
  ExpectError(ErrorCode::kNotFound, [&] { this->annotations().Delete(car.annotation.id); });
}

TYPED_TEST(AnnotationStoreTest, DeleteInsideATransactionRollsBack) {
  const BoxAnnotation car = BoxOnDatum(2, "car");
  this->annotations().PutBox(car);
  {
    GraphStore::Transaction txn = this->store_->Begin();
    this->annotations().PutBox(BoxUnder(car.annotation.id, "wheel"));
    EXPECT_EQ(this->annotations().Delete(car.annotation.id), 2);
  }  // rolled back
  EXPECT_EQ(this->annotations().GetBox(car.annotation.id).box, car.box);
  EXPECT_TRUE(this->store_->ChildAnnotations(car.annotation.id).empty());
}

TYPED_TEST(AnnotationStoreTest, CompoundQueryWithAndWithoutChild) {
  // Datum 2: car with a wheel. Datum 3: car without children. Datum 1: car, but its wheel
  // hangs two levels down (not a direct child). Datum 4 (t = 400) outside [150, 350]: car and
  // wheel. Datum 5 on the walker at t = 200: car and wheel.
  const BoxAnnotation car2 = BoxOnDatum(2, "car"), car3 = BoxOnDatum(3, "car");
  const BoxAnnotation car1 = BoxOnDatum(1, "car"), car4 = BoxOnDatum(4, "car");
  const BoxAnnotation car5 = BoxOnDatum(5, "car");
  for (const BoxAnnotation& b : {car1, car2, car3, car4, car5}) this->annotations().PutBox(b);
  this->annotations().PutBox(BoxUnder(car2.annotation.id, "wheel"));
  this->annotations().PutBox(BoxUnder(car2.annotation.id, "wheel"));  // two wheels: still once
  const BoxAnnotation door = BoxUnder(car1.annotation.id, "door");
  this->annotations().PutBox(door);
  this->annotations().PutBox(BoxUnder(door.annotation.id, "wheel"));
  this->annotations().PutBox(BoxUnder(car4.annotation.id, "wheel"));
  this->annotations().PutBox(BoxUnder(car5.annotation.id, "wheel"));
  this->annotations().PutBox(BoxOnDatum(3, "pedestrian"));

  AnnotatedDataQuery q{kRover, 150, 350, ParseLabelFilter("label=car")};
  EXPECT_EQ(DataIds(this->annotations().FindAnnotatedData(q)), (std::vector<std::int64_t>{2, 3}));
  q.filter = ParseLabelFilter("label=car > label=wheel");
  const std::vector<AnnotatedDatum> with_wheel = this->annotations().FindAnnotatedData(q);
  ASSERT_EQ(with_wheel.size(), 1u);
  EXPECT_EQ(with_wheel[0], (AnnotatedDatum{2, 200, 7}));
  // Bounds are inclusive: [100, 400] takes in data 1 and 4.
  q.from_ns = 100;
  q.to_ns = 400;
  EXPECT_EQ(DataIds(this->annotations().FindAnnotatedData(q)), (std::vector<std::int64_t>{2, 4}));
  q.filter = ParseLabelFilter("label=car");
  EXPECT_EQ(DataIds(this->annotations().FindAnnotatedData(q)),
            (std::vector<std::int64_t>{1, 2, 3, 4}));
  q.filter = ParseLabelFilter("label=car > label=door");
  EXPECT_EQ(DataIds(this->annotations().FindAnnotatedData(q)), (std::vector<std::int64_t>{1}));
  // A child label alone does not match as a top-level label on a datum.
  q.filter = ParseLabelFilter("label=wheel");
  EXPECT_TRUE(this->annotations().FindAnnotatedData(q).empty());
  // The other platform.
  q = AnnotatedDataQuery{kWalker, 0, 1000, ParseLabelFilter("label=car>label=wheel")};
  EXPECT_EQ(DataIds(this->annotations().FindAnnotatedData(q)), (std::vector<std::int64_t>{5}));
  q.to_ns = -1;
  ExpectError(
      ErrorCode::kInvalidArgument, [&] { this->annotations().FindAnnotatedData(q); }, "window");
}

TYPED_TEST(AnnotationStoreTest, NodeAndDatumLinkBothWays) {
  // An experience node built from datum 2 (seed 000 §4.3.1: the map and the raw data link).
  const Node node{Uuid::Generate(), 200, Uuid::Generate(), Uuid::Generate(), "lm"};
  this->store_->PutNode(node);
  const Uuid link = Uuid::Generate();
  this->annotations().LinkToDatum(link, AnnotationTarget::kNode, node.id, 2);
  this->annotations().LinkToDatum(link, AnnotationTarget::kNode, node.id, 2);  // no-op
  ExpectError(ErrorCode::kConflict,
              [&] { this->annotations().LinkToDatum(link, AnnotationTarget::kNode, node.id, 3); });
  const BoxAnnotation car = BoxOnDatum(2, "car");
  this->annotations().PutBox(car);
  this->annotations().PutBox(BoxOnDatum(3, "bus"));  // on a datum the node is not built from

  // node -> data -> their annotations.
  EXPECT_EQ(this->annotations().DataLinkedTo(node.id),
            (std::vector<LinkedDatum>{LinkedDatum{link, 2, 200}}));
  EXPECT_EQ(this->annotations().AnnotationsOnDataLinkedTo(node.id),
            std::vector<Annotation>{car.annotation});
  // datum -> the node; the link is also an ordinary annotation on the node.
  const std::vector<Annotation> back = this->annotations().LinksToDatum(2);
  ASSERT_EQ(back.size(), 1u);
  EXPECT_EQ(back[0].target_kind, AnnotationTarget::kNode);
  EXPECT_EQ(back[0].target, node.id);
  EXPECT_EQ(this->store_->AnnotationsOn(AnnotationTarget::kNode, node.id).size(), 1u);
  EXPECT_TRUE(this->annotations().LinksToDatum(3).empty());

  // Either end missing is refused, naming it.
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->annotations().LinkToDatum(Uuid::Generate(), AnnotationTarget::kNode, node.id, 42);
      },
      "42");
  const Uuid stranger = Uuid::Generate();
  ExpectError(
      ErrorCode::kIntegrity,
      [&] {
        this->annotations().LinkToDatum(Uuid::Generate(), AnnotationTarget::kNode, stranger, 2);
      },
      stranger.ToString());
  ExpectError(ErrorCode::kInvalidArgument, [&] {
    this->annotations().LinkToDatum(Uuid::Generate(), AnnotationTarget::kDatum, node.id, 2);
  });
  // Deleting the link unlinks.
  EXPECT_EQ(this->annotations().Delete(link), 1);
  EXPECT_TRUE(this->annotations().DataLinkedTo(node.id).empty());
}

TYPED_TEST(AnnotationStoreTest, ExistingGraphAnnotationsKeepWorking) {
  const Node a{Uuid::Generate(), 1, Uuid::Generate(), Uuid::Generate(), "x"};
  this->store_->PutNode(a);
  const Annotation on_node{Uuid::Generate(), AnnotationTarget::kNode, a.id, Uuid(), "t", "p"};
  const Annotation child{Uuid::Generate(), AnnotationTarget::kNone, Uuid(), on_node.id, "c", ""};
  this->store_->Put(GraphBatch{{}, {}, {}, {on_node, child}});
  EXPECT_EQ(this->store_->GetAnnotation(child.id), child);
  EXPECT_EQ(this->store_->AnnotationsOn(AnnotationTarget::kNode, a.id),
            std::vector<Annotation>{on_node});
  // A box may hang off a node's annotation too, and deleting the node's annotation takes it.
  const BoxAnnotation box = BoxUnder(on_node.id, "sign");
  this->annotations().PutBox(box);
  EXPECT_EQ(this->annotations().Delete(on_node.id), 3);
  EXPECT_EQ(this->store_->Stats().annotations, 0);
}

// The filter syntax needs no store.
TEST(LabelFilterTest, ParsesAndRefuses) {
  EXPECT_EQ(ParseLabelFilter("label=car"), (LabelFilter{"car", std::nullopt}));
  EXPECT_EQ(ParseLabelFilter("  label=car >  label=wheel "), (LabelFilter{"car", "wheel"}));
  EXPECT_EQ(ParseLabelFilter("label=car>label=wheel"), (LabelFilter{"car", "wheel"}));
  for (const char* bad : {"", "car", "label=", "label=car >", "label=car > wheel",
                          "label=car > label=wheel > label=hub", "labels=car", "label=a=b",
                          "label=car label=bus", "score=0.5"}) {
    ExpectError(
        ErrorCode::kInvalidArgument, [&] { ParseLabelFilter(bad); }, "label=");
  }
}

}  // namespace
}  // namespace fleetmap
