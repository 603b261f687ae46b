// `fleetmap download`: DOWNLOAD (seed 004 §V-B), the part of a revision a robot takes on its
// next mission, chosen by a policy (copy, tod, paths, budget and their combinations), written
// into a new store for the robot.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/map_management/download_policy.h"
#include "fleetmap/map_management/download_route.h"
#include "new_store.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

struct DownloadArgs {
  std::string store;
  std::string policy;
  std::string mission_start;
  std::string mission_end;
  double window_min = 0.0;  // 0: the policy's own (ParseDownloadPolicy)
  double epoch_min = 60.0;
  double percent = 50.0;
  std::optional<std::int64_t> budget_bytes;
  CoverageOptions coverage;
  std::optional<RevisionNumber> revision;
  std::string route;  // download_route.h RouteOfArgument
  double route_radius_m = 0.0;
  std::string out;
  bool json = false;
};

// The policy and its parameters, each checked against the option that set it, then read as a
// robot's request is (PolicyOfRequest: the same defaults), plus what only a local selection
// takes: the mission's end and the coverage's stretches.
DownloadPolicy PolicyOf(const DownloadArgs& args) {
  const auto fail = [](const std::string& message) {
    throw Error(ErrorCode::kInvalidArgument, message);
  };
  if (!(std::isfinite(args.window_min) && args.window_min >= 0)) {
    fail(
        "--window-min (T_w of Eq. 4) must be a positive number of minutes (0: the policy's "
        "default), not " +
        std::to_string(args.window_min));
  }
  if (!(args.epoch_min > 0 && args.epoch_min <= 1440)) {
    fail("--epoch-min (Δt of Eq. 5) must be in (0, 1440] minutes, not " +
         std::to_string(args.epoch_min));
  }
  if (!(args.percent > 0 && args.percent <= 100)) {
    fail("--percent (p of Algorithm 3) must be in (0, 100], not " + std::to_string(args.percent));
  }
  if (args.budget_bytes && *args.budget_bytes <= 0) {
    fail("--budget-bytes must be > 0, not " + std::to_string(*args.budget_bytes));
  }
  DownloadParams params;
  params.policy = args.policy;
  if (!args.mission_start.empty()) {
    params.mission_start_min = ParseTimeOfDay(args.mission_start, "--mission-start");
  }
  params.window_min = args.window_min;
  params.epoch_min = args.epoch_min;
  params.best_percent = args.percent;
  params.budget_bytes = args.budget_bytes.value_or(0);
  if (!args.route.empty()) {
    SetRequestRoute(params, RouteOfArgument(args.route, args.route_radius_m), args.route_radius_m);
  }
  DownloadPolicy policy = PolicyOfRequest(params);
  const bool copy = !policy.time_of_day && !policy.paths && !policy.cover && !policy.budget_bytes;
  if (args.mission_start.empty() && !copy) {
    fail("--mission-start HH:MM is required for policy \"" + policy.Name() +
         "\" (only \"copy\" ignores the mission time)");
  }
  if (args.budget_bytes && !policy.budget_bytes) {
    fail("--budget-bytes needs a policy with \"budget\" (e.g. tod+budget), not \"" + policy.Name() +
         "\"");
  }
  if (!args.mission_end.empty()) {
    policy.mission_end_min = ParseTimeOfDay(args.mission_end, "--mission-end");
  }
  policy.coverage = args.coverage;
  ValidateDownloadPolicy(policy);
  return policy;
}

std::string ClockTime(double minutes) {
  char text[16];
  const int m = static_cast<int>(std::lround(minutes)) % 1440;
  std::snprintf(text, sizeof text, "%02d:%02d", m / 60, m % 60);
  return text;
}

double Percent(double part, double whole) {
  return whole > 0 ? 100.0 * part / whole : 0.0;
}

// Landmark bytes of the download and of the whole map. DownloadReport counts them from the nodes
// SelectDownload weighed, which Repository::SelectForDownload reads without landmarks unless a
// budget needs them (so the report says 0 then); these are counted from what is sent and stored.
struct Bytes {
  std::int64_t download = 0, map = 0;
};

void PrintReport(const Download& download, const DownloadPolicy& policy, const DownloadArgs& args,
                 const std::string& store_uri, const Bytes& bytes) {
  const DownloadReport& r = download.report;
  const IntegrityReport& integrity = r.integrity;
  if (args.json) {
    nlohmann::ordered_json json;
    json["revision"] = download.revision;
    json["out"] = args.out;
    json["policy"] = r.policy;
    json["mission_start"] = ClockTime(policy.mission_start_min);
    if (policy.mission_end_min) json["mission_end"] = ClockTime(*policy.mission_end_min);
    json["window_min"] = policy.window_min;
    json["epoch_min"] = policy.epoch_min;
    json["best_percent"] = policy.best_percent;
    if (policy.budget_bytes) json["budget_bytes"] = *policy.budget_bytes;
    if (policy.cover) {
      json["cover_k"] = policy.coverage.experiences;
      json["cover_cap"] = policy.coverage.most_experiences;
      json["cover_stretch_m"] = policy.coverage.stretch_m;
      json["stretches"] = r.stretches;
      json["stretches_reached_outside"] = r.stretches_reached_outside;
    }
    json["map_nodes"] = r.map_nodes;
    json["picked_nodes"] = r.picked_nodes;
    json["bridging_nodes"] = integrity.bridging_nodes;
    json["nodes"] = r.nodes;
    json["edges"] = r.edges;
    json["paths"] = r.paths;
    json["map_bytes"] = bytes.map;
    json["bytes"] = bytes.download;
    json["paths_chosen"] = r.paths_chosen;
    json["epoch_start"] = r.epoch_start ? nlohmann::ordered_json(*r.epoch_start) : nullptr;
    json["epoch_end"] = r.epoch_end ? nlohmann::ordered_json(*r.epoch_end) : nullptr;
    json["map_components"] = integrity.map_components;
    json["touched_components"] = integrity.touched_components;
    json["fragments_before"] = integrity.fragments_before;
    json["components_after"] = integrity.components_after;
    if (policy.route) {
      json["corridor_nodes"] = r.corridor_nodes;
      json["route_length_m"] = r.route_length_m;
      json["route_covered_m"] = r.route_covered_m;
    }
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("download \"%s\" of revision %lld of %s into %s\n", r.policy.c_str(),
              static_cast<long long>(download.revision), store_uri.c_str(), args.out.c_str());
  if (policy.time_of_day || policy.paths || policy.cover || policy.budget_bytes) {
    std::printf("  mission    starts %s UTC", ClockTime(policy.mission_start_min).c_str());
    if (policy.mission_end_min)
      std::printf(", ends %s", ClockTime(*policy.mission_end_min).c_str());
    if (policy.time_of_day) std::printf("; T_w %.0f min", policy.window_min);
    if (policy.paths || policy.budget_bytes) {
      std::printf("; epochs of %.0f min", policy.epoch_min);
    }
    if (policy.paths) std::printf("; best %.0f %% of paths", policy.best_percent);
    if (policy.budget_bytes) {
      std::printf("; budget %lld bytes", static_cast<long long>(*policy.budget_bytes));
    }
    std::printf("\n");
  }
  if (policy.cover) {
    std::printf(
        "  coverage   %d experience(s) kept in each of %zu stretches of %.0f m; %zu reached "
        "outside what the other parts allow\n",
        policy.coverage.experiences, r.stretches, policy.coverage.stretch_m,
        r.stretches_reached_outside);
  }
  std::printf("  nodes      %zu picked + %zu bridging = %zu of %zu map nodes (%.1f %%)\n",
              r.picked_nodes, integrity.bridging_nodes, r.nodes, r.map_nodes,
              Percent(static_cast<double>(r.nodes), static_cast<double>(r.map_nodes)));
  std::printf("  edges      %zu\n  paths      %zu\n", r.edges, r.paths);
  std::printf("  bytes      %lld of %lld map landmark bytes (%.1f %%)\n",
              static_cast<long long>(bytes.download), static_cast<long long>(bytes.map),
              Percent(static_cast<double>(bytes.download), static_cast<double>(bytes.map)));
  if (policy.paths) {
    std::printf(policy.cover ? "  P*         %s driven within the window, the best share"
                             : "  P*         %s chosen by Algorithm 3",
                Count(static_cast<std::int64_t>(r.paths_chosen), "path").c_str());
    if (r.epoch_start && r.epoch_end) {
      std::printf(" over epochs %d..%d%s\n", *r.epoch_start, *r.epoch_end,
                  *r.epoch_start > *r.epoch_end ? " (across midnight)" : "");
    } else {
      std::printf("; no epochs with path data\n");
    }
  } else if (policy.budget_bytes && r.epoch_start && r.epoch_end) {
    std::printf("  epochs     %d..%d weigh the paths\n", *r.epoch_start, *r.epoch_end);
  }
  if (policy.route) {
    std::printf(
        "  route      %.0f m, corridor of %.0f m holds %zu nodes; %.1f %% of the route has "
        "a node within 5 m in the download\n",
        r.route_length_m, policy.route->radius_m, r.corridor_nodes,
        r.route_length_m > 0 ? 100.0 * r.route_covered_m / r.route_length_m : 0.0);
  }
  std::printf("  components %zu of %zu in the map touched; the picks fell in %s, joined into %zu\n",
              integrity.touched_components, integrity.map_components,
              Count(static_cast<std::int64_t>(integrity.fragments_before), "fragment").c_str(),
              integrity.components_after);
}

void RunDownload(const DownloadArgs& args) {
  const DownloadPolicy policy = PolicyOf(args);
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  if (args.revision) RequireRevision(*repository, *args.revision);
  RequireNewStore(args.out, "--out");
  const Download download = repository->SelectForDownload(policy, args.revision);
  Bytes bytes;
  bytes.map = repository->inspect().StatsAt(download.revision).landmark_bytes;
  bytes.download = WriteNewStore(args.out, "--out", download.map).landmark_bytes;
  PrintReport(download, policy, args, repository->uri(), bytes);
}

}  // namespace

void AddDownloadCommand(CLI::App& app) {
  auto args = std::make_shared<DownloadArgs>();
  CLI::App* download =
      app.add_subcommand("download", "Write a mission's part of a revision into a new store");
  download->footer(
      "DOWNLOAD (seed 004 §V-B): the part of a revision a robot needs for its next mission, "
      "written into a new store. Policies: copy (the whole map, Eq. 3); tod (nodes captured within "
      "T_w "
      "of the mission start on the 24-hour clock, Eq. 4); paths (nodes on the best p % of the "
      "paths of each of the mission's epochs, Algorithms 2-3, Eq. 7); budget (filled path by "
      "path up to a byte budget); joined with '+', e.g. tod+paths. The download is always "
      "integral: picked nodes are joined by the nodes between them. Mission times are UTC, " +
      std::string(kTimeOfDayGrammar) + "; the budget counts landmark bytes.");
  AddStoreOption(*download, args->store);
  download
      ->add_option("--policy", args->policy,
                   "copy, tod, paths, cover, budget, or parts joined with '+' (tod+paths, "
                   "tod+cover, tod+paths+cover, tod+budget, ...). cover keeps in every stretch of "
                   "the map its k experiences most likely to localise at the mission's time, "
                   "even outside the window; with it tod also keeps what robots used "
                   "within the window")
      ->required();
  download->add_option("--mission-start", args->mission_start,
                       "Mission start (t_foray), UTC, " + std::string(kTimeOfDayGrammar) +
                           "; required unless the policy is copy");
  download->add_option("--mission-end", args->mission_end,
                       "Mission end, UTC, " + std::string(kTimeOfDayGrammar) +
                           "; for paths without tod (default: the last epoch with data)");
  download
      ->add_option("--window-min", args->window_min,
                   "T_w of Eq. 4, minutes (0, the default: 120 with cover, else 180)")
      ->capture_default_str();
  download->add_option("--epoch-min", args->epoch_min, "Δt of Eq. 5, minutes")
      ->capture_default_str();
  download->add_option("--percent", args->percent, "p of Algorithm 3: best paths per epoch, %")
      ->capture_default_str();
  download->add_option("--budget-bytes", args->budget_bytes,
                       "Landmark byte budget for a policy with budget (default 256 MiB)");
  download
      ->add_option("--cover-k", args->coverage.experiences,
                   "cover: experiences every stretch keeps")
      ->capture_default_str();
  download
      ->add_option("--cover-cap", args->coverage.most_experiences,
                   "cover: most experiences a stretch keeps (0: no cap)")
      ->capture_default_str();
  download
      ->add_option("--cover-stretch-m", args->coverage.stretch_m,
                   "cover: length of a stretch, metres")
      ->capture_default_str();
  download->add_option("--revision", args->revision, "Revision (default: the head)");
  download->add_option("--route", args->route,
                       "Only the map within --route-radius of a route: an earlier outing's UUID, "
                       "or a file (or ';'-separated text) of `anchor NODE-UUID` then `x y z` "
                       "lines, metres in that node's frame");
  download->add_option("--route-radius", args->route_radius_m,
                       "Metres either side of --route (0: 10 m)");
  download->add_option("--out", args->out, "The new store for the robot (must hold no map yet)")
      ->required();
  download->add_flag("--json", args->json, "Print the report as JSON");
  download->callback([args] { RunDownload(*args); });
}

}  // namespace fleetmap::cli
