// `fleetmap info STORE` and `fleetmap doctor STORE`: what a map store holds,
// and what is wrong with it (store_facts.h, store_diagnosis.h). Both open the store read-only,
// so neither can change what they look at.
#include <CLI/CLI.hpp>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "commands.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/store/graph_store.h"
#include "fleetmap/store/store_diagnosis.h"
#include "fleetmap/store/store_facts.h"
#include "repository_arguments.h"

namespace fleetmap::cli {

namespace {

struct InspectArgs {
  std::string store = kDefaultStore;
  bool json = false;
  double receiving_stuck_h = 24.0;
  double queued_stuck_h = 1.0;
};

// A store as typed: a URI, or a bare path meaning an SQLite file.
std::string StoreUri(const std::string& text) {
  if (text.find(':') == std::string::npos) return "sqlite:" + text;
  return text;
}

std::unique_ptr<GraphStore> OpenForReading(const std::string& text) {
  StoreOptions options;
  options.read_only = true;
  const std::string uri = StoreUri(text);
  try {
    return GraphStore::Open(uri, options);
  } catch (const Error& e) {
    throw InContext(e, "cannot open " + uri);
  }
}

void RunInfo(const InspectArgs& args) {
  const std::unique_ptr<GraphStore> store = OpenForReading(args.store);
  const StoreFacts f = DescribeStore(*store);
  if (args.json) {
    nlohmann::ordered_json out;
    out["store"] = f.uri;
    out["engine"] = f.engine;
    out["schema_version"] = f.schema_version;
    out["bytes_on_disk"] = f.bytes_on_disk;
    out["stored"] = {{"nodes", f.stored.nodes},
                     {"edges", f.stored.edges},
                     {"paths", f.stored.paths},
                     {"annotations", f.stored.annotations},
                     {"landmark_bytes", f.stored.landmark_bytes}};
    out["head"] = f.head;
    out["at_head"] = {{"nodes", f.at_head.nodes},
                      {"edges", f.at_head.edges},
                      {"paths", f.at_head.paths},
                      {"landmark_bytes", f.at_head.landmark_bytes}};
    if (f.last_revision) {
      out["last_revision"] = {{"revision", f.last_revision->number},
                              {"time", FormatUtc(f.last_revision->created_ns)},
                              {"author", f.last_revision->author}};
    }
    out["submissions"] = f.submissions;
    out["oldest"] = f.oldest_ns ? nlohmann::ordered_json(FormatUtc(*f.oldest_ns)) : nullptr;
    out["newest"] = f.newest_ns ? nlohmann::ordered_json(FormatUtc(*f.newest_ns)) : nullptr;
    nlohmann::ordered_json robots = nlohmann::ordered_json::array();
    for (const RobotNodes& r : f.robots) {
      robots.push_back({{"robot", r.robot.ToString()},
                        {"nodes", r.nodes},
                        {"oldest", FormatUtc(r.oldest_ns)},
                        {"newest", FormatUtc(r.newest_ns)}});
    }
    out["robots"] = robots;
    std::cout << JsonText(out, 2) << "\n";
    return;
  }
  std::printf("store         %s\n", f.uri.c_str());
  std::printf("engine        %s, schema version %d\n", f.engine.c_str(), f.schema_version);
  std::printf("on disk       %s\n", BytesText(static_cast<std::uint64_t>(f.bytes_on_disk)).c_str());
  std::printf("stored        %s, %s, %s, %s; %s of landmarks\n",
              Count(f.stored.nodes, "node").c_str(), Count(f.stored.edges, "edge").c_str(),
              Count(f.stored.paths, "path").c_str(),
              Count(f.stored.annotations, "annotation").c_str(),
              BytesText(static_cast<std::uint64_t>(f.stored.landmark_bytes)).c_str());
  if (f.last_revision) {
    std::printf("head          revision %lld (%s by %s): %s, %s, %s\n",
                static_cast<long long>(f.head), FormatUtc(f.last_revision->created_ns).c_str(),
                f.last_revision->author.c_str(), Count(f.at_head.nodes, "node").c_str(),
                Count(f.at_head.edges, "edge").c_str(), Count(f.at_head.paths, "path").c_str());
  } else {
    std::printf("head          no revisions yet\n");
  }
  std::string submissions;
  for (const auto& [state, n] : f.submissions) {
    submissions += (submissions.empty() ? "" : ", ") + std::to_string(n) + " " + state;
  }
  std::printf("submissions   %s\n", submissions.empty() ? "none" : submissions.c_str());
  if (f.oldest_ns) {
    std::printf("stamps        %s to %s\n", FormatUtc(*f.oldest_ns).c_str(),
                FormatUtc(*f.newest_ns).c_str());
  }
  std::printf("robots        %zu\n", f.robots.size());
  for (const RobotNodes& r : f.robots) {
    std::printf("  %s  %s, %s to %s\n", r.robot.ToString().c_str(), Count(r.nodes, "node").c_str(),
                FormatUtc(r.oldest_ns).c_str(), FormatUtc(r.newest_ns).c_str());
  }
}

void RunDoctor(const InspectArgs& args) {
  const std::unique_ptr<GraphStore> store = OpenForReading(args.store);
  DiagnosisOptions options;
  options.now_ns = WallClockNs();
  options.receiving_stuck_after =
      std::chrono::minutes(static_cast<std::int64_t>(args.receiving_stuck_h * 60.0));
  options.queued_stuck_after =
      std::chrono::minutes(static_cast<std::int64_t>(args.queued_stuck_h * 60.0));
  const std::vector<StoreProblem> problems = DiagnoseStore(*store, options);
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const StoreProblem& p : problems) {
      list.push_back({{"check", p.check}, {"what", p.what}, {"remedy", p.remedy}});
    }
    std::cout << JsonText(nlohmann::ordered_json{{"store", store->uri()}, {"problems", list}}, 2)
              << "\n";
  } else if (problems.empty()) {
    std::printf(
        "%s: healthy (engine check, references, head, cut-off pieces, history, submissions)\n",
        store->uri().c_str());
  } else {
    std::printf("%s: %s\n", store->uri().c_str(),
                Count(static_cast<std::int64_t>(problems.size()), "problem").c_str());
    for (const StoreProblem& p : problems) {
      std::printf("\n[%s] %s\n  what to do: %s\n", p.check.c_str(), p.what.c_str(),
                  p.remedy.c_str());
    }
  }
  // Exit 1 when something is wrong, so a cron job or a CI step notices (CLI11 prints nothing
  // for a RuntimeError; what is wrong is printed above).
  if (!problems.empty()) throw CLI::RuntimeError(1);
}

void AddStoreArgument(CLI::App& command, InspectArgs& args) {
  command.add_option("store", args.store,
                     "The store: sqlite:PATH, postgresql://USER@HOST/DB, or a path to an SQLite "
                     "file (default: " +
                         std::string(kDefaultStore) + ")");
  command.add_flag("--json", args.json, "Print JSON");
}

}  // namespace

void AddStoreInspectionCommands(CLI::App& app) {
  auto info_args = std::make_shared<InspectArgs>();
  CLI::App* info = app.add_subcommand("info", "What a map store holds");
  info->footer(
      "The engine and schema version, size on disk, counts of everything stored (hidden "
      "elements too) and of the map at the head revision, the last revision, submissions by "
      "state, the oldest and newest node stamps, and each robot's nodes. Opens the store "
      "read-only.");
  AddStoreArgument(*info, *info_args);
  info->callback([info_args] { RunInfo(*info_args); });

  auto doctor_args = std::make_shared<InspectArgs>();
  CLI::App* doctor = app.add_subcommand("doctor", "Check a map store and say what to do");
  doctor->footer(
      "Checks, read-only: the engine's own check (SQLite integrity_check and foreign_key_check; "
      "PostgreSQL invalid indexes and unvalidated constraints); stored edges whose node or path "
      "is not stored; edges visible at the head whose node or path is hidden; pieces of the head "
      "a hide (revert, promotion) cut off from the rest of the map; version records "
      "of elements or revisions that do not exist; revisions numbered 1..head without a gap, "
      "each merge and its submission agreeing; pushes receiving for longer than "
      "--receiving-stuck-h and queued submissions no fleetmapd has claimed for longer than "
      "--queued-stuck-h. Each problem comes with what to do about it. Exit status: 0 healthy, "
      "1 problems found (or the store cannot be opened).");
  AddStoreArgument(*doctor, *doctor_args);
  doctor
      ->add_option("--receiving-stuck-h", doctor_args->receiving_stuck_h,
                   "A push still receiving after this many hours has stopped (default 24)")
      ->check(CLI::NonNegativeNumber);
  doctor
      ->add_option("--queued-stuck-h", doctor_args->queued_stuck_h,
                   "A queued submission unclaimed after this many hours is stuck (default 1)")
      ->check(CLI::NonNegativeNumber);
  doctor->callback([doctor_args] { RunDoctor(*doctor_args); });
}

}  // namespace fleetmap::cli
