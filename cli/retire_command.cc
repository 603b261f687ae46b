// `fleetmap retire`: hides the experiences nobody has localised against for a stated time (as
// MERGE measured it: its replays and the robots' path memory), where the place holds others
// (Repository::Retire, retirement.h), as a new revision that `fleetmap revert` undoes whole.
// --dry-run shows the plan and writes nothing.
#include <cmath>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/repository/retirement.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

// Longer than any fleet keeps a map, and far from overflowing nanoseconds (292 years).
constexpr double kMaxRetireAfterDays = 36'500.0;

struct RetireArgs {
  std::string store;
  double retire_after_days = 14.0;
  double place_radius_m = RetireOptions{}.place_radius_m;
  std::string now;  // empty: the map's own clock
  bool dry_run = false;
  bool json = false;
  std::string author;
};

RetireOptions OptionsOf(const RetireArgs& args) {
  RetireOptions options;
  options.retire_after_ns = std::llround(args.retire_after_days * kNanosecondsPerDay);
  options.place_radius_m = args.place_radius_m;
  if (!args.now.empty()) options.now_ns = ParseUtcTime(args.now, "--now");
  return options;
}

// Why the candidates that stay, stay: "2 the last of their place, 1 joining the map, ...".
std::string KeptText(const RetirementPlan& plan) {
  return std::to_string(plan.kept_last_of_place) + " the last of their place, " +
         std::to_string(plan.kept_joins_map) + " joining the map, " +
         std::to_string(plan.kept_for_submissions) + " named by unmerged submissions";
}

void PrintClock(const RetirementPlan& plan, bool clock_given) {
  std::printf("  map clock %s (%s); unused since %s makes a candidate\n",
              FormatUtc(plan.now_ns).c_str(), clock_given ? "--now" : "the newest stamp seen",
              FormatUtc(plan.cutoff_ns).c_str());
  std::printf("  %s visible, %s; kept: %s\n",
              Count(static_cast<std::int64_t>(plan.visible_nodes), "node").c_str(),
              Count(static_cast<std::int64_t>(plan.candidates), "candidate").c_str(),
              KeptText(plan).c_str());
}

// Each node the plan hides: why it may go (last used, frames) and what keeps its place.
void PrintRetired(const RetirementPlan& plan) {
  if (plan.retire.empty()) return;
  std::printf("  %-36s  %-20s  %8s  %-36s  %s\n", "NODE", "LAST USED (UTC)", "FRAMES",
              "PLACE HELD BY", "AT");
  for (const RetiredNode& node : plan.retire) {
    std::printf("  %-36s  %-20s  %8lld  %-36s  %.1f m\n", node.node.ToString().c_str(),
                FormatUtc(node.last_used_ns).c_str(), static_cast<long long>(node.frames),
                node.held_by.ToString().c_str(), node.held_by_m);
  }
}

nlohmann::ordered_json PlanJson(const RetirementPlan& plan) {
  return nlohmann::ordered_json::parse(RetirementPlanJson(plan));
}

void RunDryRun(Repository& repository, const RetireOptions& options, const RetireArgs& args) {
  const RetirementPlan plan = repository.PlanRetirement(options);
  if (args.json) {
    nlohmann::ordered_json json;
    json["dry_run"] = true;
    json["plan"] = PlanJson(plan);
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("dry run on revision %lld of %s: %s would be retired (nothing written)\n",
              static_cast<long long>(plan.head), repository.uri().c_str(),
              Count(static_cast<std::int64_t>(plan.retire.size()), "node").c_str());
  PrintClock(plan, options.now_ns.has_value());
  PrintRetired(plan);
}

// Retire on the head; a writer that appended first (a merge) makes it plan once more on the new
// head, as the user would by hand.
std::optional<Revision> RetireOnHead(Repository& repository, const RetireOptions& options,
                                     const std::string& author) {
  try {
    return repository.Retire(options, author);
  } catch (const Error& error) {
    if (error.code() != ErrorCode::kConflict) throw;
  }
  return repository.Retire(options, author);
}

void RunRetire(const RetireArgs& args) {
  const RetireOptions options = OptionsOf(args);
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  if (args.dry_run) {
    RunDryRun(*repository, options, args);
    return;
  }
  std::optional<Revision> revision;
  try {
    revision =
        RetireOnHead(*repository, options, args.author.empty() ? DefaultAuthor() : args.author);
  } catch (const Error& error) {
    throw InContext(error, "cannot retire");
  }
  // With nothing retired there is no report: the plan again says why everything stayed.
  const RetirementPlan plan = revision ? RetirementPlan{} : repository->PlanRetirement(options);
  if (args.json) {
    nlohmann::ordered_json json;
    json["dry_run"] = false;
    json["revision"] = revision ? nlohmann::ordered_json(revision->number) : nullptr;
    json["hidden"] = {{"nodes", revision ? revision->nodes_hidden : 0},
                      {"edges", revision ? revision->edges_hidden : 0},
                      {"paths", revision ? revision->paths_hidden : 0}};
    if (revision) {
      // The report as stored: the plan as JSON, or its text should it not read as JSON.
      const nlohmann::ordered_json report =
          nlohmann::ordered_json::parse(revision->report, nullptr, /*allow_exceptions=*/false);
      json["plan"] = report.is_discarded() ? nlohmann::ordered_json(revision->report) : report;
    } else {
      json["plan"] = PlanJson(plan);
    }
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  if (!revision) {
    std::printf("nothing to retire at revision %lld of %s\n", static_cast<long long>(plan.head),
                repository->uri().c_str());
    PrintClock(plan, options.now_ns.has_value());
    return;
  }
  std::printf("revision %lld retires %s (author %s)\n", static_cast<long long>(revision->number),
              Count(revision->nodes_hidden, "node").c_str(),
              PrintableText(revision->author).c_str());
  std::printf(
      "  hid %s, %s, %s; nothing is deleted: `fleetmap revert %lld` restores them\n",
      Count(revision->nodes_hidden, "node").c_str(), Count(revision->edges_hidden, "edge").c_str(),
      Count(revision->paths_hidden, "path").c_str(), static_cast<long long>(revision->number));
}

}  // namespace

void AddRetireCommand(CLI::App& app) {
  auto args = std::make_shared<RetireArgs>();
  CLI::App* retire = app.add_subcommand(
      "retire", "Hide experiences unused for a while where their place holds others");
  retire->footer(
      "Makes a new revision (kind retire) hiding the nodes nobody has localised against (MERGE's "
      "replays, robots' path memory) "
      "since the map's clock minus --retire-after (the clock: the newest stamp the map has seen, "
      "or --now), with every edge that ends at one. A node stays when it is the last experience "
      "of its place (no other outing's node that stays lies within --place-radius, along "
      "metric edges), when its going would cut the map apart, or when a robot's unmerged "
      "submission names it. Channels pinned to earlier revisions keep what they held. Nothing "
      "is deleted: `fleetmap revert N` restores exactly what revision N hid. --dry-run prints "
      "each node that would go (last used, frames, the experience that holds its place and how "
      "far) and why the other candidates stay, and writes nothing.");
  AddStoreOption(*retire, args->store);
  retire
      ->add_option("--retire-after", args->retire_after_days,
                   "Days unused (fractions allowed, above 0) that make a node a candidate")
      ->capture_default_str()
      ->check(CLI::PositiveNumber)
      ->check(CLI::Range(0.0, kMaxRetireAfterDays));
  retire
      ->add_option("--place-radius", args->place_radius_m,
                   "Metres within which another experience holds a node's place")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  retire->add_option("--now", args->now,
                     "The clock to measure from: UTC ns or ISO 8601 like 2024-05-01T08:30:00Z "
                     "(default: the newest stamp the map has seen)");
  retire->add_flag("--dry-run", args->dry_run,
                   "Print what would be retired and why; write nothing");
  retire->add_flag("--json", args->json, "Print JSON (the plan as the revision's report holds it)");
  retire->add_option("--author", args->author, "Who retires (default: $USER)");
  retire->callback([args] { RunRetire(*args); });
}

}  // namespace fleetmap::cli
