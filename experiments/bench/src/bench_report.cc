#include "bench_report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <map>
#include <set>
#include <tuple>

#include "fleetmap/core/error.h"
#include "fleetmap/runners/gnuplot.h"

namespace fleetmap::bench {

namespace {

constexpr double kBatchCreateTargetNodesPerS = 200'000.0;
constexpr double kIndividualRatioTarget = 1.3;

// 1234567 -> "1,234,567".
std::string Grouped(double value) {
  std::string digits = std::to_string(static_cast<long long>(value + 0.5));
  for (int i = static_cast<int>(digits.size()) - 3; i > 0; i -= 3) {
    digits.insert(static_cast<std::size_t>(i), ",");
  }
  return digits;
}

std::string DurabilityLabel(const std::string& durability) {
  return durability == "synchronous" ? "sync" : "buffered";
}

std::string BackendLabel(const std::string& backend) {
  return backend == "sqlite" ? "SQLite" : "PostgreSQL";
}

// Single quotes for a POSIX shell.
std::string ShellQuote(const std::string& s) {
  std::string quoted = "'";
  for (char c : s) quoted += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return quoted + "'";
}

// The row with the largest n among those that pass keep, if any.
template <typename Keep>
const BenchRow* LargestN(const std::vector<BenchRow>& rows, Keep keep) {
  const BenchRow* best = nullptr;
  for (const BenchRow& r : rows) {
    if (keep(r) && (best == nullptr || r.n > best->n)) best = &r;
  }
  return best;
}

}  // namespace

std::string Format(const char* format, double value) {
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, format, value);
  return buffer;
}

double Median(std::vector<double> values) {
  if (values.empty() ||
      std::any_of(values.begin(), values.end(), [](double v) { return std::isnan(v); })) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  std::sort(values.begin(), values.end());
  return values[values.size() / 2];
}

void PrintTable(std::ostream& out, const std::vector<BenchRow>& rows) {
  char line[256];
  std::snprintf(line, sizeof line, "%-10s %-11s %-6s %-10s %8s %11s %11s %8s %13s\n", "backend",
                "durability", "op", "mode", "n", "ours_s", "raw_s", "ours/raw", "ours_nodes/s");
  out << line;
  for (const BenchRow& r : rows) {
    const std::string ours = r.ours_s ? Format("%.6f", *r.ours_s) : "-";
    const std::string raw = r.raw_s ? Format("%.6f", *r.raw_s) : "-";
    const std::string ratio =
        r.measured() && *r.raw_s > 0 ? Format("%.2f", *r.ours_s / *r.raw_s) : "-";
    const std::string rate =
        r.ours_s && *r.ours_s > 0 ? Grouped(static_cast<double>(r.n) / *r.ours_s) : "-";
    std::snprintf(line, sizeof line, "%-10s %-11s %-6s %-10s %8zu %11s %11s %8s %13s",
                  r.backend.c_str(), r.durability.c_str(), r.op.c_str(), r.mode.c_str(), r.n,
                  ours.c_str(), raw.c_str(), ratio.c_str(), rate.c_str());
    out << line;
    if (!r.status.empty()) out << "  " << r.status;
    out << "\n";
  }
}

void WriteCsv(const std::filesystem::path& file, const std::vector<BenchRow>& rows) {
  std::ofstream csv(file);
  csv << "backend,durability,op,mode,n,ours_s,raw_s,ratio_ours_raw,ours_nodes_per_s,"
         "raw_nodes_per_s,status\n";
  for (const BenchRow& r : rows) {
    const auto seconds = [](const std::optional<double>& s) {
      return s ? Format("%.9g", *s) : std::string();
    };
    const auto rate = [&](const std::optional<double>& s) {
      return s && *s > 0 ? Format("%.1f", static_cast<double>(r.n) / *s) : std::string();
    };
    std::string status = r.status;
    std::replace(status.begin(), status.end(), '"', '\'');
    csv << r.backend << ',' << r.durability << ',' << r.op << ',' << r.mode << ',' << r.n << ','
        << seconds(r.ours_s) << ',' << seconds(r.raw_s) << ','
        << (r.measured() && *r.raw_s > 0 ? Format("%.4f", *r.ours_s / *r.raw_s) : "") << ','
        << rate(r.ours_s) << ',' << rate(r.raw_s) << ",\"" << status << "\"\n";
  }
  csv.close();
  if (!csv) throw Error(ErrorCode::kBackend, "cannot write " + file.string());
}

bool PlotWithGnuplot(const std::filesystem::path& dir, const std::vector<BenchRow>& rows,
                     std::ostream& log) {
  if (std::system("command -v gnuplot > /dev/null 2>&1") != 0) {
    log << "gnuplot not found: skipping " << (dir / "graph_bench.png").string()
        << " (install gnuplot-nox; the numbers are in graph_bench.csv)\n";
    return false;
  }
  const std::filesystem::path script_file = dir / "graph_bench.gp";
  const std::filesystem::path png_file = dir / "graph_bench.png";

  // One series per (backend, durability, op, mode, ours|raw), points in n order.
  using SeriesKey = std::tuple<std::string, std::string, std::string, std::string, bool>;
  std::map<SeriesKey, std::vector<std::pair<std::size_t, double>>> series;
  for (const BenchRow& r : rows) {
    if (r.ours_s)
      series[{r.backend, r.durability, r.op, r.mode, false}].push_back({r.n, *r.ours_s});
    if (r.raw_s) series[{r.backend, r.durability, r.op, r.mode, true}].push_back({r.n, *r.raw_s});
  }

  std::ofstream gp(script_file);
  gp << "# Generated by `fleetmap bench graph`; rerun with: gnuplot " << script_file.string()
     << "\n"
     << "if (strstrt(GPVAL_TERMINALS, 'pngcairo') > 0) {\n"
     << "  set terminal pngcairo size 1500,1100 font ',10'\n"
     << "} else {\n"
     << "  set terminal png size 1500,1100\n"
     << "}\n"
     << "set output " << GnuplotQuote(png_file.string()) << "\n";
  std::map<SeriesKey, std::string> block_names;
  int block = 0;
  for (auto& [key, points] : series) {
    std::sort(points.begin(), points.end());
    const std::string name = "$series" + std::to_string(block++);
    block_names[key] = name;
    gp << name << " << EOD\n";
    for (const auto& [n, seconds] : points) gp << n << ' ' << Format("%.9g", seconds) << "\n";
    gp << "EOD\n";
  }
  gp << "set multiplot layout 2,2 title 'fleetmap bench graph: linear chains (seed 000 Figs 6-7)."
        " Solid: GraphStore (ours); dashed: raw SQL baseline.'\n"
     << "set logscale xy\n"
     << "set format x '10^{%L}'\n"
     << "set format y '10^{%L}'\n"
     << "set xlabel 'chain length n (nodes)'\n"
     << "set ylabel 'time (s)'\n"
     << "set key top left font ',8'\n"
     << "set grid\n";

  struct Panel {
    const char* op;
    const char* mode;
    const char* title;
  };
  const Panel panels[] = {
      {"create", "individual", "Create, one call per node and edge (Fig. 6 left)"},
      {"create", "batch", "Create, the whole chain in one call (Fig. 6 right)"},
      {"read", "individual", "Read, GetNode + EdgesFrom per node (Fig. 7 left)"},
      {"read", "batch", "Read, ReadChain in one call (Fig. 7 right)"},
  };
  // Colour by backend and durability; raw uses the same colour, dashed, open points.
  const std::map<std::pair<std::string, std::string>, const char*> colours = {
      {{"sqlite", "synchronous"}, "#1f4e9c"},
      {{"sqlite", "buffered"}, "#4fa3e0"},
      {{"postgresql", "synchronous"}, "#b2182b"},
      {{"postgresql", "buffered"}, "#f08c3a"},
  };
  for (const Panel& panel : panels) {
    gp << "set title '" << panel.title << "'\n";
    std::vector<std::string> plots;
    for (const auto& [key, name] : block_names) {
      const auto& [backend, durability, op, mode, raw] = key;
      if (op != panel.op || mode != panel.mode) continue;
      auto colour = colours.find({backend, durability});
      plots.push_back(name + " using 1:2 with linespoints lw 2 lc rgb '" +
                      (colour == colours.end() ? "#444444" : colour->second) + "' dt " +
                      (raw ? "2 pt 6" : "1 pt 7") + " title '" + BackendLabel(backend) + " " +
                      DurabilityLabel(durability) + (raw ? ", raw" : ", ours") + "'");
    }
    if (plots.empty()) {
      gp << "unset logscale\nset label 1 'not measured' at graph 0.5,0.5 center\n"
         << "plot [0:1][0:1] -1 notitle\nunset label 1\nset logscale xy\n";
      continue;
    }
    gp << "plot ";
    for (std::size_t i = 0; i < plots.size(); ++i) gp << (i ? ", \\\n     " : "") << plots[i];
    gp << "\n";
  }
  gp << "unset multiplot\n";
  gp.close();
  if (!gp) {
    log << "cannot write " << script_file.string() << ": skipping the plot\n";
    return false;
  }
  const std::string command = "gnuplot " + ShellQuote(script_file.string());
  if (std::system(command.c_str()) != 0) {
    log << "gnuplot failed on " << script_file.string() << ": no plot\n";
    return false;
  }
  return true;
}

bool PrintHeadlineChecks(std::ostream& out, const std::vector<BenchRow>& rows) {
  bool all_passed = true;
  const auto verdict = [&](bool passed) {
    all_passed = all_passed && passed;
    return passed ? "PASS" : "FAIL";
  };
  for (const char* durability : {"synchronous", "buffered"}) {
    const BenchRow* r = LargestN(rows, [&](const BenchRow& row) {
      return row.backend == "sqlite" && row.durability == durability && row.op == "create" &&
             row.mode == "batch" && row.ours_s && *row.ours_s > 0;
    });
    if (r == nullptr) continue;
    const double rate = static_cast<double>(r->n) / *r->ours_s;
    out << "SQLite batch chain create (" << durability << "): " << Grouped(rate)
        << " nodes/s at n=" << Grouped(static_cast<double>(r->n))
        << " (target >= " << Grouped(kBatchCreateTargetNodesPerS) << ")  "
        << verdict(rate >= kBatchCreateTargetNodesPerS) << "\n";
  }
  std::set<std::pair<std::string, std::string>> configs;
  for (const BenchRow& r : rows) configs.insert({r.backend, r.durability});
  for (const auto& [backend, durability] : configs) {
    for (const char* op : {"create", "read"}) {
      const BenchRow* r = LargestN(rows, [&](const BenchRow& row) {
        return row.backend == backend && row.durability == durability && row.op == op &&
               row.mode == "individual" && row.measured() && *row.raw_s > 0;
      });
      if (r == nullptr) continue;
      const double ratio = *r->ours_s / *r->raw_s;
      out << "individual-call overhead ours/raw (" << backend << " " << durability << " " << op
          << ", n=" << Grouped(static_cast<double>(r->n)) << "): " << Format("%.2f", ratio)
          << " (target <= " << Format("%.1f", kIndividualRatioTarget) << ")  "
          << verdict(ratio <= kIndividualRatioTarget) << "\n";
    }
  }
  return all_passed;
}

}  // namespace fleetmap::bench
