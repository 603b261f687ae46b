// `fleetmap dream-now`, `fleetmap candidates` and `fleetmap promote`: the nightly dream
// (nightly_dream.h) by hand, the candidate maps dreams left (dream_candidates.h), and making
// one of them the map (Repository::Promote).
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/repository/dream_candidates.h"
#include "fleetmap/repository/nightly_dream.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

std::string ScoreText(const DreamCandidateRecord& c) {
  char text[160];
  std::snprintf(text, sizeof text, "P(gap > %.0f m) %.4f, %.1f %% not localised, score %.4f",
                c.gap_m, c.p_gap_exceeds, 100.0 * c.not_localised, c.score);
  std::string out = text;
  if (c.merged_order_score) {
    std::snprintf(text, sizeof text, " (the order the server merged: %.4f)", *c.merged_order_score);
    out += text;
  }
  return out;
}

void PrintCandidate(const DreamCandidateRecord& c) {
  std::printf("candidate %s  %s\n", c.id.ToString().c_str(), FormatUtc(c.created_ns).c_str());
  std::printf("  %s into revision %lld's map (head %lld when dreamed), best of %zu orders\n",
              Count(static_cast<std::int64_t>(c.groups.size()), "group").c_str(),
              static_cast<long long>(c.base_revision), static_cast<long long>(c.dreamed_at_head),
              c.orders);
  std::printf("  held out: submission %s (%zu frames)\n", c.held_out.ToString().c_str(),
              c.held_out_frames);
  std::printf("  held-out score: %s\n", ScoreText(c).c_str());
  std::printf("  content: %s, %s, %s; %s\n", Count(c.nodes, "node").c_str(),
              Count(c.edges, "edge").c_str(), Count(c.paths, "path").c_str(),
              c.promoted_as ? ("promoted as revision " + std::to_string(c.promoted_as)).c_str()
                            : "not promoted");
}

// ---- dream-now ----

struct DreamNowArgs {
  std::string store;
  NightlyDreamOptions options;
  std::size_t max_orders = 0;
  bool json = false;
};

void RunDreamNow(DreamNowArgs args) {
  if (args.max_orders > 0) args.options.max_orders = args.max_orders;
  const std::unique_ptr<Repository> repository = OpenExistingRepository(args.store);
  ProgressBar bar("dreaming", std::cerr);
  const NightlyDreamOutcome outcome =
      RunNightlyDream(*repository, args.options, [&bar](std::size_t done, std::size_t all) {
        bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(all));
      });
  bar.Finish();
  if (args.json) {
    std::cout << (outcome.candidate ? DreamCandidateJson(*outcome.candidate)
                                    : JsonText(nlohmann::json({{"skipped", outcome.skipped}})))
              << "\n";
    return;
  }
  if (!outcome.candidate) {
    std::printf("no dream: %s\n", outcome.skipped.c_str());
    return;
  }
  PrintCandidate(*outcome.candidate);
  std::printf("`fleetmap promote %s` makes it the next revision\n",
              outcome.candidate->id.ToString().c_str());
}

// ---- candidates ----

struct CandidatesArgs {
  std::string store;
  bool json = false;
};

void RunCandidates(const CandidatesArgs& args) {
  const std::unique_ptr<Repository> repository = OpenExistingRepository(args.store);
  const std::vector<DreamCandidateRecord> records = DreamCandidates(*repository).List();
  if (args.json) {
    nlohmann::json list = nlohmann::json::array();
    for (const DreamCandidateRecord& c : records) {
      list.push_back(nlohmann::json::parse(DreamCandidateJson(c)));
    }
    std::cout << JsonText(list, 2) << "\n";
    return;
  }
  if (records.empty()) {
    std::printf("no dream candidates (fleetmapd --dream-at HH:MM, or fleetmap dream-now)\n");
    return;
  }
  for (const DreamCandidateRecord& c : records) PrintCandidate(c);
}

// ---- promote ----

struct PromoteArgs {
  std::string store;
  std::string candidate;
  std::string author;
  bool force = false;
};

void RunPromote(const PromoteArgs& args) {
  const Uuid id = ParseUuidArgument(args.candidate, "CANDIDATE");
  const std::unique_ptr<Repository> repository = OpenExistingRepository(args.store);
  Revision revision;
  try {
    revision =
        repository->Promote(id, args.author.empty() ? DefaultAuthor() : args.author, args.force);
  } catch (const Error& error) {
    throw InContext(error, "cannot promote " + id.ToString());
  }
  const DreamCandidateRecord record = DreamCandidateFromJson(revision.report);
  std::printf("revision %lld promotes dream candidate %s (author %s)\n",
              static_cast<long long>(revision.number), id.ToString().c_str(),
              PrintableText(revision.author).c_str());
  std::printf(
      "  added %s, %s, %s; hid %s, %s\n", Count(revision.nodes_added, "node").c_str(),
      Count(revision.edges_added, "edge").c_str(), Count(revision.paths_added, "path").c_str(),
      Count(revision.nodes_hidden, "node").c_str(), Count(revision.edges_hidden, "edge").c_str());
  std::printf("  held-out score: %s\n", ScoreText(record).c_str());
}

}  // namespace

void AddDreamCandidateCommands(CLI::App& app) {
  auto now_args = std::make_shared<DreamNowArgs>();
  CLI::App* now =
      app.add_subcommand("dream-now", "Run the nightly dream now; leave its map as a candidate");
  now->footer(
      "What fleetmapd --dream-at runs each night (seed 004 §VI-E): the submissions merged since "
      "the last dream's held-out one are taken in the order the server merged them; the newest "
      "is held out and judges the maps; the up to --max-groups before it are merged in every "
      "order into the map as it was before the first of them. The best map (lowest P(gap > 10 "
      "m) of the held-out data, ties by the share not localised) is stored as a candidate: the "
      "head does not change until `fleetmap promote`. With fewer than two submissions since "
      "the last dream there is nothing to judge, and it says so.");
  AddStoreOption(*now, now_args->store);
  now->add_option("--max-groups", now_args->options.max_groups,
                  "Groups merged in every order at most (k! orders)")
      ->capture_default_str()
      ->check(CLI::Range(std::size_t{1}, std::size_t{kMaxDreamGroups}));
  now->add_option("--max-orders", now_args->max_orders,
                  "Explore at most this many orders (default 0: all)");
  now->add_flag("--json", now_args->json, "Print the candidate's record as JSON");
  now->callback([now_args] { RunDreamNow(*now_args); });

  auto list_args = std::make_shared<CandidatesArgs>();
  CLI::App* list = app.add_subcommand("candidates", "List the candidate maps dreams left");
  list->footer(
      "Newest first: what each dream merged into which revision, the submission held out, its "
      "held-out score (P(gap > 10 m), the share of frames not localised; lower is better) and "
      "whether it was promoted.");
  AddStoreOption(*list, list_args->store);
  list->add_flag("--json", list_args->json, "Print JSON");
  list->callback([list_args] { RunCandidates(*list_args); });

  auto promote_args = std::make_shared<PromoteArgs>();
  CLI::App* promote =
      app.add_subcommand("promote", "Make a dream's candidate map the next revision");
  promote->footer(
      "Makes a new revision (kind promote) in which the candidate replaces what the merges of "
      "its groups added: its nodes, edges and paths that are not in the store are added, the "
      "groups' nodes it did without are hidden (with any edge left dangling). Everything since "
      "the dream stays: later merges, and reverts. The revision's report is the candidate's "
      "record with its held-out score (`fleetmap log --json`). Nothing is deleted; a promotion "
      "cannot be reverted (nothing un-hides): promote another candidate instead. A candidate "
      "whose held-out score does not beat that of the order the server merged (a tie is no "
      "gain), or whose dream did not score that order, is refused with both scores unless "
      "--force is given.");
  AddStoreOption(*promote, promote_args->store);
  promote->add_option("candidate", promote_args->candidate, "The candidate's UUID")->required();
  promote->add_option("--author", promote_args->author, "Who promotes (default: $USER)");
  promote->add_flag("--force", promote_args->force,
                    "Promote even a candidate that does not beat the order the server merged");
  promote->callback([promote_args] { RunPromote(*promote_args); });
}

}  // namespace fleetmap::cli
