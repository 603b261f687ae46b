#include <algorithm>
#include <cmath>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/lifelong_report.h"
#include "lifelong_held_out.h"

namespace fleetmap {
namespace {

using lifelong_internal::HeldOutIn;
using lifelong_internal::Smoothed;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// "day 4" or "days 21-30".
std::string DaysText(int first, int last) {
  return first == last ? "day " + std::to_string(first)
                       : "days " + std::to_string(first) + "-" + std::to_string(last);
}

std::string Counts(std::int64_t k, std::int64_t n) {
  return std::to_string(k) + "/" + std::to_string(n);
}

// The line over seeds from each seed's value (lifelong_report.h: LifelongLine).
LifelongLine Line(std::string name, double bound, std::vector<double> per_seed,
                  std::vector<std::string> per_seed_counts) {
  LifelongLine line{std::move(name), bound, std::move(per_seed), std::move(per_seed_counts)};
  double sum = 0.0;
  bool judged = true;
  for (const double v : line.per_seed) {
    if (std::isnan(v)) judged = false;
    sum += v;
    line.worst = std::max(line.worst, v);
  }
  line.mean = sum / static_cast<double>(line.per_seed.size());
  if (!judged) line.worst = kNaN;
  line.pass = judged && line.mean <= bound && line.worst <= 2 * bound;
  return line;
}

// An arm's two lines over the seeds' verdicts.
void AddArmLines(const std::string& arm, const std::vector<LifelongVerdict>& verdicts,
                 std::vector<LifelongLine>& lines) {
  const LifelongVerdict& first = verdicts.front();
  const std::string windows = DaysText(first.late_first, first.late_last) + " / " +
                              DaysText(first.early_first, first.early_last);
  std::vector<double> growth, p10;
  std::vector<std::string> growth_counts, p10_counts;
  for (const LifelongVerdict& v : verdicts) {
    growth.push_back(v.growth);
    growth_counts.push_back(std::to_string(v.late_added) + " / " + std::to_string(v.early_added));
    p10.push_back(v.copy_p10_ratio);
    p10_counts.push_back(Counts(v.late_beyond, v.late_frames) + " vs " +
                         Counts(v.early_beyond, v.early_frames));
  }
  lines.push_back(Line(arm + "nodes MERGE added, " + windows, kLifelongGrowthBound,
                       std::move(growth), std::move(growth_counts)));
  lines.push_back(Line(arm + "copy's P(X > 10 m), " + windows, kLifelongP10Bound, std::move(p10),
                       std::move(p10_counts)));
}

}  // namespace

LifelongWindows LifelongWindowsOf(int days) {
  if (days < 3) throw Error(ErrorCode::kInvalidArgument, "lifelong: judging needs >= 3 days");
  if (days >= 30) return {1, 10, 21, 30};
  const int third = days / 3;
  return {1, third, days - third + 1, days};
}

LifelongVerdict JudgeLifelong(std::span<const LifelongDay> days) {
  const LifelongWindows w = LifelongWindowsOf(static_cast<int>(days.size()));
  LifelongVerdict v;
  v.early_first = w.early_first, v.early_last = w.early_last;
  v.late_first = w.late_first, v.late_last = w.late_last;
  for (const LifelongDay& day : days) {
    const bool early = day.day >= v.early_first && day.day <= v.early_last;
    const bool late = day.day >= v.late_first && day.day <= v.late_last;
    if (!early && !late) continue;
    const LifelongHeldOut* copy = HeldOutIn(day, "copy");
    (early ? v.early_added : v.late_added) += day.nodes_added;
    if (copy != nullptr) {
      (early ? v.early_beyond : v.late_beyond) += copy->beyond_10m;
      (early ? v.early_frames : v.late_frames) += copy->frames;
    }
  }
  v.growth = v.early_added == 0
                 ? (v.late_added == 0 ? 0.0 : 1e9)
                 : static_cast<double>(v.late_added) / static_cast<double>(v.early_added);
  v.copy_p10_ratio =
      Smoothed(v.late_beyond, v.late_frames) / Smoothed(v.early_beyond, v.early_frames);
  v.growth_pass = v.growth <= kLifelongGrowthBound;
  v.p10_pass = v.copy_p10_ratio <= kLifelongP10Bound;
  return v;
}

bool RetirementVerdict::all() const {
  return size_pass && std::all_of(held_out.begin(), held_out.end(), [](const RetiredHeldOut& h) {
           return h.p10_pass && h.not_localised_pass;
         });
}

RetirementVerdict JudgeRetirement(std::span<const LifelongDay> without,
                                  std::span<const LifelongDay> with) {
  const LifelongWindows w = LifelongWindowsOf(static_cast<int>(with.size()));
  const bool same_days =
      without.size() == with.size() &&
      std::equal(without.begin(), without.end(), with.begin(),
                 [](const LifelongDay& a, const LifelongDay& b) { return a.day == b.day; });
  if (!same_days) {
    throw Error(ErrorCode::kInvalidArgument,
                "lifelong: the arms with and without retirement must run the same days");
  }
  RetirementVerdict v;
  const LifelongDay& middle = with[with.size() / 2 - 1];
  v.middle_day = middle.day;
  v.middle_nodes = middle.map_nodes;
  v.last_day = with.back().day;
  v.last_nodes = with.back().map_nodes;
  v.size_ratio = v.middle_nodes == 0
                     ? (v.last_nodes == 0 ? 0.0 : 1e9)
                     : static_cast<double>(v.last_nodes) / static_cast<double>(v.middle_nodes);
  v.size_pass = v.size_ratio <= kRetiredSizeBound;

  v.late_first = w.late_first;
  v.late_last = w.late_last;
  for (const std::string& map : kRetirementJudgedMaps) {
    RetiredHeldOut h;
    h.map = map;
    bool held_without = false, held_with = false;
    for (std::size_t i = 0; i < with.size(); ++i) {
      if (with[i].day < w.late_first || with[i].day > w.late_last) continue;
      if (const LifelongHeldOut* a = HeldOutIn(without[i], map)) {
        held_without = true;
        h.frames_without += a->frames;
        h.beyond_without += a->beyond_10m;
        h.not_localised_without += a->not_localised;
      }
      if (const LifelongHeldOut* b = HeldOutIn(with[i], map)) {
        held_with = true;
        h.frames_with += b->frames;
        h.beyond_with += b->beyond_10m;
        h.not_localised_with += b->not_localised;
      }
    }
    h.measured = held_without && held_with && h.frames_without > 0 && h.frames_with > 0;
    if (h.measured) {
      h.p10_ratio =
          Smoothed(h.beyond_with, h.frames_with) / Smoothed(h.beyond_without, h.frames_without);
      h.not_localised_ratio = Smoothed(h.not_localised_with, h.frames_with) /
                              Smoothed(h.not_localised_without, h.frames_without);
      h.p10_pass = h.p10_ratio <= kRetiredHeldOutBound;
      h.not_localised_pass = h.not_localised_ratio <= kRetiredHeldOutBound;
    }
    v.held_out.push_back(std::move(h));
  }
  return v;
}

bool LifelongAcceptance::all() const {
  return std::all_of(lines.begin(), lines.end(), [](const LifelongLine& l) { return l.pass; });
}

LifelongAcceptance JudgeLifelongSeeds(std::span<const LifelongSeedRun> seeds) {
  if (seeds.empty()) throw Error(ErrorCode::kInvalidArgument, "lifelong: no seeds to judge");
  const bool retiring = !seeds.front().result.retiring_days.empty();
  for (const LifelongSeedRun& seed : seeds) {
    if (seed.result.retiring_days.empty() == retiring ||
        seed.result.days.size() != seeds.front().result.days.size()) {
      throw Error(ErrorCode::kInvalidArgument,
                  "lifelong: every seed must run the same days and the same arms");
    }
  }
  std::vector<LifelongVerdict> without, with;
  std::vector<RetirementVerdict> retirement;
  for (const LifelongSeedRun& seed : seeds) {
    without.push_back(JudgeLifelong(seed.result.days));
    if (!retiring) continue;
    with.push_back(JudgeLifelong(seed.result.retiring_days));
    retirement.push_back(JudgeRetirement(seed.result.days, seed.result.retiring_days));
  }
  LifelongAcceptance acceptance;
  AddArmLines(retiring ? "without retirement: " : "", without, acceptance.lines);
  if (!retiring) return acceptance;
  AddArmLines("with retirement: ", with, acceptance.lines);

  const RetirementVerdict& first = retirement.front();
  std::vector<double> size;
  std::vector<std::string> size_counts;
  for (const RetirementVerdict& v : retirement) {
    size.push_back(v.size_ratio);
    size_counts.push_back(std::to_string(v.last_nodes) + " / " + std::to_string(v.middle_nodes));
  }
  acceptance.lines.push_back(Line("with retirement: map nodes, day " +
                                      std::to_string(first.last_day) + " / day " +
                                      std::to_string(first.middle_day),
                                  kRetiredSizeBound, std::move(size), std::move(size_counts)));
  const std::string late = DaysText(first.late_first, first.late_last);
  for (std::size_t m = 0; m < kRetirementJudgedMaps.size(); ++m) {
    std::vector<double> p10, lost;
    std::vector<std::string> p10_counts, lost_counts;
    for (const RetirementVerdict& v : retirement) {
      const RetiredHeldOut& h = v.held_out[m];
      p10.push_back(h.p10_ratio);
      p10_counts.push_back(h.measured ? Counts(h.beyond_with, h.frames_with) + " vs " +
                                            Counts(h.beyond_without, h.frames_without)
                                      : "not measured");
      lost.push_back(h.not_localised_ratio);
      lost_counts.push_back(h.measured ? Counts(h.not_localised_with, h.frames_with) + " vs " +
                                             Counts(h.not_localised_without, h.frames_without)
                                       : "not measured");
    }
    const std::string& map = kRetirementJudgedMaps[m];
    acceptance.lines.push_back(Line(map + "'s P(X > 10 m), " + late + ", with retirement / without",
                                    kRetiredHeldOutBound, std::move(p10), std::move(p10_counts)));
    acceptance.lines.push_back(Line(map + " not localised, " + late + ", with retirement / without",
                                    kRetiredHeldOutBound, std::move(lost), std::move(lost_counts)));
  }
  return acceptance;
}

}  // namespace fleetmap
