// Output of `fleetmap bench graph`: the results table, a CSV, a gnuplot figure in the layout
// of seed 000 Figs 6-7, and the acceptance checks computed from the measurements.
#pragma once

#include <cstddef>
#include <filesystem>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

namespace fleetmap::bench {

// One (backend, durability, op, mode, n) measurement of ours against the raw baseline.
// Times are wall-clock seconds (median over repetitions); unset when not measured, and then
// status says why ("skipped: ...", "error: ...").
struct BenchRow {
  std::string backend;     // "sqlite" | "postgresql"
  std::string durability;  // "synchronous" | "buffered"
  std::string op;          // "create" | "read"
  std::string mode;        // "individual" | "batch"
  std::size_t n = 0;       // chain length in nodes
  std::optional<double> ours_s;
  std::optional<double> raw_s;
  std::string status;  // empty when both were measured

  bool measured() const { return ours_s.has_value() && raw_s.has_value(); }
};

// Fixed-width table: backend, durability, op, mode, n, ours s, raw s, ours/raw, ours nodes/s.
// VALUE printed with a printf FORMAT of one double conversion ("%.1f"), for the tables.
std::string Format(const char* format, double value);

// The median of values (the upper middle one for an even count); NaN when values is empty or
// holds a NaN, so a side that was not measured never passes a bound.
double Median(std::vector<double> values);

void PrintTable(std::ostream& out, const std::vector<BenchRow>& rows);

// Throws Error(kBackend) when the file cannot be written.
void WriteCsv(const std::filesystem::path& file, const std::vector<BenchRow>& rows);

// Writes DIR/graph_bench.gp and runs gnuplot on it to make DIR/graph_bench.png: log-log time
// against n, one panel per op x mode, a line per backend and durability, ours solid, raw
// dashed. Returns false (and says why on log) when gnuplot is missing or fails.
bool PlotWithGnuplot(const std::filesystem::path& dir, const std::vector<BenchRow>& rows,
                     std::ostream& log);

// The headline checks: SQLite batch create throughput (target >= 200,000 nodes/s) and the
// ours/raw ratio of individual calls (target <= 1.3) per backend and durability at the largest
// n measured. Returns true when every check that could be computed passed.
bool PrintHeadlineChecks(std::ostream& out, const std::vector<BenchRow>& rows);

}  // namespace fleetmap::bench
