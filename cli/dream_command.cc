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
#include "fleetmap/policies/dream_plan.h"
#include "fleetmap/policies/dreaming.h"
#include "fleetmap/policies/held_out_replay.h"
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

void RunDream(const DreamArgs& args) {
  // Everything the user typed is checked before anything is read.
  std::vector<Uuid> group_ids;
  for (const std::string& text : args.groups) {
    group_ids.push_back(ParseUuidArgument(text, "--groups submission"));
  }
  const Uuid held_out_id = ParseUuidArgument(args.held_out, "--held-out submission");
  if (group_ids.empty() || group_ids.size() > 12) {
    throw Error(ErrorCode::kInvalidArgument,
                "--groups: dreaming merges 1 to 12 groups (k! orders), not " +
                    std::to_string(group_ids.size()));
  }
  if (std::set<Uuid>(group_ids.begin(), group_ids.end()).size() != group_ids.size()) {
    throw Error(ErrorCode::kInvalidArgument, "--groups names a submission twice");
  }
  if (std::find(group_ids.begin(), group_ids.end(), held_out_id) != group_ids.end()) {
    throw Error(ErrorCode::kInvalidArgument,
                "--held-out submission " + held_out_id.ToString() +
                    " is also a group: held-out data must not build the maps it judges");
  }
  if (args.max_orders && *args.max_orders == 0) {
    throw Error(ErrorCode::kInvalidArgument, "--max-orders must be at least 1");
  }
  if (args.group_seconds && !(*args.group_seconds > 0)) {
    throw Error(ErrorCode::kInvalidArgument, "--group-seconds (T_G of Eq. 8) must be > 0");
  }
  if (!args.out.empty()) RequireNewStore(args.out, "--out");

  const std::unique_ptr<Repository> repository = OpenRepository(args.store);
  const auto read = [&](const Uuid& id, const std::string& option) {
    try {
      return repository->ReadSubmission(id);
    } catch (const Error& error) {
      throw InContext(error, option + " (in " + repository->store().uri() + ")");
    }
  };
  std::vector<GraphBatch> groups;
  for (const Uuid& id : group_ids) groups.push_back(read(id, "--groups"));
  const GraphBatch held_out_map = read(held_out_id, "--held-out");
  const std::vector<HeldOutOuting> held_out = HeldOutOutings(held_out_map);
  const DreamWords words = DreamVocabulary(*repository, groups);
  if (words.trained) {
    std::cerr << "dream: " << repository->store().uri()
              << " has no appearance vocabulary yet; trained one from the groups\n";
  }

  // The repository's merge options, and its localiser for the held-out replay, so candidates
  // are judged as MERGE judges segments.
  DreamOptions options;
  options.merge = repository->merge_options();
  options.max_orders = args.max_orders;
  options.seed = args.seed;
  std::vector<HeldOutReplay> replays;
  const DreamScorer scorer = HeldOutDreamScorer(held_out, options.merge.localiser, kGapM, &replays);
  ProgressBar bar("dreaming", std::cerr);
  const DreamResult result =
      Dream(groups, GraphBatch{}, words.vocabulary, scorer, options,
            [&bar](std::size_t done, std::size_t all) {
              bar.Update(static_cast<std::int64_t>(done), static_cast<std::int64_t>(all));
            });
  bar.Finish();

  std::optional<StoreStats> written;
  if (!args.out.empty()) written = WriteNewStore(args.out, "--out", result.best_content);
  const int k = static_cast<int>(groups.size());
  const double t_merge = Mean(result.merge_seconds);
  const double t_copy = Mean(result.copy_seconds);
  std::optional<double> predicted;
  if (args.group_seconds) predicted = DreamingTimeRatio(k, *args.group_seconds, t_merge, t_copy);
  std::size_t held_out_frames = 0;
  for (const HeldOutOuting& outing : held_out) held_out_frames += outing.frames.size();

  if (args.json) {
    nlohmann::ordered_json json;
    json["groups"] = nlohmann::ordered_json::array();
    for (const Uuid& id : group_ids) json["groups"].push_back(id.ToString());
    json["held_out"] = {{"submission", held_out_id.ToString()},
                        {"outings", held_out.size()},
                        {"frames", held_out_frames}};
    json["gap_m"] = kGapM;
    json["orders"] = nlohmann::ordered_json::array();
    for (std::size_t i = 0; i < result.orders.size(); ++i) {
      const HeldOutReplay& replay = replays.at(i);
      json["orders"].push_back({{"order", result.orders[i].order},
                                {"p_gap_exceeds", replay.ProbabilityGapExceeds(kGapM)},
                                {"not_localised", replay.FractionNotLocalised()},
                                {"frames", replay.frames},
                                {"localised_frames", replay.localised_frames},
                                {"nodes", result.orders[i].nodes},
                                {"score", result.orders[i].score}});
    }
    json["best"] = result.best;
    json["timings"] = {{"merges", result.merge_seconds.size()},
                       {"first_merges", result.first_merge_seconds.size()},
                       {"copies", result.copy_seconds.size()},
                       {"t_merge_mean_s", t_merge},
                       {"t_copy_mean_s", t_copy},
                       {"score_s", result.score_seconds},
                       {"total_s", result.seconds}};
    if (predicted) {
      json["eq8"] = {{"t_group_s", *args.group_seconds}, {"predicted_ratio", *predicted}};
    }
    if (written) {
      json["out"] = {{"uri", args.out},
                     {"nodes", written->nodes},
                     {"edges", written->edges},
                     {"paths", written->paths}};
    }
    std::cout << json.dump(2) << "\n";
    return;
  }

  const auto count = [](std::size_t n, std::string_view one, std::string_view many = {}) {
    return Count(static_cast<std::int64_t>(n), one, many);
  };
  std::printf("dreaming (seed 004 §VI-E): %s, %zu of %zu! orders, %s, %s\n",
              count(group_ids.size(), "group").c_str(), result.orders.size(), group_ids.size(),
              count(result.plan.merges, "merge").c_str(),
              count(result.plan.copies, "copy", "copies").c_str());
  for (std::size_t g = 0; g < group_ids.size(); ++g) {
    std::printf("  group %zu  submission %s (%s)\n", g, group_ids[g].ToString().c_str(),
                count(groups[g].nodes.size(), "node").c_str());
  }
  std::printf("  held out  submission %s (%s, %s)\n", held_out_id.ToString().c_str(),
              count(held_out.size(), "outing").c_str(), count(held_out_frames, "frame").c_str());
  std::printf("\n%-24s  %14s  %13s  %6s\n", "ORDER", "P(gap > 10 m)", "NOT LOCALISED", "NODES");
  for (std::size_t i = 0; i < result.orders.size(); ++i) {
    const HeldOutReplay& replay = replays.at(i);
    std::printf("%-24s  %14.4f  %12.1f%%  %6zu%s\n", OrderText(result.orders[i].order).c_str(),
                replay.ProbabilityGapExceeds(kGapM), 100.0 * replay.FractionNotLocalised(),
                result.orders[i].nodes, i == result.best ? "  <- best" : "");
  }
  const HeldOutReplay& best = replays.at(result.best);
  std::printf(
      "\nbest order: %s (P(gap > 10 m) %.4f, %.1f %% not localised, %zu nodes; lower P "
      "is better, ties by the share not localised)\n",
      OrderText(result.orders[result.best].order).c_str(), best.ProbabilityGapExceeds(kGapM),
      100.0 * best.FractionNotLocalised(), result.orders[result.best].nodes);
  std::printf(
      "timings: %s of a group into the empty map (mean %.2f s), %s into a parent's map "
      "(T_M mean %.2f s), %s (T_C mean %.3f s), scoring %.2f s, whole run %.2f s\n",
      count(result.first_merge_seconds.size(), "merge").c_str(), Mean(result.first_merge_seconds),
      count(result.merge_seconds.size(), "merge").c_str(), t_merge,
      count(result.copy_seconds.size(), "copy", "copies").c_str(), t_copy, result.score_seconds,
      result.seconds);
  if (predicted) {
    std::printf(
        "Eq. 8: with T_G = %.1f s, dreaming takes %.4f of the time of re-running "
        "single-agent EBN for every order\n",
        *args.group_seconds, *predicted);
  }
  if (written) {
    std::printf("best map written to %s: %lld nodes, %lld edges, %lld paths\n", args.out.c_str(),
                static_cast<long long>(written->nodes), static_cast<long long>(written->edges),
                static_cast<long long>(written->paths));
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
  dream->add_option("--groups", args->groups, "Group submissions S1,S2,... (1 to 12)")
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
