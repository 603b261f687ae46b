// `fleetmap dream`: dreaming (seed 004 §VI-E). The maps of k groups of submissions are MERGEd
// from an empty map in every order (or a sample of orders), each candidate is scored by how far
// a held-out submission travels unlocalised in it, and the best is kept.
#include <algorithm>
#include <cstdio>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numeric>
#include <optional>
#include <set>

#include "commands.h"
#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"
#include "fleetmap/map_management/dream_plan.h"
#include "fleetmap/map_management/dreaming.h"
#include "fleetmap/map_management/held_out_replay.h"
#include "new_store.h"
#include "progress_bar.h"
#include "repository_arguments.h"

namespace fleetmap::cli {
namespace {

// The repository's setting (Repository keeps its vocabulary there; it has no accessor for it).
// Seed 004 §VI-E judges candidate maps by the distance travelled without localisation; the
// experiments (seed 002 §VII-B) count gaps beyond 10 m as failures.
constexpr double kGapM = 10.0;

struct DreamArgs {
  std::string store;
  std::vector<std::string> groups;
  std::string held_out;
  std::optional<std::size_t> max_orders;
  std::uint64_t seed = 1;
  std::optional<double> group_seconds;
  std::string out;
  bool json = false;
};

double Mean(const std::vector<double>& v) {
  return v.empty() ? 0.0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size());
}

// The repository's vocabulary when it has one; else one trained from the groups' descriptors
// (thinned to about 200k, like the repository's own first training), so the dream's maps are
// indexed as a merge into this repository would index them.
struct DreamWords {
  std::shared_ptr<const AppearanceVocabulary> vocabulary;
  bool trained = false;  // not stored with the repository: trained here
};

DreamWords DreamVocabulary(Repository& repository, const std::vector<GraphBatch>& groups) {
  if (std::shared_ptr<const AppearanceVocabulary> stored = repository.StoredVocabulary()) {
    return {std::move(stored), false};
  }
  std::vector<Descriptor256> all;
  for (const GraphBatch& group : groups) {
    for (const Node& node : group.nodes) {
      const Landmarks landmarks = DecodeLandmarks(node.landmarks_blob);
      all.insert(all.end(), landmarks.descriptors.begin(), landmarks.descriptors.end());
    }
  }
  if (all.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "dream: the groups hold no landmarks to learn an appearance vocabulary from");
  }
  constexpr std::size_t kMaxSample = 200'000;
  std::vector<Descriptor256> sample;
  const std::size_t stride = (all.size() + kMaxSample - 1) / kMaxSample;
  for (std::size_t i = 0; i < all.size(); i += stride) sample.push_back(all[i]);
  return {std::make_shared<const AppearanceVocabulary>(AppearanceVocabulary::Train(sample)), true};
}

std::string OrderText(const std::vector<int>& order) {
  std::string text;
  for (int g : order) text += (text.empty() ? "" : " ") + std::to_string(g);
  return text;
}

// The submissions the options name, checked before anything is read.
struct DreamIds {
  std::vector<Uuid> groups;
  Uuid held_out;
};

DreamIds CheckDreamArgs(const DreamArgs& args) {
  DreamIds ids;
  for (const std::string& text : args.groups) {
    ids.groups.push_back(ParseUuidArgument(text, "--groups submission"));
  }
  ids.held_out = ParseUuidArgument(args.held_out, "--held-out submission");
  if (ids.groups.empty() || ids.groups.size() > static_cast<std::size_t>(kMaxDreamGroups)) {
    throw Error(ErrorCode::kInvalidArgument,
                "--groups: dreaming merges 1 to " + std::to_string(kMaxDreamGroups) +
                    " groups (k! orders), not " + std::to_string(ids.groups.size()));
  }
  if (std::set<Uuid>(ids.groups.begin(), ids.groups.end()).size() != ids.groups.size()) {
    throw Error(ErrorCode::kInvalidArgument, "--groups names a submission twice");
  }
  if (std::find(ids.groups.begin(), ids.groups.end(), ids.held_out) != ids.groups.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "--held-out submission " + ids.held_out.ToString() +
                    " is also a group: held-out data must not build the maps it judges");
  }
  if (args.max_orders && *args.max_orders == 0) {
    throw Error(ErrorCode::kInvalidArgument, "--max-orders must be at least 1");
  }
  if (args.group_seconds && !(*args.group_seconds > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "--group-seconds (T_G of Eq. 8) must be > 0");
  }
  if (!args.out.empty()) RequireNewStore(args.out, "--out");
  return ids;
}

// What a dream read, made and wrote: everything its report shows.
struct DreamOutcome {
  DreamIds ids;
  std::vector<GraphBatch> groups;
  std::vector<HeldOutOuting> held_out;
  std::vector<HeldOutReplay> replays;  // one per order of `result`
  DreamResult result;
  std::optional<StoreStats> written;  // the best map in --out
  double t_merge = 0.0;
  double t_copy = 0.0;
  std::optional<double> predicted;  // Eq. 8, given --group-seconds
  std::size_t held_out_frames = 0;
};

void PrintDreamJson(const DreamArgs& args, const DreamOutcome& d) {
  nlohmann::ordered_json json;
  json["groups"] = nlohmann::ordered_json::array();
  for (const Uuid& id : d.ids.groups) json["groups"].push_back(id.ToString());
  json["held_out"] = {{"submission", d.ids.held_out.ToString()},
                      {"outings", d.held_out.size()},
                      {"frames", d.held_out_frames}};
  json["gap_m"] = kGapM;
  json["orders"] = nlohmann::ordered_json::array();
  for (std::size_t i = 0; i < d.result.orders.size(); ++i) {
    const HeldOutReplay& replay = d.replays.at(i);
    json["orders"].push_back({{"order", d.result.orders[i].order},
                              {"p_gap_exceeds", replay.ProbabilityGapExceeds(kGapM)},
                              {"not_localised", replay.FractionNotLocalised()},
                              {"frames", replay.frames},
                              {"localised_frames", replay.localised_frames},
                              {"nodes", d.result.orders[i].nodes},
                              {"score", d.result.orders[i].score}});
  }
  json["best"] = d.result.best;
  json["timings"] = {{"merges", d.result.merge_seconds.size()},
                     {"first_merges", d.result.first_merge_seconds.size()},
                     {"copies", d.result.copy_seconds.size()},
                     {"t_merge_mean_s", d.t_merge},
                     {"t_copy_mean_s", d.t_copy},
                     {"score_s", d.result.score_seconds},
                     {"total_s", d.result.seconds}};
  if (d.predicted) {
    json["eq8"] = {{"t_group_s", *args.group_seconds}, {"predicted_ratio", *d.predicted}};
  }
  if (d.written) {
    json["out"] = {{"uri", args.out},
                   {"nodes", d.written->nodes},
                   {"edges", d.written->edges},
                   {"paths", d.written->paths}};
  }
  std::cout << JsonText(json, 2) << "\n";
}

void PrintDreamText(const DreamArgs& args, const DreamOutcome& d) {
  const auto count = [](std::size_t n, std::string_view one, std::string_view many = {}) {
    return Count(static_cast<std::int64_t>(n), one, many);
  };
  std::printf("dreaming (seed 004 §VI-E): %s, %zu of %zu! orders, %s, %s\n",
              count(d.ids.groups.size(), "group").c_str(), d.result.orders.size(),
              d.ids.groups.size(), count(d.result.plan.merges, "merge").c_str(),
              count(d.result.plan.copies, "copy", "copies").c_str());
  for (std::size_t g = 0; g < d.ids.groups.size(); ++g) {
    std::printf("  group %zu  submission %s (%s)\n", g, d.ids.groups[g].ToString().c_str(),
                count(d.groups[g].nodes.size(), "node").c_str());
  }
  std::printf("  held out  submission %s (%s, %s)\n", d.ids.held_out.ToString().c_str(),
              count(d.held_out.size(), "outing").c_str(),
              count(d.held_out_frames, "frame").c_str());
  std::printf("\n%-24s  %14s  %13s  %6s\n", "ORDER", "P(gap > 10 m)", "NOT LOCALISED", "NODES");
  for (std::size_t i = 0; i < d.result.orders.size(); ++i) {
    const HeldOutReplay& replay = d.replays.at(i);
    std::printf("%-24s  %14.4f  %12.1f%%  %6zu%s\n", OrderText(d.result.orders[i].order).c_str(),
                replay.ProbabilityGapExceeds(kGapM), 100.0 * replay.FractionNotLocalised(),
                d.result.orders[i].nodes, i == d.result.best ? "  <- best" : "");
  }
  const HeldOutReplay& best = d.replays.at(d.result.best);
  std::printf(
      "\nbest order: %s (P(gap > 10 m) %.4f, %.1f %% not localised, %zu nodes; lower P "
      "is better, ties by the share not localised)\n",
      OrderText(d.result.orders[d.result.best].order).c_str(), best.ProbabilityGapExceeds(kGapM),
      100.0 * best.FractionNotLocalised(), d.result.orders[d.result.best].nodes);
  std::printf(
      "timings: %s of a group into the empty map (mean %.2f s), %s into a parent's map "
      "(T_M mean %.2f s), %s (T_C mean %.3f s), scoring %.2f s, whole run %.2f s\n",
      count(d.result.first_merge_seconds.size(), "merge").c_str(),
      Mean(d.result.first_merge_seconds), count(d.result.merge_seconds.size(), "merge").c_str(),
      d.t_merge, count(d.result.copy_seconds.size(), "copy", "copies").c_str(), d.t_copy,
      d.result.score_seconds, d.result.seconds);
  if (d.predicted) {
    std::printf(
        "Eq. 8: with T_G = %.1f s, dreaming takes %.4f of the time of re-running "
        "single-agent EBN for every order\n",
        *args.group_seconds, *d.predicted);
  }
  if (d.written) {
    std::printf("best map written to %s: %lld nodes, %lld edges, %lld paths\n", args.out.c_str(),
                static_cast<long long>(d.written->nodes), static_cast<long long>(d.written->edges),
                static_cast<long long>(d.written->paths));
  }
}

void RunDream(const DreamArgs& args) {
  DreamOutcome d;
  d.ids = CheckDreamArgs(args);

  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const auto read = [&](const Uuid& id, const std::string& option) {
    try {
      return repository->ReadSubmission(id);
    } catch (const Error& error) {
      throw InContext(error, option + " (in " + repository->uri() + ")");
    }
  };
  for (const Uuid& id : d.ids.groups) d.groups.push_back(read(id, "--groups"));
  const GraphBatch held_out_map = read(d.ids.held_out, "--held-out");
  d.held_out = HeldOutOutings(held_out_map);
  const DreamWords words = DreamVocabulary(*repository, d.groups);
  if (words.trained) {
    std::cerr << "dream: " << repository->uri()
              << " has no appearance vocabulary yet; trained one from the groups\n";
  }

  // The repository's merge options, and its localiser for the held-out replay, so candidates
  // are judged as MERGE judges segments.
  DreamOptions options;
  options.merge = repository->merge_options();
  options.max_orders = args.max_orders;
  options.seed = args.seed;
  const DreamScorer scorer =
      HeldOutDreamScorer(d.held_out, options.merge.localiser, kGapM, &d.replays);
  ProgressBar bar("dreaming", std::cerr);
  d.result = Dream(d.groups, GraphBatch{}, words.vocabulary, scorer, options,
                   [&bar](std::size_t done, std::size_t all) {
                     bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(all));
                   });
  bar.Finish();

  if (!args.out.empty()) d.written = WriteNewStore(args.out, "--out", d.result.best_content);
  const int k = static_cast<int>(d.groups.size());
  d.t_merge = Mean(d.result.merge_seconds);
  d.t_copy = Mean(d.result.copy_seconds);
  if (args.group_seconds)
    d.predicted = DreamingTimeRatio(k, *args.group_seconds, d.t_merge, d.t_copy);
  for (const HeldOutOuting& outing : d.held_out) d.held_out_frames += outing.frames.size();

  if (args.json) {
    PrintDreamJson(args, d);
  } else {
    PrintDreamText(args, d);
  }
}

}  // namespace

void AddDreamCommand(CLI::App& app) {
  auto args = std::make_shared<DreamArgs>();
  CLI::App* dream =
      app.add_subcommand("dream", "Merge groups of submissions in every order; keep the best map");
  dream->footer(
      "Dreaming (seed 004 §VI-E): MERGEs the maps of k group submissions into an empty map in "
      "every order (k!, or a seeded sample of --max-orders), sharing the merges of common "
      "prefixes, with the repository's merge options and appearance vocabulary. Each candidate "
      "is scored by replaying the held-out submission against it, outing by outing from lost "
      "(seed 004 §VI-B): P(gap > 10 m), the share of frames after more than 10 m of visual "
      "odometry without localisation; lower is better, ties go to the fewer frames not "
      "localised. Prints every order, the best, the timings (T_M, T_C) and, given "
      "--group-seconds, Eq. 8's predicted share of the time single-agent EBN would take. "
      "The repository is only read; --out writes the best map into a new store.");
  AddStoreOption(*dream, args->store);
  dream
      ->add_option("--groups", args->groups,
                   "Group submissions S1,S2,... (1 to " + std::to_string(kMaxDreamGroups) + ")")
      ->required()
      ->delimiter(',');
  dream->add_option("--held-out", args->held_out, "The held-out submission that judges the maps")
      ->required();
  dream->add_option("--max-orders", args->max_orders,
                    "Explore at most this many orders, drawn with --seed (default: all k!)");
  dream->add_option("--seed", args->seed, "Seed of the sample of orders")->capture_default_str();
  dream->add_option("--group-seconds", args->group_seconds,
                    "T_G of Eq. 8: seconds to build one group's map by single-agent EBN; "
                    "prints the predicted time ratio (default: not shown)");
  dream->add_option("--out", args->out, "Write the best order's map into this new store");
  dream->add_flag("--json", args->json, "Print JSON");
  dream->callback([args] { RunDream(*args); });
}

}  // namespace fleetmap::cli
