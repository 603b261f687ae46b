#include "fleet_edge_errors.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <span>
#include <vector>

#include "report_text.h"

namespace fleetmap {
namespace {

// The q-quantile of `sorted` by the nearest rank, NaN when empty.
double Quantile(std::span<const float> sorted, double q) {
  if (sorted.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto rank = static_cast<std::size_t>(std::ceil(q * static_cast<double>(sorted.size())));
  return sorted[std::clamp<std::size_t>(rank, 1, sorted.size()) - 1];
}

EdgeErrorSummary Summarise(std::vector<float> errors, const std::vector<float>& sigmas) {
  EdgeErrorSummary summary;
  std::size_t within = 0;
  for (std::size_t i = 0; i < errors.size() && i < sigmas.size(); ++i) {
    if (std::isnan(sigmas[i])) continue;
    ++summary.with_covariance;
    within += errors[i] <= 3.0f * sigmas[i] ? 1 : 0;
  }
  summary.within_3_sigma =
      summary.with_covariance == 0
          ? std::numeric_limits<double>::quiet_NaN()
          : static_cast<double>(within) / static_cast<double>(summary.with_covariance);
  std::sort(errors.begin(), errors.end());
  summary.edges = errors.size();
  summary.p50_m = Quantile(errors, 0.5);
  summary.p90_m = Quantile(errors, 0.9);
  summary.max_m = Quantile(errors, 1.0);
  return summary;
}

EdgeErrorSummary SummariseMap(const FleetExperimentResult& result, const std::string& map) {
  std::vector<float> errors, sigmas;
  for (const FleetEdgeErrors& e : result.edge_errors) {
    if (e.map != map) continue;
    errors.insert(errors.end(), e.errors_m.begin(), e.errors_m.end());
    sigmas.insert(sigmas.end(), e.sigmas_m.begin(), e.sigmas_m.end());
    sigmas.resize(errors.size(), std::numeric_limits<float>::quiet_NaN());
  }
  return Summarise(std::move(errors), sigmas);
}

constexpr const char* kMaps[] = {"single", "groups", "merged", "merge links"};

}  // namespace

EdgeErrorSummary SummariseEdgeErrors(const FleetExperimentResult& result, const std::string& map) {
  return SummariseMap(result, map);
}

void WriteEdgeErrorTable(std::ostringstream& md, const FleetExperimentResult& result) {
  if (result.edge_errors.empty()) return;
  md << "How well the edges between outings agree with the world (ground truth): per edge, the "
        "distance between the translation it carries and the true one, over every fold. The "
        "localiser composes these across experiences when it searches a neighbourhood.\n\n"
        "| map | edges between outings | p50 m | p90 m | max m | with a covariance | of those, "
        "within 3 sigma |\n|---|---|---|---|---|---|---|\n";
  for (const char* map : kMaps) {
    const EdgeErrorSummary s = SummariseEdgeErrors(result, map);
    const std::string name = std::string(map) == "single"   ? "single-agent"
                             : std::string(map) == "groups" ? "the groups' maps, before MERGE"
                             : std::string(map) == "merged" ? "merged (all)"
                                                            : "merged, MERGE's links only";
    md << "| " << name << " | " << s.edges << " | " << Fixed(s.p50_m, 3) << " | "
       << Fixed(s.p90_m, 3) << " | " << Fixed(s.max_m, 3) << " | " << s.with_covariance << " | "
       << Fixed(s.within_3_sigma, 3) << " |\n";
  }
  std::size_t links = 0, registered = 0, inconsistent = 0;
  for (const FleetBuild& build : result.builds) {
    links += build.links;
    registered += build.links_registered;
    inconsistent += build.links_inconsistent;
  }
  md << "\nMERGE made " << links << " links to the server map, " << registered
     << " of them by the frame's own registration against the node (the rest at the pose its "
        "replay composed, with that pose's uncertainty), and dropped "
     << inconsistent << " more than 3 sigma from their neighbours.\n\n";
}

std::string EdgeErrorCsv(const FleetExperimentResult& result) {
  std::ostringstream csv;
  csv << "fold,map,edges,p50_m,p90_m,max_m,with_covariance,within_3_sigma\n";
  for (const FleetEdgeErrors& e : result.edge_errors) {
    const EdgeErrorSummary s = Summarise(e.errors_m, e.sigmas_m);
    csv << e.fold << ',' << e.map << ',' << s.edges << ',' << Fixed(s.p50_m, 4) << ','
        << Fixed(s.p90_m, 4) << ',' << Fixed(s.max_m, 4) << ',' << s.with_covariance << ','
        << Fixed(s.within_3_sigma, 4) << '\n';
  }
  return csv.str();
}

}  // namespace fleetmap
