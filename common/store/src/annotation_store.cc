#include "fleetmap/store/annotation_store.h"

#include <array>
#include <cctype>
#include <cmath>

#include "fleetmap/core/error.h"

namespace fleetmap {

namespace {

constexpr std::array kBoxColumns{
    AnnotationColumn{"x_px", AnnotationColumnKind::kReal},
    AnnotationColumn{"y_px", AnnotationColumnKind::kReal},
    AnnotationColumn{"width_px", AnnotationColumnKind::kReal},
    AnnotationColumn{"height_px", AnnotationColumnKind::kReal},
    AnnotationColumn{"label", AnnotationColumnKind::kText},
    AnnotationColumn{"score", AnnotationColumnKind::kReal},
};
constexpr std::array kLinkColumns{
    AnnotationColumn{"data_id", AnnotationColumnKind::kInteger},
};
// Tables are created by migration 0004 (common/store/src/<backend>/migrations).
constexpr std::array kTypes{
    AnnotationType{kBoundingBox2dType, "annotation_bbox2d", kBoxColumns, "label"},
    AnnotationType{kDatumLinkType, "annotation_datum_link", kLinkColumns, ""},
};

[[noreturn]] void Invalid(const std::string& message) {
  throw Error(ErrorCode::kInvalidArgument, message);
}

// One "label=VALUE" term of a filter starting at `pos`; advances pos past it.
std::string ParseLabelTerm(std::string_view text, std::size_t& pos) {
  const auto quoted = "filter '" + std::string(text) + "'";
  constexpr std::string_view kKey = "label=";
  if (text.substr(pos, kKey.size()) != kKey) {
    Invalid(quoted + ": expected 'label=' at column " + std::to_string(pos + 1) +
            " (syntax: label=THETA [> label=PHI])");
  }
  pos += kKey.size();
  const std::size_t start = pos;
  while (pos < text.size() && !std::isspace(static_cast<unsigned char>(text[pos])) &&
         text[pos] != '>' && text[pos] != '=') {
    ++pos;
  }
  if (pos == start) {
    Invalid(quoted + ": empty label at column " + std::to_string(start + 1) +
            " (syntax: label=THETA [> label=PHI])");
  }
  return std::string(text.substr(start, pos - start));
}

void SkipSpaces(std::string_view text, std::size_t& pos) {
  while (pos < text.size() && std::isspace(static_cast<unsigned char>(text[pos]))) ++pos;
}

void RequireElement(AnnotationTarget kind, const char* what) {
  if (kind != AnnotationTarget::kNode && kind != AnnotationTarget::kEdge) {
    Invalid(std::string(what) + " needs a node or an edge");
  }
}

}  // namespace

std::span<const AnnotationType> AnnotationTypes() {
  return kTypes;
}

const AnnotationType* FindAnnotationType(std::string_view name) {
  for (const AnnotationType& type : kTypes) {
    if (type.name == name) return &type;
  }
  return nullptr;
}

void Validate(const BoundingBox2d& box) {
  for (const auto& [name, value] :
       {std::pair{"x", box.x_px}, std::pair{"y", box.y_px}, std::pair{"width", box.width_px},
        std::pair{"height", box.height_px}, std::pair{"score", box.score}}) {
    if (!std::isfinite(value)) Invalid(std::string("bbox2d: ") + name + " is not finite");
  }
  if (box.width_px <= 0 || box.height_px <= 0) {
    Invalid("bbox2d: width and height must be > 0 pixels (got " + std::to_string(box.width_px) +
            " x " + std::to_string(box.height_px) + ")");
  }
  if (box.label.empty()) Invalid("bbox2d: the label is empty");
  if (box.score < 0 || box.score > 1) {
    Invalid("bbox2d: score " + std::to_string(box.score) + " is outside [0, 1]");
  }
}

LabelFilter ParseLabelFilter(std::string_view text) {
  LabelFilter filter;
  std::size_t pos = 0;
  SkipSpaces(text, pos);
  filter.label = ParseLabelTerm(text, pos);
  SkipSpaces(text, pos);
  if (pos < text.size() && text[pos] == '>') {
    ++pos;
    SkipSpaces(text, pos);
    filter.child_label = ParseLabelTerm(text, pos);
    SkipSpaces(text, pos);
  }
  if (pos != text.size()) {
    Invalid("filter '" + std::string(text) + "': unexpected '" + std::string(text.substr(pos)) +
            "' at column " + std::to_string(pos + 1) +
            " (syntax: label=THETA [> label=PHI], one child level)");
  }
  return filter;
}

AnnotationStore::~AnnotationStore() = default;

void AnnotationStore::PutBox(const BoxAnnotation& box) {
  BoxAnnotation normalised = box;
  if (normalised.annotation.type.empty()) normalised.annotation.type = kBoundingBox2dType;
  const Annotation& a = normalised.annotation;
  Validate(a);
  if (a.type != kBoundingBox2dType) {
    Invalid("annotation " + a.id.ToString() + " has type '" + a.type + "', not 'bbox2d'");
  }
  if (!a.payload.empty()) {
    Invalid("annotation " + a.id.ToString() +
            ": a bbox2d keeps its box in its table; the "
            "opaque payload must be empty");
  }
  Validate(normalised.box);
  DoPutBox(normalised);
}

BoxAnnotation AnnotationStore::GetBox(const Uuid& id) {
  std::optional<BoxAnnotation> found = DoFindBox(id);
  if (!found) throw Error(ErrorCode::kNotFound, "no annotation " + id.ToString());
  return std::move(*found);
}

void AnnotationStore::UpdateBox(const Uuid& id, const BoundingBox2d& box) {
  Validate(box);
  if (DoUpdateBox(id, box) == 1) return;
  if (!DoFindAnnotation(id)) throw Error(ErrorCode::kNotFound, "no annotation " + id.ToString());
  Invalid("annotation " + id.ToString() + " is not a bbox2d");
}

std::int64_t AnnotationStore::Delete(const Uuid& id) {
  const std::int64_t deleted = DoDelete(id);
  if (deleted == 0) throw Error(ErrorCode::kNotFound, "no annotation " + id.ToString());
  return deleted;
}

std::vector<Annotation> AnnotationStore::OnDatum(std::int64_t data_id) {
  return DoOnDatum(data_id);
}

std::vector<AnnotatedDatum> AnnotationStore::FindAnnotatedData(const AnnotatedDataQuery& query) {
  if (query.filter.label.empty()) Invalid("annotated-data query: the label is empty");
  if (query.filter.child_label && query.filter.child_label->empty()) {
    Invalid("annotated-data query: the child label is empty");
  }
  if (query.to_ns < query.from_ns) {
    Invalid("annotated-data query: the window ends (" + std::to_string(query.to_ns) +
            " ns) before it starts (" + std::to_string(query.from_ns) + " ns)");
  }
  return DoFindAnnotatedData(query);
}

void AnnotationStore::LinkToDatum(const Uuid& link, AnnotationTarget kind, const Uuid& element,
                                  std::int64_t data_id) {
  RequireElement(kind, "a datum link");
  Annotation a;
  a.id = link;
  a.target_kind = kind;
  a.target = element;
  a.type = kDatumLinkType;
  Validate(a);
  if (data_id <= 0) Invalid("a datum link needs a data id > 0, got " + std::to_string(data_id));
  DoLinkToDatum(a, data_id);
}

std::vector<LinkedDatum> AnnotationStore::DataLinkedTo(const Uuid& element) {
  return DoDataLinkedTo(element);
}

std::vector<Annotation> AnnotationStore::AnnotationsOnDataLinkedTo(const Uuid& element) {
  return DoAnnotationsOnDataLinkedTo(element);
}

std::vector<Annotation> AnnotationStore::LinksToDatum(std::int64_t data_id) {
  return DoLinksToDatum(data_id);
}

}  // namespace fleetmap
