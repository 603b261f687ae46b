// `fleetmap init`, `log`, `checkout`, `diff` and `revert`: the repository's linear history of
// revisions (seed 004 §V: like SVN, every revision can be checked out exactly; a revert hides
// what a revision added and never deletes it).
#include <cstdio>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/repository/dream_candidates.h"
#include "new_store.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

// ---- init ----

struct InitArgs {
  std::string store;
};

void RunInit(const InitArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store, /*create=*/true);
  std::printf("repository %s\n", repository->uri().c_str());
  std::printf("  schema version %d (this fleetmap writes %d)\n",
              repository->inspect().SchemaVersion(), GraphStore::LatestSchemaVersion());
  std::printf("  head revision  %lld\n", static_cast<long long>(repository->Head()));
  std::printf("  submissions    %zu\n", repository->Submissions().size());
}

// ---- log ----

struct LogArgs {
  std::string store;
  bool json = false;
};

// The kind of each revision by number, to tell a revert of a retirement (a restore) from one
// of a merge.
std::map<RevisionNumber, RevisionKind> KindsOf(const std::vector<Revision>& history) {
  std::map<RevisionNumber, RevisionKind> kinds;
  for (const Revision& r : history) kinds[r.number] = r.kind;
  return kinds;
}

bool RestoresRetirement(const Revision& r, const std::map<RevisionNumber, RevisionKind>& kinds) {
  if (r.kind != RevisionKind::kRevert) return false;
  const auto reverted = kinds.find(r.reverted);
  return reverted != kinds.end() && reverted->second == RevisionKind::kRetire;
}

// "retirement of 12 nodes unused since 2024-05-01T08:30:00Z": the count the store recorded, the
// cutoff from the plan the revision keeps as its report (left out when that does not read).
std::string RetirementSource(const Revision& r) {
  std::string text = "retirement of " + Count(r.nodes_hidden, "node");
  const nlohmann::json plan = nlohmann::json::parse(r.report, nullptr, /*allow_exceptions=*/false);
  if (plan.is_object() && plan.contains("cutoff_ns") && plan["cutoff_ns"].is_number_integer()) {
    text += " unused since " + FormatUtc(plan["cutoff_ns"].get<std::int64_t>());
  }
  return text;
}

std::string Source(const Revision& r, const std::map<RevisionNumber, RevisionKind>& kinds) {
  switch (r.kind) {
    case RevisionKind::kMerge:
      return "submission " + r.submission.ToString();
    case RevisionKind::kRevert:
      if (RestoresRetirement(r, kinds)) {
        return "revision " + std::to_string(r.reverted) + ": restored " +
               Count(r.nodes_added, "node");
      }
      return "revision " + std::to_string(r.reverted);
    case RevisionKind::kRetire:
      return RetirementSource(r);
    case RevisionKind::kPromote:
      break;
  }
  try {
    return "dream candidate " + DreamCandidateFromJson(r.report).id.ToString();
  } catch (const Error&) {
    return "a dream candidate";
  }
}

void RunLog(const LogArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const std::vector<Revision> history = repository->History();
  const std::map<RevisionNumber, RevisionKind> kinds = KindsOf(history);
  if (args.json) {
    nlohmann::ordered_json list = nlohmann::ordered_json::array();
    for (const Revision& r : history) {
      nlohmann::ordered_json entry;
      entry["revision"] = r.number;
      entry["time"] = FormatUtc(r.created_ns);
      entry["created_ns"] = r.created_ns;
      entry["author"] = r.author;
      entry["kind"] = RevisionKindName(r.kind);
      if (r.kind == RevisionKind::kMerge) entry["submission"] = r.submission.ToString();
      if (r.kind == RevisionKind::kRevert) entry["reverted"] = r.reverted;
      if (RestoresRetirement(r, kinds)) entry["restores"] = "retire";
      if (r.kind != RevisionKind::kMerge) entry["source"] = Source(r, kinds);
      entry["added"] = {
          {"nodes", r.nodes_added}, {"edges", r.edges_added}, {"paths", r.paths_added}};
      entry["hidden"] = {
          {"nodes", r.nodes_hidden}, {"edges", r.edges_hidden}, {"paths", r.paths_hidden}};
      // A merge keeps MERGE's report as JSON, a retirement its plan (retirement.h); anything
      // else stays text.
      const nlohmann::ordered_json report =
          nlohmann::ordered_json::parse(r.report, nullptr, /*allow_exceptions=*/false);
      entry["report"] = report.is_discarded() ? nlohmann::ordered_json(r.report) : report;
      list.push_back(std::move(entry));
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (history.empty()) {
    std::printf("no revisions in %s yet: the map is empty (push, then `fleetmap merge`)\n",
                repository->uri().c_str());
    return;
  }
  // Authors are outside text: escaped to one line each, so none can forge a row or drive the
  // terminal.
  // The OF column is as wide as its longest entry (a retirement's reads longer than a UUID).
  int author_width = 6, of_width = 47;
  for (const Revision& r : history) {
    author_width = std::max(author_width, static_cast<int>(PrintableText(r.author).size()));
    of_width = std::max(of_width, static_cast<int>(Source(r, kinds).size()));
  }
  std::printf("%-4s  %-20s  %-*s  %-6s  %-*s  %-23s  %s\n", "REV", "TIME (UTC)", author_width,
              "AUTHOR", "KIND", of_width, "OF", "ADDED nodes/edges/paths",
              "HIDDEN nodes/edges/paths");
  for (const Revision& r : history) {
    const std::string added = std::to_string(r.nodes_added) + "/" + std::to_string(r.edges_added) +
                              "/" + std::to_string(r.paths_added);
    const std::string hidden = std::to_string(r.nodes_hidden) + "/" +
                               std::to_string(r.edges_hidden) + "/" +
                               std::to_string(r.paths_hidden);
    std::printf("%-4lld  %-20s  %-*s  %-6s  %-*s  %-23s  %s\n", static_cast<long long>(r.number),
                FormatUtc(r.created_ns).c_str(), author_width, PrintableText(r.author).c_str(),
                std::string(RevisionKindName(r.kind)).c_str(), of_width, Source(r, kinds).c_str(),
                added.c_str(), hidden.c_str());
  }
}

// ---- checkout ----

struct CheckoutArgs {
  std::string store;
  std::optional<RevisionNumber> revision;
  std::string out;
};

void RunCheckout(const CheckoutArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const RevisionNumber revision = args.revision.value_or(repository->Head());
  RequireRevision(*repository, revision);
  RequireNewStore(args.out, "--out");
  const GraphBatch map = repository->Checkout(revision);
  const StoreStats written = WriteNewStore(args.out, "--out", map);
  std::printf("checked out revision %lld of %s into %s\n", static_cast<long long>(revision),
              repository->uri().c_str(), args.out.c_str());
  std::printf("  %s, %s, %s, %lld landmark bytes\n", Count(written.nodes, "node").c_str(),
              Count(written.edges, "edge").c_str(), Count(written.paths, "path").c_str(),
              static_cast<long long>(written.landmark_bytes));
}

// ---- diff ----

struct DiffArgs {
  std::string store;
  RevisionNumber from = 0, to = 0;
  bool json = false;
};

nlohmann::ordered_json Ids(const std::vector<Uuid>& ids) {
  nlohmann::ordered_json list = nlohmann::ordered_json::array();
  for (const Uuid& id : ids) list.push_back(id.ToString());
  return list;
}

void RunDiff(const DiffArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  RequireRevision(*repository, args.from);
  RequireRevision(*repository, args.to);
  const RevisionChanges c = repository->Diff(args.from, args.to);
  if (args.json) {
    nlohmann::ordered_json json;
    json["from"] = c.from;
    json["to"] = c.to;
    json["added"] = {{"nodes", Ids(c.nodes_added)},
                     {"edges", Ids(c.edges_added)},
                     {"paths", Ids(c.paths_added)}};
    json["removed"] = {{"nodes", Ids(c.nodes_removed)},
                       {"edges", Ids(c.edges_removed)},
                       {"paths", Ids(c.paths_removed)}};
    std::cout << JsonText(json, 2) << "\n";
    return;
  }
  std::printf("revision %lld -> %lld\n", static_cast<long long>(args.from),
              static_cast<long long>(args.to));
  std::printf("  nodes  +%zu -%zu\n", c.nodes_added.size(), c.nodes_removed.size());
  std::printf("  edges  +%zu -%zu\n", c.edges_added.size(), c.edges_removed.size());
  std::printf("  paths  +%zu -%zu\n", c.paths_added.size(), c.paths_removed.size());
}

// ---- revert ----

struct RevertArgs {
  std::string store;
  RevisionNumber revision = 0;
  std::string author;
};

void RunRevert(const RevertArgs& args) {
  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  RequireRevision(*repository, args.revision);
  if (args.revision == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                "revision 0 is the empty map before the first merge: there is nothing to revert");
  }
  Revision revert;
  try {
    revert = repository->Revert(args.revision, args.author.empty() ? DefaultAuthor() : args.author);
  } catch (const Error& error) {
    throw InContext(error, "cannot revert revision " + std::to_string(args.revision));
  }
  std::printf("revision %lld reverts revision %lld (author %s)\n",
              static_cast<long long>(revert.number), static_cast<long long>(args.revision),
              PrintableText(revert.author).c_str());
  // A revert of a retirement brings back what it hid, and the store counts that as added.
  if (const std::optional<Revision> reverted = repository->inspect().FindRevision(args.revision);
      reverted && reverted->kind == RevisionKind::kRetire) {
    std::printf("  restored %s, %s, %s that revision %lld retired\n",
                Count(revert.nodes_added, "node").c_str(),
                Count(revert.edges_added, "edge").c_str(),
                Count(revert.paths_added, "path").c_str(), static_cast<long long>(args.revision));
    return;
  }
  std::printf("  hid %s, %s, %s (kept in the store: revision %lld still checks out)\n",
              Count(revert.nodes_hidden, "node").c_str(),
              Count(revert.edges_hidden, "edge").c_str(),
              Count(revert.paths_hidden, "path").c_str(), static_cast<long long>(args.revision));
}

}  // namespace

void AddInitCommand(CLI::App& app) {
  auto args = std::make_shared<InitArgs>();
  CLI::App* init = app.add_subcommand("init", "Create (or open) a repository and migrate it");
  init->footer(
      "Opens the repository at --store, creating it and applying the numbered schema migrations "
      "if needed, and prints its URI (without password), schema version and head revision. The "
      "other repository commands refuse an SQLite repository that does not exist yet.");
  AddStoreOption(*init, args->store);
  init->callback([args] { RunInit(*args); });
}

void AddHistoryCommands(CLI::App& app) {
  auto log_args = std::make_shared<LogArgs>();
  CLI::App* log = app.add_subcommand("log", "Show the history of revisions");
  log->footer(
      "The linear history of revisions (seed 004 §V: like SVN): number, time (UTC), author, "
      "kind (a merge of a submission, a revert of a revision, a promotion of a dream candidate, "
      "a retirement of unused experiences), and the nodes, edges and paths each added and hid "
      "(a revert of a retirement adds back what it hid).");
  AddStoreOption(*log, log_args->store);
  log->add_flag("--json", log_args->json,
                "Print JSON (with each merge's full report, each retirement's plan)");
  // Record files moved from `log` to `records`: a user who types the old command
  // is told where it went instead of reading a parse error.
  log->allow_extras();
  log->callback([log_args, log] {
    const std::vector<std::string> extras = log->remaining();
    if (!extras.empty()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "`fleetmap log` shows the revision history and takes no '" + extras.front() +
                      "'; record files are under `fleetmap records split|cat|ingest|reindex`");
    }
    RunLog(*log_args);
  });

  auto checkout_args = std::make_shared<CheckoutArgs>();
  CLI::App* checkout =
      app.add_subcommand("checkout", "Write the whole map at a revision into a new store");
  checkout->footer(
      "Writes every node (with its landmarks), edge and path visible at the revision into a new "
      "store: the map as it was then (seed 004 Eq. 3, \"copy\", of any revision). Refuses an "
      "--out store that already holds nodes.");
  AddStoreOption(*checkout, checkout_args->store);
  checkout->add_option("--revision", checkout_args->revision, "Revision (default: the head)");
  checkout->add_option("--out", checkout_args->out, "The new store (must hold no map yet)")
      ->required();
  checkout->callback([checkout_args] { RunCheckout(*checkout_args); });

  auto diff_args = std::make_shared<DiffArgs>();
  CLI::App* diff = app.add_subcommand("diff", "Compare the maps at two revisions");
  diff->footer(
      "Counts the nodes, edges and paths visible at TO but not at FROM (added) and at FROM but "
      "not at TO (removed); --json lists their UUIDs.");
  AddStoreOption(*diff, diff_args->store);
  diff->add_option("from", diff_args->from, "Revision FROM")->required();
  diff->add_option("to", diff_args->to, "Revision TO")->required();
  diff->add_flag("--json", diff_args->json, "Print JSON with the UUIDs of everything that differs");
  diff->callback([diff_args] { RunDiff(*diff_args); });

  auto revert_args = std::make_shared<RevertArgs>();
  CLI::App* revert = app.add_subcommand("revert", "Hide what a revision added, as a new revision");
  revert->footer(
      "Makes a new revision that hides every node, edge and path REVISION added, and any edge "
      "that would dangle. Nothing is deleted: every earlier revision still checks out, and "
      "hidden nodes are never merged again (seed 004 §III-D: UUIDs identify data). A revert "
      "of a retirement (`fleetmap retire`) instead restores what it hid. A revert cannot be "
      "reverted, nor a revision twice.");
  AddStoreOption(*revert, revert_args->store);
  revert->add_option("revision", revert_args->revision, "The revision to revert")->required();
  revert->add_option("--author", revert_args->author, "Who reverts (default: $USER)");
  revert->callback([revert_args] { RunRevert(*revert_args); });
}

}  // namespace fleetmap::cli
