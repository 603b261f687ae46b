#include "merge_report_json.h"

#include <nlohmann/json.hpp>

#include "fleetmap/core/printable_text.h"

namespace fleetmap {

std::string MergeReportJson(const MergeReport& r) {
  nlohmann::ordered_json json;
  json["submitted_nodes"] = r.submitted_nodes;
  json["duplicate_nodes"] = r.duplicate_nodes;
  json["segments"] = r.segments;
  json["stretches"] = r.stretches;
  json["stretches_added"] = r.stretches_added;
  json["stretches_omitted"] = r.stretches_omitted;
  json["localised_ends_omitted"] = r.localised_ends_omitted;
  json["nodes_added"] = r.nodes_added;
  json["metric_edges_added"] = r.metric_edges_added;
  json["links_added"] = r.links_added;
  json["links_registered"] = r.links_registered;
  json["links_inconsistent"] = r.links_inconsistent;
  json["path_edges_added"] = r.path_edges_added;
  json["path_edges_dropped"] = r.path_edges_dropped;
  json["paths_added"] = r.paths_added;
  json["stand_ins"] = r.stand_ins;
  json["edges_unresolved"] = r.edges_unresolved;
  json["edges_to_hidden"] = r.edges_to_hidden;
  json["derived_edges"] = r.derived_edges;
  json["seconds"] = r.seconds;
  return JsonText(json);
}

}  // namespace fleetmap
