// See limit_line.h.
#include "fleetmap/bench/limit_line.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "bench_report.h"

namespace fleetmap::bench {

namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::vector<double> Ratios(const LimitLine& line) {
  if (!line.ratios.empty()) return line.ratios;
  std::vector<double> r;
  const std::size_t n = std::min(line.ours.size(), line.limit.size());
  for (std::size_t i = 0; i < n; ++i) {
    r.push_back(line.limit[i] != 0 ? line.ours[i] / line.limit[i] : kNaN);
  }
  return r;
}

// Figures with 3 significant digits at least, without a long tail of decimals.
std::string Figure(double v) {
  if (std::isnan(v)) return "-";
  const double a = std::fabs(v);
  if (a >= 1000) return Format("%.0f", v);
  if (a >= 100) return Format("%.1f", v);
  if (a >= 1) return Format("%.2f", v);
  return Format("%.3f", v);
}

// CSV field: quoted when it holds a comma or a quote.
std::string Field(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string q = "\"";
  for (char c : s) q += c == '"' ? std::string("\"\"") : std::string(1, c);
  return q + "\"";
}

}  // namespace

double MedianOurs(const LimitLine& line) {
  return Median(line.ours);
}

double MedianLimit(const LimitLine& line) {
  return Median(line.limit);
}

double MedianRatio(const LimitLine& line) {
  return Median(Ratios(line));
}

bool Met(const LimitLine& line) {
  if (line.bound == LimitLine::Bound::kNone) return true;
  const double judged = line.bound_on_ours ? MedianOurs(line) : MedianRatio(line);
  if (std::isnan(judged)) return false;
  return line.bound == LimitLine::Bound::kAtMost ? judged <= line.bound_value
                                                 : judged >= line.bound_value;
}

std::string BoundText(const LimitLine& line) {
  if (line.bound == LimitLine::Bound::kNone) return "-";
  std::string text = line.bound == LimitLine::Bound::kAtMost ? "<= " : ">= ";
  text += Figure(line.bound_value);
  if (line.bound_on_ours) text += " " + line.unit;
  return text;
}

void WriteLimitsMarkdown(const std::vector<LimitLine>& lines, std::ostream& out) {
  out << "| measure | ours | raw limit in the same run | ratio | bound | met |\n"
      << "|---|---|---|---|---|---|\n";
  for (const LimitLine& l : lines) {
    const std::string limit =
        l.limit.empty() ? "-" : Figure(MedianLimit(l)) + " " + l.unit + " (" + l.limit_name + ")";
    out << "| " << l.measure << " | " << Figure(MedianOurs(l)) << " " << l.unit << " | " << limit
        << " | " << Figure(MedianRatio(l)) << " | " << BoundText(l) << " | "
        << (l.bound == LimitLine::Bound::kNone ? "-"
            : Met(l)                           ? "yes"
                                               : "**no**")
        << " |\n";
  }
}

void WriteLimitsCsv(const std::vector<LimitLine>& lines, std::ostream& out) {
  out << "measure,unit,ours,limit_name,limit,ratio,bound,met,repetitions,note\n";
  for (const LimitLine& l : lines) {
    out << Field(l.measure) << ',' << Field(l.unit) << ',' << Format("%.6g", MedianOurs(l)) << ','
        << Field(l.limit_name) << ',' << Format("%.6g", MedianLimit(l)) << ','
        << Format("%.6g", MedianRatio(l)) << ',' << Field(BoundText(l)) << ','
        << (Met(l) ? "yes" : "no") << ',' << l.ours.size() << ',' << Field(l.note) << '\n';
  }
}

}  // namespace fleetmap::bench
