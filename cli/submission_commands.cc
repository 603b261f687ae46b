// `fleetmap push`, `fleetmap submissions` and `fleetmap merge`: a robot's map into the
// repository whole (seed 004 §IV: robots hand their EBN maps to the server), and MERGE of what
// was pushed into the linear history (seed 004 §V-A).
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>

#include "commands.h"
#include "fleetmap/core/clock.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/store/graph_store.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

// ---- push ----

struct PushArgs {
  std::string store;
  std::string map;
  std::string robot;
  std::string author;
  std::string id;
};

// Everything in a robot's map store: nodes with landmarks, every edge touching them, paths.
GraphBatch ReadRobotMap(const std::string& uri) {
  const std::string path = SqlitePath(uri);
  if (!path.empty() && !std::filesystem::exists(path)) {
    throw Error(ErrorCode::kNotFound, "--map " + uri + ": no such file " + path);
  }
  // The robot's map must already be a fleetmap store: opened as an ordinary store, an empty
  // file (or another program's database) would be created and migrated into an empty map, and
  // the file changed by a command that only reads it.
  StoreOptions existing_only;
  existing_only.create_if_missing = false;
  existing_only.read_only = true;
  GraphBatch map;
  try {
    map = GraphStore::Open(uri, existing_only)->ReadMap();
  } catch (const Error& error) {
    // Open says "URI is not a fleetmap map store (why)" for an empty file, a missing table or
    // a file that is not a database; that reads best after "--map" as it is.
    if (error.message().find(" is not a fleetmap map store (") != std::string::npos) {
      throw Error(error.code(), "--map " + error.message() + "; nothing was pushed");
    }
    throw InContext(error, "--map " + uri + " could not be read, nothing was pushed");
  }
  if (map.nodes.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "--map " + uri + " holds no nodes: nothing to push");
  }
  return map;
}

void RunPush(const PushArgs& args) {
  const Uuid robot = ParseUuidArgument(args.robot, "--robot");
  const Uuid id = args.id.empty() ? Uuid::GenerateRandom() : ParseUuidArgument(args.id, "--id");
  const GraphBatch map = ReadRobotMap(args.map);
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const bool stored_before = repository->inspect().FindSubmission(id).has_value();
  const std::string author = args.author.empty() ? robot.ToString() : args.author;
  Submission submission;
  try {
    submission = repository->Push(id, robot, author, map);
  } catch (const Error& error) {
    throw InContext(error, "push of " + args.map + " as submission " + id.ToString() +
                               " refused, nothing stored");
  }
  std::size_t metric = 0;
  for (const Edge& edge : map.edges) metric += edge.kind == EdgeKind::kMetric ? 1 : 0;
  std::printf(
      "submission %s %s\n", submission.id.ToString().c_str(),
      stored_before ? "was already stored with this content: nothing changed" : "stored whole");
  std::printf("  robot     %s\n  author    %s\n", submission.robot.ToString().c_str(),
              PrintableText(submission.author).c_str());
  std::printf("  map       %s: %s, %s (%zu metric, %zu path), %s\n", args.map.c_str(),
              Count(static_cast<std::int64_t>(map.nodes.size()), "node").c_str(),
              Count(static_cast<std::int64_t>(map.edges.size()), "edge").c_str(), metric,
              map.edges.size() - metric,
              Count(static_cast<std::int64_t>(map.paths.size()), "path").c_str());
  std::printf("  bytes     %lld in %s\n", static_cast<long long>(submission.bytes),
              Count(submission.chunk_count, "chunk").c_str());
  std::printf("  state     %s", std::string(SubmissionStateName(submission.state)).c_str());
  if (submission.state == SubmissionState::kMerged) {
    std::printf(" (revision %lld)", static_cast<long long>(submission.revision));
  } else if (submission.state == SubmissionState::kQueued) {
    std::printf(" for `fleetmap merge`");
  }
  std::printf("\n");
}

// ---- submissions ----

struct SubmissionsArgs {
  std::string store;
  bool json = false;
};

// The claim a fleetmapd holds on a queued submission to merge it (several servers on one
// store), when its lease has not ended by this host's clock.
std::optional<SubmissionClaim> QueuedClaim(Repository& repository, const Submission& s) {
  if (s.state != SubmissionState::kQueued) return std::nullopt;
  std::optional<SubmissionClaim> claim = repository.inspect().FindClaim(s.id);
  const std::int64_t now_ns = WallClockNs();
  if (!claim || claim->lease_until_ns <= now_ns) return std::nullopt;
  return claim;
}

void RunSubmissions(const SubmissionsArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const std::vector<Submission> submissions = repository->Submissions();
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const Submission& s : submissions) {
      nlohmann::ordered_json entry;
      entry["id"] = s.id.ToString();
      entry["robot"] = s.robot.ToString();
      entry["author"] = s.author;
      entry["received"] = FormatUtc(s.received_ns);
      entry["received_ns"] = s.received_ns;
      entry["bytes"] = s.bytes;
      entry["chunks"] = s.chunk_count;
      entry["state"] = SubmissionStateName(s.state);
      if (s.state == SubmissionState::kMerged) entry["revision"] = s.revision;
      // Failed: why. Queued: the last transient failure of its merge, which fleetmapd retries.
      if (!s.error.empty()) entry["error"] = s.error;
      if (const std::optional<SubmissionClaim> claim = QueuedClaim(*repository, s)) {
        entry["claimed_by"] = claim->instance;
        entry["lease_until"] = FormatUtc(claim->lease_until_ns);
      }
      list.push_back(std::move(entry));
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (submissions.empty()) {
    std::printf("no submissions in %s (robots add theirs with `fleetmap push`)\n",
                repository->uri().c_str());
    return;
  }
  // Authors, errors and instance names are outside text: escaped to one line each, so none can
  // forge a row or drive the terminal.
  int author_width = 6;
  for (const Submission& s : submissions) {
    author_width = std::max(author_width, static_cast<int>(PrintableText(s.author).size()));
  }
  std::printf("%-36s  %-36s  %-*s  %-20s  %10s  %-9s  %s\n", "SUBMISSION", "ROBOT", author_width,
              "AUTHOR", "RECEIVED (UTC)", "BYTES", "STATE", "REVISION / ERROR");
  for (const Submission& s : submissions) {
    std::string outcome;
    if (s.state == SubmissionState::kMerged) outcome = std::to_string(s.revision);
    if (s.state != SubmissionState::kMerged) outcome = s.error;  // queued: the last retry's
    if (const std::optional<SubmissionClaim> claim = QueuedClaim(*repository, s)) {
      outcome = "claimed by " + claim->instance + " until " + FormatUtc(claim->lease_until_ns) +
                (outcome.empty() ? "" : "; " + outcome);
    }
    std::printf("%-36s  %-36s  %-*s  %-20s  %10lld  %-9s  %s\n", s.id.ToString().c_str(),
                s.robot.ToString().c_str(), author_width, PrintableText(s.author).c_str(),
                FormatUtc(s.received_ns).c_str(), static_cast<long long>(s.bytes),
                std::string(SubmissionStateName(s.state)).c_str(), PrintableText(outcome).c_str());
  }
}

// ---- merge ----

struct MergeArgs {
  std::string store;
  std::vector<std::string> submissions;
  bool all = false;
};

void PrintMerge(const Uuid& id, const MergeOutcome& outcome) {
  if (outcome.already_merged) {
    std::printf("submission %s: already merged as revision %lld; nothing to do\n",
                id.ToString().c_str(), static_cast<long long>(outcome.revision.number));
    return;
  }
  const MergeReport& r = outcome.report;
  std::printf("submission %s -> revision %lld (author %s)\n", id.ToString().c_str(),
              static_cast<long long>(outcome.revision.number),
              PrintableText(outcome.revision.author).c_str());
  std::printf("  segments   %zu, decided in %zu stretches: %zu added, %zu omitted (localised)\n",
              r.segments, r.stretches, r.stretches_added, r.stretches_omitted);
  std::printf(
      "  nodes      %zu submitted, %zu duplicates, %zu added (%zu localised at the ends of added "
      "stretches left out)\n",
      r.submitted_nodes, r.duplicate_nodes, r.nodes_added, r.localised_ends_omitted);
  std::printf(
      "  edges      %zu metric added (%zu links to the map), %zu path added, %zu path "
      "dropped\n",
      r.metric_edges_added, r.links_added, r.path_edges_added, r.path_edges_dropped);
  std::printf(
      "  links      %zu registered against the map, %zu dropped (more than 3 sigma from their "
      "neighbours)\n",
      r.links_registered, r.links_inconsistent);
  std::printf("  paths      %zu added\n", r.paths_added);
  std::printf("  time       %.2f s (MERGE %.2f s)\n", outcome.seconds, r.seconds);
}

void RunMerge(const MergeArgs& args) {
  if (args.all == !args.submissions.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                args.all ? "merge: give submission ids or --all, not both"
                         : "merge: name the submissions to merge, or --all for every queued one");
  }
  // Every id is checked before anything is merged: a typo merges nothing.
  std::vector<Uuid> ids;
  for (const std::string& text : args.submissions) {
    ids.push_back(ParseUuidArgument(text, "submission"));
  }
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  for (const Uuid& id : ids) {
    if (!repository->inspect().FindSubmission(id)) {
      throw Error(ErrorCode::kNotFound, "no submission " + id.ToString() + " in " +
                                            repository->uri() +
                                            " (see `fleetmap submissions`); nothing merged");
    }
  }
  if (args.all) {
    for (const Submission& s : repository->Submissions()) {  // in the order received
      if (s.state == SubmissionState::kQueued) ids.push_back(s.id);
    }
    if (ids.empty()) {
      std::printf("nothing to merge: no queued submissions in %s\n", repository->uri().c_str());
      return;
    }
  }
  for (const Uuid& id : ids) {
    ProgressBar bar("merge " + id.ToString().substr(0, 8), std::cerr);
    MergeOutcome outcome;
    try {
      outcome = repository->Merge(id, [&bar](std::size_t done, std::size_t all) {
        bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(all));
      });
    } catch (const Error& error) {
      throw InContext(error,
                      "merge of submission " + id.ToString() + " failed and changed nothing");
    }
    if (!outcome.already_merged) bar.Finish();
    PrintMerge(id, outcome);
  }
}

}  // namespace

void AddSubmissionCommands(CLI::App& app) {
  auto push_args = std::make_shared<PushArgs>();
  CLI::App* push = app.add_subcommand("push", "Store a robot's map as a submission");
  push->footer(
      "Stores a robot's whole local map (every node with its landmarks, every edge touching "
      "them, every path) in the repository as one immutable submission, queued for MERGE (seed "
      "004 §IV: robots hand their independently built EBN maps to the server; nothing they send "
      "is lost). Pushing the same --id with the same content again changes nothing; other "
      "content under a stored id is refused. The --map store is only read: it must already be a "
      "fleetmap store at this fleetmap's schema version.");
  AddStoreOption(*push, push_args->store);
  push->add_option("--map", push_args->map, "The robot's map store (sqlite:PATH or postgresql://)")
      ->required();
  push->add_option("--robot", push_args->robot, "The robot's UUID")->required();
  push->add_option("--author", push_args->author, "Who pushed (default: the robot's UUID)");
  push->add_option("--id", push_args->id, "The submission's UUID (default: a fresh random one)");
  push->callback([push_args] { RunPush(*push_args); });

  auto list_args = std::make_shared<SubmissionsArgs>();
  CLI::App* submissions = app.add_subcommand("submissions", "List the pushed submissions");
  submissions->footer(
      "Every submission robots pushed, in the order received: id, robot, author, when (UTC), "
      "bytes, state (queued, merged, failed) and the revision it became or why MERGE refused it.");
  AddStoreOption(*submissions, list_args->store);
  submissions->add_flag("--json", list_args->json, "Print JSON instead of a table");
  submissions->callback([list_args] { RunSubmissions(*list_args); });

  auto merge_args = std::make_shared<MergeArgs>();
  CLI::App* merge = app.add_subcommand("merge", "MERGE submissions into new revisions");
  merge->footer(
      "MERGE (seed 004 §V-A, Algorithm 1) of each submission into the map at the head, as the "
      "next revision: its linear segments are replayed through the localiser against the map, "
      "the stretches that localise are omitted (the map already covers them), the rest are "
      "added and linked to the map. A submission merged before is not merged again; --all skips "
      "failed ones (name one to retry it). Every named id is checked before anything merges.");
  AddStoreOption(*merge, merge_args->store);
  merge->add_option("submissions", merge_args->submissions, "Submission ids to merge, in order");
  merge->add_flag("--all", merge_args->all, "Merge every queued submission in the order received");
  merge->callback([merge_args] { RunMerge(*merge_args); });
}

}  // namespace fleetmap::cli
