// One line of `fleetmap bench limits`: a measure of ours beside its raw limit, both taken in
// the same run, and the bound put on their ratio. Repetitions are kept so the line's
// figures are medians and its ratio is the median of the per-repetition ratios (each measured
// in the same minutes, so machine noise cancels in the ratio, not in the figures).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct LimitLine {
  std::string measure;       // "index insert, SQLite synchronous, 10^6 rows"
  std::string unit;          // of ours and limit: "rows/s", "us", "ms", "MB/s"
  std::string limit_name;    // what the limit is: "plain sqlite3 prepared inserts"
  std::vector<double> ours;  // per repetition
  std::vector<double> limit;
  // Per repetition; empty: ours / limit per repetition. Set it when the ratio is not ours
  // over limit (a mean over seeds, say).
  std::vector<double> ratios;
  enum class Bound { kAtMost, kAtLeast, kNone } bound = Bound::kNone;
  double bound_value = 0;  // the ratio's bound; for kNone, nothing is judged
  // A line judged on `ours` alone (cold download >= 300 MB/s, growth 0): bound applies to
  // ours' median instead of the ratio.
  bool bound_on_ours = false;
  std::string note;  // what the run noticed (a failed child, load above 1, ...)
};

// The medians of a line (NaN for an empty side).
double MedianOurs(const LimitLine& line);
double MedianLimit(const LimitLine& line);
double MedianRatio(const LimitLine& line);

// Met: the judged figure is within its bound. A line without figures, or with a NaN, is not
// met; a line with Bound::kNone is reported only and counts as met.
bool Met(const LimitLine& line);
std::string BoundText(const LimitLine& line);  // "<= 1.2", ">= 300 MB/s", "-"

// The table as Markdown (docs/experiments.md, "Benchmarks") and as CSV (one row per line:
// measure, unit, ours, limit_name, limit, ratio, bound, met, repetitions, note).
void WriteLimitsMarkdown(const std::vector<LimitLine>& lines, std::ostream& out);
void WriteLimitsCsv(const std::vector<LimitLine>& lines, std::ostream& out);

}  // namespace fleetmap::bench
