// AnnotationStore: annotations on raw sensor data (seed 000 §4.2, §5.2) over the GraphStore's
// one global annotation table.
//
// The model (seed 000 §4.2, §5.2):
//   annotations(id, node_id | edge_id | data_id | parent_id, type, payload)   ONE table; every
//       annotation is on exactly one thing: a graph node or edge (graph.h, §4.3.1), a datum
//       of the sensor index (sensor_index.h), or a lower-level annotation (its parent).
//   annotation_<type>(annotation_id, columns...)   one typed payload table per registered type,
//       one row per annotation of that type, deleted with it.
// Registered types (AnnotationTypes()):
//   "bbox2d"      an axis-aligned box in image pixels, a label and a score in [0, 1];
//   "datum_link"  on a node or edge: "this element was built from datum D" (seed 000 §4.3.1,
//                 the map and the raw data reach each other both ways).
// Annotations of other types go through GraphStore::PutAnnotation with an opaque payload.
//
// Compound queries (seed 000 §4.2, σ_θ(Data ⋈ Annotations)) run as ONE SQL statement per call
// on either backend; nothing is filtered client-side.
//
// Errors: Error(kInvalidArgument) for malformed input (naming the field), Error(kNotFound) for
// an unknown annotation, Error(kIntegrity) when what an annotation is on is not stored,
// Error(kConflict) for an id stored with other content, Error(kBackend) for the database.
//
// Threading: an AnnotationStore belongs to its GraphStore (GraphStore::annotations()) and
// shares its connection and its Transaction: one thread at a time.
#pragma once

#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/uuid.h"

namespace fleetmap {

// ---- The registry of typed payload tables --------------------------------------------------

enum class AnnotationColumnKind { kReal, kText, kInteger };

struct AnnotationColumn {
  std::string_view name;
  AnnotationColumnKind kind;
};

// A typed payload table registered by name. Its table is created by a schema migration; its
// first column is annotation_id (the annotation's UUID, ON DELETE CASCADE), then `columns`.
struct AnnotationType {
  std::string_view name;   // Annotation::type of its annotations
  std::string_view table;  // the payload table
  std::span<const AnnotationColumn> columns;
  // The column compound queries match labels against; empty when the type has no label.
  std::string_view label_column;
};

// Every registered type, in a fixed order. Constant data, not state.
std::span<const AnnotationType> AnnotationTypes();
// The registered type called `name`, or nullptr.
const AnnotationType* FindAnnotationType(std::string_view name);

inline constexpr std::string_view kBoundingBox2dType = "bbox2d";
inline constexpr std::string_view kDatumLinkType = "datum_link";

// ---- Payloads -------------------------------------------------------------------------------

// Type "bbox2d". Image conventions: origin at the top-left pixel corner, x right, y down, all in
// pixels. INVARIANTS (Validate): finite, width and height > 0, label non-empty, score in [0, 1].
struct BoundingBox2d {
  double x_px = 0;
  double y_px = 0;
  double width_px = 0;
  double height_px = 0;
  std::string label;
  double score = 1;

  friend bool operator==(const BoundingBox2d&, const BoundingBox2d&) = default;
};

// Throws Error(kInvalidArgument) naming the field that breaks an invariant.
void Validate(const BoundingBox2d& box);

// An annotation of type "bbox2d" with its payload row. annotation.type is "bbox2d" and
// annotation.payload is empty: the box lives in its own table.
struct BoxAnnotation {
  Annotation annotation;
  BoundingBox2d box;
};

// ---- Compound queries -----------------------------------------------------------------------

// "label=θ" or "label=θ > label=φ": an annotation labelled θ, and optionally one of its direct
// child annotations labelled φ.
struct LabelFilter {
  std::string label;
  std::optional<std::string> child_label{};

  friend bool operator==(const LabelFilter&, const LabelFilter&) = default;
};

// Parses the CLI's filter syntax:  label=θ [> label=φ]  (spaces around '>' optional; a label
// is one or more characters other than whitespace, '>' and '='). Throws
// Error(kInvalidArgument) that quotes the filter and says what was expected where.
LabelFilter ParseLabelFilter(std::string_view text);

// Data of one platform with stamp in [from_ns, to_ns] (both inclusive, seed 000 §4.2's
// [t0, t1]) that carry an annotation matching `filter`.
struct AnnotatedDataQuery {
  std::int64_t platform = 0;  // PlatformId of the sensor index
  std::int64_t from_ns = 0;
  std::int64_t to_ns = 0;
  LabelFilter filter;
};

struct AnnotatedDatum {
  std::int64_t data_id = 0;
  std::int64_t stamp_ns = 0;
  std::int64_t sensor = 0;

  friend bool operator==(const AnnotatedDatum&, const AnnotatedDatum&) = default;
};

// A datum linked to a node or edge by a "datum_link" annotation.
struct LinkedDatum {
  Uuid link;  // the datum_link annotation
  std::int64_t data_id = 0;
  std::int64_t stamp_ns = 0;

  friend bool operator==(const LinkedDatum&, const LinkedDatum&) = default;
};

class AnnotationStore {
 public:
  virtual ~AnnotationStore();
  AnnotationStore(const AnnotationStore&) = delete;
  AnnotationStore& operator=(const AnnotationStore&) = delete;

  // ---- bbox2d: create, read, update -------------------------------------------------------

  // Stores the annotation and its box atomically. REQUIRES: box.annotation is on a datum, a
  // node, an edge or a parent (exactly one, graph.h Validate) and its type is "bbox2d" (or
  // empty, which is taken as "bbox2d"); payload empty. The same annotation again is a no-op.
  void PutBox(const BoxAnnotation& box);
  BoxAnnotation GetBox(const Uuid& id);  // Error(kNotFound); Error(kInvalidArgument) if no box
  // Replaces the box of a stored bbox2d annotation (what it is on never changes).
  void UpdateBox(const Uuid& id, const BoundingBox2d& box);

  // ---- Any annotation ---------------------------------------------------------------------

  // Deletes the annotation, all annotations below it (children, their children, ...) and the
  // payload rows of all of them, atomically. Returns how many annotations went.
  // Error(kNotFound) for an unknown id.
  std::int64_t Delete(const Uuid& id);

  // Annotations directly on a datum, ordered by UUID.
  std::vector<Annotation> OnDatum(std::int64_t data_id);

  // ---- Compound queries -------------------------------------------------------------------

  // Seed 000 §4.2: the data of query.platform in [from_ns, to_ns] with an annotation labelled
  // filter.label (on the datum itself) that, when filter.child_label is set, has a direct
  // child labelled filter.child_label. Each datum once, ordered by stamp then data_id. Labels
  // come from every registered type with a label column. Error(kInvalidArgument) for an
  // empty label or to_ns < from_ns.
  std::vector<AnnotatedDatum> FindAnnotatedData(const AnnotatedDataQuery& query);

  // ---- Links between the map and the raw data (seed 000 §4.3.1) ---------------------------

  // Puts a "datum_link" annotation with id `link` on the node or edge `element` saying it
  // was built from datum `data_id`. Error(kIntegrity) if either end is not stored.
  void LinkToDatum(const Uuid& link, AnnotationTarget kind, const Uuid& element,
                   std::int64_t data_id);
  // The data linked to a node or edge, ordered by stamp then data_id.
  std::vector<LinkedDatum> DataLinkedTo(const Uuid& element);
  // The annotations on the data linked to a node or edge (one query): e.g. the boxes seen in
  // the image an experience was built from. Ordered by data_id, then UUID.
  std::vector<Annotation> AnnotationsOnDataLinkedTo(const Uuid& element);
  // The nodes and edges linked to a datum, as their datum_link annotations, ordered by UUID.
  std::vector<Annotation> LinksToDatum(std::int64_t data_id);

 protected:
  AnnotationStore() = default;

  // Backend primitives; the public methods have validated their arguments. Writes are atomic
  // (a savepoint inside the GraphStore's open Transaction, else a transaction of their own).
  virtual void DoPutBox(const BoxAnnotation& box) = 0;
  virtual std::optional<BoxAnnotation> DoFindBox(const Uuid& id) = 0;
  virtual std::optional<Annotation> DoFindAnnotation(const Uuid& id) = 0;
  // Returns the number of rows updated (0: no box for id).
  virtual int DoUpdateBox(const Uuid& id, const BoundingBox2d& box) = 0;
  virtual std::int64_t DoDelete(const Uuid& id) = 0;
  virtual std::vector<Annotation> DoOnDatum(std::int64_t data_id) = 0;
  virtual std::vector<AnnotatedDatum> DoFindAnnotatedData(const AnnotatedDataQuery& query) = 0;
  virtual void DoLinkToDatum(const Annotation& link, std::int64_t data_id) = 0;
  virtual std::vector<LinkedDatum> DoDataLinkedTo(const Uuid& element) = 0;
  virtual std::vector<Annotation> DoAnnotationsOnDataLinkedTo(const Uuid& element) = 0;
  virtual std::vector<Annotation> DoLinksToDatum(std::int64_t data_id) = 0;
};

}  // namespace fleetmap
