// Results of a Google Benchmark executable run as a child of `fleetmap bench limits`
// (--benchmark_format=json): the per-repetition runs, so a line can pair ours with its limit
// repetition by repetition.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace fleetmap::bench {

struct BenchmarkRun {
  std::string name;    // run_name without the "/real_time" and "/iterations:N" suffixes
  int repetition = 0;  // repetition_index
  double real_ms = 0;  // real_time per iteration, in milliseconds whatever the time_unit
  std::map<std::string, double> counters;
  std::string error;  // error_message of a run that reported an error
};

// The iteration runs (aggregates are left out: medians are taken over repetitions here).
// Throws Error(kInvalidArgument) when the text is not Google Benchmark's JSON.
std::vector<BenchmarkRun> ParseBenchmarkJson(const std::string& json_text);

// Per repetition, in repetition order: real_ms ("real_ms") or a counter of the runs named
// `name`. Empty when there is none; a run that reported an error contributes NaN.
std::vector<double> PerRepetition(const std::vector<BenchmarkRun>& runs, const std::string& name,
                                  const std::string& field);

// Runs `executable` with `arguments` plus --benchmark_out=json_file (json format), its output
// to log_file; returns its exit status (-1 when it could not run or was killed).
int RunBenchmarkExecutable(const std::string& executable, const std::vector<std::string>& arguments,
                           const std::string& json_file, const std::string& log_file);

}  // namespace fleetmap::bench
