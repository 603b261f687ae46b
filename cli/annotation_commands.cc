// `fleetmap annotate bbox|rm` and `fleetmap query annotated`: annotations on raw sensor data
// and the compound query over them (annotation_store.h, seed 000 §4.2).
#include <cinttypes>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/store/annotation_store.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/sensor_index.h"
#include "repository_arguments.h"

namespace fleetmap::cli {

namespace {

struct BoxArgs {
  std::string store = kDefaultStore;
  std::optional<std::int64_t> datum;
  std::string parent;
  std::string id;
  BoundingBox2d box;
  bool json = false;
};

struct RemoveArgs {
  std::string store = kDefaultStore;
  std::string id;
  bool json = false;
};

struct AnnotatedQueryArgs {
  std::string store = kDefaultStore;
  std::string platform;
  std::int64_t from_ns = 0;
  std::int64_t to_ns = 0;
  std::string filter;
  bool json = false;
};

void RunBox(const BoxArgs& args) {
  if (args.datum.has_value() == !args.parent.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "annotate bbox: give exactly one of --datum ID and --parent ANNOTATION");
  }
  BoxAnnotation box;
  box.annotation.id = args.id.empty() ? Uuid::Generate() : ParseUuidArgument(args.id, "--id");
  box.annotation.type = kBoundingBox2dType;
  if (args.datum) {
    box.annotation.target_kind = AnnotationTarget::kDatum;
    box.annotation.data_id = *args.datum;
  } else {
    box.annotation.parent = ParseUuidArgument(args.parent, "--parent");
  }
  box.box = args.box;
  const std::unique_ptr<GraphStore> store = OpenRepositoryStore(args.store);
  store->annotations().PutBox(box);
  if (args.json) {
    nlohmann::ordered_json json;
    json["annotation"] = box.annotation.id.ToString();
    if (args.datum) {
      json["datum"] = *args.datum;
    } else {
      json["parent"] = box.annotation.parent.ToString();
    }
    json["label"] = box.box.label;
    json["score"] = box.box.score;
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("%s\n", box.annotation.id.ToString().c_str());
}

void RunRemove(const RemoveArgs& args) {
  const Uuid id = ParseUuidArgument(args.id, "annotation");
  const std::unique_ptr<GraphStore> store = OpenRepositoryStore(args.store);
  const std::int64_t deleted = store->annotations().Delete(id);
  if (args.json) {
    nlohmann::ordered_json json;
    json["annotation"] = id.ToString();
    json["deleted"] = deleted;
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("deleted %s and the annotations below it: %s in all\n", id.ToString().c_str(),
              Count(deleted, "annotation").c_str());
}

// A platform by name, or by its numeric id when no platform has that name.
PlatformId ResolvePlatform(GraphStore& store, const std::string& text) {
  if (std::optional<Platform> p = store.sensors().FindPlatform(text)) return p->id;
  try {
    std::size_t used = 0;
    const long long id = std::stoll(text, &used);
    if (used == text.size()) return store.sensors().GetPlatform(id).id;
  } catch (const std::logic_error&) {
    // not a number: fall through to the error naming the text
  }
  throw Error(ErrorCode::kNotFound,
              "--platform '" + text + "': no such platform in " + store.uri());
}

void RunQuery(const AnnotatedQueryArgs& args) {
  // The filter first: a typo is reported before any store is touched.
  AnnotatedDataQuery query;
  query.filter = ParseLabelFilter(args.filter);
  query.from_ns = args.from_ns;
  query.to_ns = args.to_ns;
  const std::unique_ptr<GraphStore> store = OpenRepositoryStore(args.store);
  query.platform = ResolvePlatform(*store, args.platform);
  const std::vector<AnnotatedDatum> data = store->annotations().FindAnnotatedData(query);
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const AnnotatedDatum& d : data) {
      nlohmann::ordered_json entry;
      entry["data_id"] = d.data_id;
      entry["stamp_ns"] = d.stamp_ns;
      entry["sensor"] = d.sensor;
      list.push_back(entry);
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (data.empty()) {
    std::printf("no data of platform %s in [%" PRId64 ", %" PRId64 "] match '%s'\n",
                args.platform.c_str(), args.from_ns, args.to_ns, args.filter.c_str());
    return;
  }
  std::printf("%-12s  %-20s  %-20s  %s\n", "DATA ID", "STAMP NS", "UTC", "SENSOR");
  for (const AnnotatedDatum& d : data) {
    std::printf("%-12" PRId64 "  %-20" PRId64 "  %-20s  %" PRId64 "\n", d.data_id, d.stamp_ns,
                FormatUtc(d.stamp_ns).c_str(), d.sensor);
  }
  std::printf("%s\n", Count(static_cast<std::int64_t>(data.size()), "datum", "data").c_str());
}

}  // namespace

void AddAnnotationCommands(CLI::App& app) {
  CLI::App* annotate =
      app.add_subcommand("annotate", "Annotations on raw sensor data (seed 000 §4.2)");
  annotate->require_subcommand(1);

  auto box_args = std::make_shared<BoxArgs>();
  CLI::App* bbox = annotate->add_subcommand(
      "bbox", "Put a 2-D bounding box (pixels, label, score) on a datum or a parent annotation");
  AddStoreOption(*bbox, box_args->store);
  bbox->add_option("--datum", box_args->datum, "Data id of the annotated datum");
  bbox->add_option("--parent", box_args->parent, "UUID of the parent annotation");
  bbox->add_option("--id", box_args->id, "UUID of the new annotation (default: a new one)");
  bbox->add_option("--x", box_args->box.x_px, "Left edge, pixels")->required();
  bbox->add_option("--y", box_args->box.y_px, "Top edge, pixels")->required();
  bbox->add_option("--w", box_args->box.width_px, "Width, pixels (> 0)")->required();
  bbox->add_option("--h", box_args->box.height_px, "Height, pixels (> 0)")->required();
  bbox->add_option("--label", box_args->box.label, "Label, e.g. car")->required();
  bbox->add_option("--score", box_args->box.score, "Detector score in [0, 1]")->required();
  bbox->add_flag("--json", box_args->json, "Print JSON");
  bbox->footer("Prints the new annotation's UUID.");
  bbox->callback([box_args] { RunBox(*box_args); });

  auto rm_args = std::make_shared<RemoveArgs>();
  CLI::App* rm = annotate->add_subcommand(
      "rm", "Delete an annotation with every annotation below it and their payloads");
  AddStoreOption(*rm, rm_args->store);
  rm->add_option("id", rm_args->id, "UUID of the annotation")->required();
  rm->add_flag("--json", rm_args->json, "Print JSON");
  rm->callback([rm_args] { RunRemove(*rm_args); });

  // `query` is shared with the sensor-index queries; whichever registers first creates it.
  // (CLI11 2.1 has no get_subcommand_no_throw, so look it up by name.)
  const std::vector<CLI::App*> found =
      app.get_subcommands([](CLI::App* sub) { return sub->get_name() == "query"; });
  CLI::App* query =
      found.empty() ? app.add_subcommand("query", "Query raw sensor data") : found.front();
  auto query_args = std::make_shared<AnnotatedQueryArgs>();
  CLI::App* annotated = query->add_subcommand(
      "annotated", "Data of a platform in a time window carrying annotations with given labels");
  AddStoreOption(*annotated, query_args->store);
  annotated->add_option("--platform", query_args->platform, "Platform name (or id)")->required();
  annotated->add_option("--from", query_args->from_ns, "Window start, UTC ns (inclusive)")
      ->required();
  annotated->add_option("--to", query_args->to_ns, "Window end, UTC ns (inclusive)")->required();
  annotated
      ->add_option("--filter", query_args->filter,
                   "label=THETA, or label=THETA > label=PHI for a child annotation labelled PHI")
      ->required();
  annotated->add_flag("--json", query_args->json, "Print JSON");
  annotated->footer(
      "Filter syntax: 'label=car' matches data with an annotation labelled car; "
      "'label=car > label=wheel' those whose car annotation has a direct child labelled wheel.");
  annotated->callback([query_args] { RunQuery(*query_args); });
}

}  // namespace fleetmap::cli
