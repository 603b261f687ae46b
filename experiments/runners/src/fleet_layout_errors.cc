#include "fleet_layout_errors.h"

#include <algorithm>
#include <cstddef>
#include <vector>

#include "report_text.h"

namespace fleetmap {
namespace {

const FleetLayoutError* Find(const FleetExperimentResult& result, int fold, const std::string& map,
                             const std::string& layout) {
  for (const FleetLayoutError& e : result.layout_errors) {
    if (e.fold == fold && e.map == map && e.layout == layout) return &e;
  }
  return nullptr;
}

}  // namespace

void WriteLayoutErrorTable(std::ostringstream& md, const FleetExperimentResult& result) {
  if (result.layout_errors.empty()) return;
  md << "Where the map's layouts put its nodes (fleetmap render and export): the largest "
        "component's node positions against where they were captured, aligned by the best rigid "
        "motion. Medians over the folds.\n\n"
        "| map | layout | nodes | RMS error m | largest error m | seconds | folds where relaxed "
        "is nearer |\n|---|---|---|---|---|---|---|\n";
  for (const std::string map : {"single", "merged"}) {
    for (const std::string layout : {"composed", "relaxed"}) {
      std::vector<double> rms, largest, seconds, nodes;
      int nearer = 0, folds = 0;
      for (const FleetLayoutError& e : result.layout_errors) {
        if (e.map != map || e.layout != layout) continue;
        rms.push_back(e.ate_rmse_m);
        largest.push_back(e.max_m);
        seconds.push_back(e.seconds);
        nodes.push_back(static_cast<double>(e.nodes));
        const FleetLayoutError* composed = Find(result, e.fold, map, "composed");
        const FleetLayoutError* relaxed = Find(result, e.fold, map, "relaxed");
        if (composed && relaxed) {
          ++folds;
          if (relaxed->ate_rmse_m < composed->ate_rmse_m) ++nearer;
        }
      }
      if (rms.empty()) continue;
      md << "| " << (map == "single" ? "single-agent" : "merged") << " | " << layout << " | "
         << Fixed(Median(nodes), 0) << " | " << Fixed(Median(rms), 3) << " | "
         << Fixed(Median(largest), 3) << " | " << Fixed(Median(seconds), 3) << " | "
         << (layout == "relaxed" ? std::to_string(nearer) + " of " + std::to_string(folds) : "")
         << " |\n";
    }
  }
  md << "\n";
}

std::string LayoutErrorCsv(const FleetExperimentResult& result) {
  std::ostringstream csv;
  csv << "fold,map,layout,nodes,ate_rmse_m,max_m,seconds\n";
  for (const FleetLayoutError& e : result.layout_errors) {
    csv << e.fold << ',' << e.map << ',' << e.layout << ',' << e.nodes << ','
        << Fixed(e.ate_rmse_m, 4) << ',' << Fixed(e.max_m, 4) << ',' << Fixed(e.seconds, 4) << '\n';
  }
  return csv.str();
}

}  // namespace fleetmap
