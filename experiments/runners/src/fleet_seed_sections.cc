// One seed's sections of the fleet report's summary.md (fleet_seed_report.h: SeedSections):
// each figure's tables, ours beside the paper's, and why the maps and downloads localise as
// they do (from each held-out frame's ground truth).
#include <algorithm>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "fleet_edge_errors.h"
#include "fleet_layout_errors.h"
#include "fleet_measures.h"
#include "fleet_seed_report.h"
#include "fleetmap/map_management/download_policy.h"
#include "report_text.h"

namespace fleetmap::fleet_report_internal {
namespace {

constexpr const char* kReachTableHead =
    "| map | lost (reference localised) | no node near | near, none localises | one localises, "
    "not a candidate | of those: lost / not reached from n_k / placed beyond the radius / n_k "
    "far from the frame | a candidate, ranked below Np | tried |\n"
    "|---|---|---|---|---|---|---|---|\n";

std::string ReachTableRow(const std::string& map, const FleetReach& r) {
  std::ostringstream row;
  row << "| " << map << " | " << r.lost << " | " << r.no_node_near << " | " << r.none_localises
      << " | " << r.not_candidate << " | " << r.not_candidate_lost << " / "
      << r.not_candidate_unreached << " / " << r.not_candidate_placed_far << " / "
      << r.not_candidate_reference_far << " | " << r.not_tried << " | " << r.tried << " |\n";
  return row.str();
}

// Why the downloads localise as they do, from each held-out frame's ground truth: how much of
// the mission's route the download holds a node near, and where it lost frames copy localised.
void DownloadWhy(std::ostringstream& md, const FleetExperimentResult& result,
                 const FleetExperimentOptions& options) {
  md << "Why (ground truth: a node \"near\" a frame was captured within "
     << Fixed(options.place_radius_m, 1)
     << " m of it). Of the frames lost where copy localised, the node copy localised in was "
        "held by the download too, or it was captured or used within the window, or neither "
        "(with the mean clock distance of its capture from the mission's start):\n\n"
        "| policy | route with a node near | frames lost where copy localised | of those, no node "
        "near | copy's node held / in the window / outside (h away) | paths chosen / paths in "
        "the map | nodes on them / copy | stretches where the guarantee reached outside |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const std::string& policy : RunMaps(result, kFig9Policies)) {
    std::int64_t frames = 0, near = 0, lost = 0, lost_empty = 0, held = 0, inside = 0, outside = 0;
    double hours = 0;
    double chosen = 0, map_paths = 0, on_paths = 0, copy_nodes = 0, reached = 0, stretches = 0;
    std::size_t n = 0;
    for (const FleetDownload& d : result.downloads) {
      if (d.policy != policy) continue;
      ++n;
      frames += d.frames;
      near += d.frames_with_node_near;
      lost += d.lost_vs_copy;
      lost_empty += d.lost_vs_copy_no_node_near;
      held += d.lost_copy_node_held;
      inside += d.lost_copy_node_in_window;
      outside += d.lost_copy_node_outside_window;
      hours += d.lost_copy_node_hours_away * static_cast<double>(d.lost_copy_node_outside_window);
      chosen += static_cast<double>(d.paths_chosen);
      map_paths += static_cast<double>(d.map_paths);
      on_paths += static_cast<double>(d.nodes_on_chosen_paths);
      copy_nodes += static_cast<double>(d.copy_nodes);
      reached += static_cast<double>(d.stretches_reached_outside);
      stretches += static_cast<double>(d.stretches);
    }
    if (n == 0) continue;
    const bool paths = policy.find("paths") != std::string::npos;
    const bool cover = policy.find("cover") != std::string::npos;
    md << "| " << policy << " | "
       << Percent(frames == 0 ? kNaN : static_cast<double>(near) / static_cast<double>(frames))
       << " % | " << lost << " of " << frames << " | "
       << (lost == 0 ? std::string("-")
                     : Percent(static_cast<double>(lost_empty) / static_cast<double>(lost)) + " %")
       << " | "
       << (lost == 0
               ? std::string("-")
               : std::to_string(held) + " / " + std::to_string(inside) + " / " +
                     std::to_string(outside) + " (" +
                     Fixed(outside == 0 ? 0.0 : hours / static_cast<double>(outside), 1) + ")")
       << " | "
       << (paths ? Fixed(chosen / static_cast<double>(n), 1) + " / " +
                       Fixed(map_paths / static_cast<double>(n), 1)
                 : std::string("-"))
       << " | " << (paths ? Percent(on_paths / copy_nodes) + " %" : std::string("-")) << " | "
       << (cover ? Fixed(reached / static_cast<double>(n), 1) + " of " +
                       Fixed(stretches / static_cast<double>(n), 1)
                 : std::string("-"))
       << " |\n";
  }
  md << "\nCould the localiser reach the experience it needed (as for the merged map, Fig. 7)? "
        "Each frame a download lost where copy localised:\n\n"
     << kReachTableHead;
  for (const std::string& policy : RunMaps(result, kFig9Policies)) {
    if (policy == "copy") continue;
    FleetReach reach;
    for (const FleetDownload& d : result.downloads) {
      if (d.policy == policy) reach += d.reach;
    }
    md << ReachTableRow(policy, reach);
  }
  md << "\n";
}

// EBN's CPU per frame against the map it localises in, over the single-agent builds' outings in
// four bins of equal count by map size: where the paper's time saving can come from.
void FrameCostWhy(std::ostringstream& md, const FleetExperimentResult& result) {
  double wall = 0, push = 0, algorithm = 0, call = 0, index = 0, region = 0, write = 0;
  for (const FleetBuild& b : result.builds) {
    if (!IsNumbered(b.map, "merge ")) continue;
    wall += b.wall_seconds;
    push += b.push_seconds;
    algorithm += b.merge_algorithm_seconds;
    call += b.merge_call_seconds;
    index += b.merge_index_seconds;
    region += b.merge_region_seconds;
    write += b.merge_write_seconds;
  }
  if (wall > 0) {
    md << "The merges' wall time, " << Fixed(wall, 1) << " s over every fold: pushing the "
       << "submissions " << Percent(push / wall) << " %, MERGE's replay and decisions "
       << Percent(algorithm / wall) << " %, the rest of the merge call "
       << Percent((call - algorithm) / wall) << " % (the vocabularies and appearance index "
       << Percent(index / wall) << " %, loading the region " << Percent(region / wall)
       << " %, writing the revision " << Percent(write / wall) << " %); the merge calls took "
       << Fixed(algorithm > 0 ? call / algorithm : 0.0, 2) << " x their replay and decisions.\n\n";
  }
  std::vector<FleetFrameCost> rows = result.frame_costs;
  if (rows.size() < 4) return;
  std::sort(rows.begin(), rows.end(), [](const FleetFrameCost& a, const FleetFrameCost& b) {
    return a.map_nodes < b.map_nodes;
  });
  md << "EBN's cost per frame against map size (single-agent builds, every outing; CPU):\n\n"
        "| map nodes (mean) | outings | CPU ms / frame |\n|---|---|---|\n";
  std::vector<double> per_frame, nodes;
  for (std::size_t bin = 0; bin < 4; ++bin) {
    const std::size_t begin = rows.size() * bin / 4, end = rows.size() * (bin + 1) / 4;
    double cpu = 0, map_nodes = 0;
    std::int64_t frames = 0;
    for (std::size_t i = begin; i < end; ++i) {
      cpu += rows[i].cpu_seconds;
      frames += rows[i].frames;
      map_nodes += static_cast<double>(rows[i].map_nodes);
    }
    nodes.push_back(map_nodes / static_cast<double>(end - begin));
    per_frame.push_back(frames == 0 ? kNaN : 1000.0 * cpu / static_cast<double>(frames));
    md << "| " << Fixed(nodes.back(), 0) << " | " << end - begin << " | "
       << Fixed(per_frame.back(), 3) << " |\n";
  }
  md << "\nFrom the smallest maps to the largest the map grows "
     << Fixed(nodes[3] / std::max(1.0, nodes[0]), 1) << "× and the cost per frame "
     << Fixed(per_frame[3] / per_frame[0], 2)
     << "×. Our localiser searches a bounded neighbourhood (seed 002 §III-C) and asks the "
        "appearance index only when lost"
     << (per_frame[3] / per_frame[0] < 0.5 * nodes[3] / std::max(1.0, nodes[0])
             ? ", so its cost per frame grows far slower than the map"
             : "; even so its cost per frame grows with the map")
     << ". The paper's FAB-MAP relocalisation compares a frame with every place, so its cost "
        "grows with the map, and k small maps built in parallel save most where the map is "
        "large; the less a frame's cost grows with the map, the less the merging strategy can "
        "save beyond running the groups side by side.\n\n";
}

// Why the merged map holds what it holds, against single-agent EBN's, per ground-truth stretch.
void MergeWhy(std::ostringstream& md, const FleetExperimentResult& result,
              const FleetExperimentOptions& options) {
  FleetMergeDiagnosis sum;
  for (const FleetMergeDiagnosis& d : result.merge_diagnoses) {
    sum.stretches += d.stretches;
    sum.stretches_more += d.stretches_more;
    sum.nodes_more += d.nodes_more;
    sum.stretches_fewer += d.stretches_fewer;
    sum.nodes_fewer += d.nodes_fewer;
    sum.frames += d.frames;
    sum.single_lost += d.single_lost;
    sum.merged_lost += d.merged_lost;
    sum.merged_lost_where_fewer += d.merged_lost_where_fewer;
    sum.merged_only_lost += d.merged_only_lost;
    sum.merged_only_lost_where_fewer += d.merged_only_lost_where_fewer;
    sum.reach += d.reach;
  }
  if (sum.stretches == 0) return;
  md << "Why, per ground-truth stretch of " << Fixed(options.coverage.stretch_m, 0)
     << " m over every fold: the merged map holds more nodes than single-agent's in "
     << sum.stretches_more << " of " << sum.stretches << " stretches (" << sum.nodes_more
     << " nodes more) and fewer in " << sum.stretches_fewer << " (" << sum.nodes_fewer
     << " fewer). Held-out frames not localised: single-agent " << sum.single_lost << ", merged "
     << sum.merged_lost << " of " << sum.frames << "; " << sum.merged_only_lost
     << " lost only in the merged map, " << sum.merged_only_lost_where_fewer
     << " of them in stretches where it holds fewer nodes than single-agent's (all merged losses "
        "there: "
     << sum.merged_lost_where_fewer << ").\n\n";
  md << "Could the localiser reach the experience it needed? Of the " << sum.merged_only_lost
     << " frames lost only in the merged map, by the merged nodes captured within "
     << Fixed(options.place_radius_m, 0)
     << " m of each (ground truth) and which of them localise it when tried one by one:\n\n"
     << kReachTableHead << ReachTableRow("merged vs single-agent", sum.reach) << "\n";
}

// A verdict line's value; NaN when the verdict has no such line.
double ValueOf(const FleetVerdict& v, const std::string& name) {
  const FleetRatio* line = v.Find(name);
  return line == nullptr ? kNaN : line->value;
}

void Fig7Section(std::ostringstream& md, const FleetExperimentResult& result, const FleetVerdict& v,
                 const std::string& h) {
  const std::map<int, FoldTimes> times = TimesByFold(result);
  const auto value = [&](const std::string& name) { return ValueOf(v, name); };

  md << h << " Fig. 7: building good maps quickly\n\n"
     << "| fold | single-agent nodes | merged nodes | ratio | single-agent CPU s | slowest "
        "group CPU s | merges CPU s | strategy / single (CPU) |\n"
        "|---|---|---|---|---|---|---|---|\n";
  for (const auto& [fold, t] : times) {
    md << "| " << fold << " | " << t.single_nodes << " | " << t.merged_nodes << " | "
       << Percent(Ratio(static_cast<double>(t.merged_nodes), static_cast<double>(t.single_nodes)))
       << " % | " << Fixed(t.single_cpu, 1) << " | " << Fixed(t.slowest_group_cpu, 1) << " | "
       << Fixed(t.merges_cpu, 1) << " | " << Percent(Ratio(t.strategy_cpu, t.single_cpu))
       << " % |\n";
  }
  md << "\n| map | mean nodes | not localised (frames) | P(X > 10 m) (frames) |\n"
        "|---|---|---|---|\n";
  for (const std::string& map : RunMaps(result, kFig7Maps)) {
    const auto r = RunsOf(result, map);
    std::size_t nodes = 0;
    for (const HeldOutRun* run : r) nodes += run->map_nodes;
    const Count lost = NotLocalisedCount(r), p10 = GapCount(r, kHeadlineGap_m);
    md << "| " << map << " | " << (r.empty() ? 0 : nodes / r.size()) << " | "
       << Percent(Fraction(lost), 2) << " % (" << CountText(lost) << ") | "
       << Fixed(Fraction(p10), 4) << " (" << CountText(p10) << ") |\n";
  }
  md << "\n| measure | paper | ours |\n|---|---|---|\n"
     << "| merged nodes / single-agent nodes | " << Percent(kPaperMergedNodes, 2) << " % | "
     << Percent(value(kMergedNodes)) << " % |\n"
     << "| merging time / single-agent time (groups in parallel) | " << Percent(kPaperMergedTime, 2)
     << " % | " << Percent(value(kMergingWall)) << " % wall, " << Percent(value(kMergingCpu))
     << " % CPU |\n"
     << "| total CPU of the merging strategy (all groups + merges) / single-agent CPU | - | "
     << Percent(value(kTotalCpu)) << " % |\n"
     << "| single-agent nodes MERGE keeps, merged into an empty map | - | "
     << Percent(SelfMergeRatio(times)) << " % |\n"
     << "| held-out frames not localised, single-agent | " << Percent(kPaperSingleNotLocalised, 2)
     << " % | " << Percent(Fraction(NotLocalisedCount(RunsOf(result, "single"))), 2) << " % |\n"
     << "| held-out frames not localised, merged | " << Percent(kPaperMergedNotLocalised, 2)
     << " % | " << Percent(Fraction(NotLocalisedCount(RunsOf(result, "merged"))), 2) << " % |\n\n";
}

void Fig8Section(std::ostringstream& md, const FleetExperimentResult& result,
                 const std::string& h) {
  md << h << " Fig. 8: sharing expertise between two robots\n\n";
  const std::vector<std::string> fig8 = RunMaps(result, {"shared", "r1", "r2"});
  if (fig8.empty()) md << "Not run (--no-sharing).\n\n";
  if (!fig8.empty())
    md << "| map | mean nodes | not localised | P(X > 10 m) |\n|---|---|---|---|\n";
  for (const std::string& map : fig8) {
    const auto r = RunsOf(result, map);
    std::size_t nodes = 0;
    for (const HeldOutRun* run : r) nodes += run->map_nodes;
    md << "| " << map << " | " << (r.empty() ? 0 : nodes / r.size()) << " | "
       << Percent(Fraction(NotLocalisedCount(r)), 2) << " % | "
       << Fixed(GapExceeds(r, kHeadlineGap_m), 4) << " |\n";
  }
  if (!fig8.empty()) {
    md << "\nThe paper (Fig. 8) shows the shared map's distribution below both lone robots'.\n\n";
  }
}

void Fig9Section(std::ostringstream& md, const FleetExperimentResult& result,
                 const FleetExperimentOptions& options, const FleetVerdict& v,
                 const std::string& h) {
  const auto value = [&](const std::string& name) { return ValueOf(v, name); };
  md << h << " Fig. 9: mission-specific downloads\n\n"
     << "Each held-out outing downloads the merged map of Fig. 7 for its own start time: tod "
        "with T_w = "
     << (options.tod_window_min > 0 ? Fixed(options.tod_window_min, 0) + " min"
                                    : Fixed(ParseDownloadPolicy("tod").window_min, 0) + " min (" +
                                          Fixed(kCoverWindowMin, 0) + " with cover)")
     << ", tod+paths with the best " << Fixed(options.paths_percent, 0) << " % of paths per "
     << Fixed(options.epoch_min, 0)
     << "-minute epoch.\n\n| policy | paper: nodes / copy | ours: nodes / copy | not "
        "localised | P(X > 10 m) (frames) | P(X > 10 m) / copy's (smoothed) |\n"
        "|---|---|---|---|---|---|\n";
  for (const std::string& policy : RunMaps(result, kFig9Policies)) {
    const auto r = RunsOf(result, policy);
    const Count p10 = GapCount(r, kHeadlineGap_m);
    const std::string paper = policy == "copy" ? "1.000" : PaperValue(policy + " nodes / copy's");
    md << "| " << policy << " | " << paper << " | "
       << Fixed(policy == "copy" ? 1.0 : MeanRatio(result, policy).ratio, 3) << " | "
       << Percent(Fraction(NotLocalisedCount(r)), 2) << " % | " << Fixed(Fraction(p10), 4) << " ("
       << CountText(p10) << ") | "
       << Fixed(policy == "copy" ? 1.0 : value(policy + " P(X > 10 m) / copy's"), 3) << " |\n";
  }
  md << "\n(The paper's two figures are its two robots.)\n\n";
}

// The frontier an operator picks from, when the experiment swept it.
void FrontierSection(std::ostringstream& md, const FleetExperimentResult& result,
                     const std::string& h) {
  if (!result.frontier.empty()) {
    md << h << " The frontier an operator picks from\n\n"
       << "Each policy with its knobs swept, every held-out outing downloading for its own start "
          "time (T_w window minutes, k experiences per stretch, cap, p paths share); against copy "
          "on the same frames. Points on the frontier need no more nodes than any point that "
          "fails less (frontier.csv, frontier.png).\n\n"
          "| policy | nodes / copy | bytes / copy | P(X > 10 m) / copy | not localised / copy | "
          "on the frontier |\n|---|---|---|---|---|---|\n";
    for (const FrontierSummary& p : SummariseFrontier(result)) {
      md << "| " << p.label << " | " << Fixed(p.node_share, 3) << " | " << Fixed(p.byte_share, 3)
         << " | " << Fixed(p.p10_ratio, 3) << " | " << Fixed(p.not_localised_ratio, 3) << " | "
         << (p.on_frontier ? "yes" : "") << " |\n";
    }
    md << "\n";
  }
}

void Fig10Section(std::ostringstream& md, const FleetExperimentResult& result,
                  const std::string& h) {
  md << h << " Fig. 10: dreaming, the groups merged in every order\n\n";
  if (result.dream_timings.empty()) {
    md << "Not run (dream folds: 0).\n\n";
  }
  for (const FleetDreamTiming& t : result.dream_timings) {
    double best = 1.0, worst = 0.0;
    std::string best_order;
    for (const FleetDreamOrder& o : result.dream_orders) {
      if (o.fold != t.fold) continue;
      if (o.score < best) {
        best = o.score;
        best_order.clear();
        for (int g : o.order) best_order += std::to_string(g);
      }
      worst = std::max(worst, o.score);
    }
    md << "Fold " << t.fold << ": " << t.orders << " orders of " << t.groups
       << " groups, P(X > 10 m) from " << Fixed(best, 4) << " (order " << best_order << ") to "
       << Fixed(worst, 4) << ". " << t.merges << " merges and " << t.copies
       << " copies (Eq. 8 counts " << (t.orders * static_cast<std::size_t>(t.groups - 1))
       << " merges).\n\n"
       << "| | T_G (group EBN) | T_M (merge) | T_C (copy) | dreaming / single-agent |\n"
       << "|---|---|---|---|---|\n"
       << "| paper | 10823 s | 1829 s | 27 s | " << Percent(kPaperEq8, 2) << " % (Eq. 8) |\n"
       << "| ours, Eq. 8 with our times | " << Fixed(t.group_seconds, 2) << " s | "
       << Fixed(t.merge_seconds, 3) << " s | " << Fixed(t.copy_seconds, 3) << " s | "
       << Percent(t.predicted_ratio, 2)
       << " % |\n"
       // Not a measured ratio: the denominator is Eq. 8's model of single-agent EBN.
       << "| ours, measured dreaming (" << Fixed(t.dream_seconds, 1)
       << " s) / modelled single-agent (Eq. 8 denominator) | | | | " << Percent(t.measured_ratio, 2)
       << " % |\n\n";
  }
}

}  // namespace

void SeedSections(std::ostringstream& md, const FleetExperimentResult& result,
                  const FleetExperimentOptions& options, const FleetVerdict& v,
                  const std::string& h) {
  Fig7Section(md, result, v, h);
  WriteEdgeErrorTable(md, result);
  WriteLayoutErrorTable(md, result);
  MergeWhy(md, result, options);
  FrameCostWhy(md, result);
  Fig8Section(md, result, h);
  Fig9Section(md, result, options, v, h);
  DownloadWhy(md, result, options);
  FrontierSection(md, result, h);
  Fig10Section(md, result, h);
}

}  // namespace fleetmap::fleet_report_internal
