// See benchmark_json.h.
#include "fleetmap/bench/benchmark_json.h"

#include <sys/wait.h>

#include <algorithm>
#include <cstdlib>
#include <limits>
#include <nlohmann/json.hpp>
#include <string_view>

#include "fleetmap/core/error.h"

namespace fleetmap::bench {

namespace {

double ToMs(double value, const std::string& unit) {
  if (unit == "ns") return value / 1e6;
  if (unit == "us") return value / 1e3;
  if (unit == "s") return value * 1e3;
  return value;  // "ms"
}

// "BM_X/real_time", "BM_X/iterations:2/real_time" -> "BM_X"; a benchmark's own arguments
// ("BM_X/warm") stay.
std::string BaseName(std::string name) {
  for (const std::string suffix : {"/real_time", "/manual_time"}) {
    if (name.size() > suffix.size() && name.ends_with(suffix)) {
      name.resize(name.size() - suffix.size());
    }
  }
  const std::size_t iterations = name.find("/iterations:");
  if (iterations != std::string::npos) name.resize(iterations);
  return name;
}

// Google Benchmark writes a counter it could not compute (a coefficient of variation over
// zero, say) as a bare NaN or inf, which is not JSON: such tokens outside strings become null.
std::string WithoutNonFiniteTokens(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  bool in_string = false;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (in_string) {
      out += c;
      if (c == '\\' && i + 1 < text.size()) {
        out += text[++i];
      } else if (c == '"') {
        in_string = false;
      }
      continue;
    }
    if (c == '"') in_string = true;
    bool replaced = false;
    for (const std::string_view token :
         {"-Infinity", "Infinity", "-NaN", "NaN", "-nan", "nan", "-inf", "inf"}) {
      if (std::string_view(text).substr(i, token.size()) == token) {
        out += "null";
        i += token.size() - 1;
        replaced = true;
        break;
      }
    }
    if (!replaced) out += c;
  }
  return out;
}

std::string Quoted(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

}  // namespace

std::vector<BenchmarkRun> ParseBenchmarkJson(const std::string& json_text) {
  const nlohmann::json doc =
      nlohmann::json::parse(WithoutNonFiniteTokens(json_text), nullptr, false);
  if (doc.is_discarded() || !doc.is_object() || !doc.contains("benchmarks") ||
      !doc["benchmarks"].is_array()) {
    throw Error(ErrorCode::kInvalidArgument, "not Google Benchmark JSON (no benchmarks array)");
  }
  // Keys of a run that are not counters.
  static const char* const kFixed[] = {"name",
                                       "family_index",
                                       "per_family_instance_index",
                                       "run_name",
                                       "run_type",
                                       "repetitions",
                                       "repetition_index",
                                       "threads",
                                       "iterations",
                                       "real_time",
                                       "cpu_time",
                                       "time_unit",
                                       "error_occurred",
                                       "error_message",
                                       "aggregate_name",
                                       "aggregate_unit",
                                       "label"};
  std::vector<BenchmarkRun> runs;
  for (const nlohmann::json& b : doc["benchmarks"]) {
    if (!b.is_object() || b.value("run_type", "iteration") != "iteration") continue;
    BenchmarkRun run;
    run.name = BaseName(b.value("run_name", b.value("name", "")));
    run.repetition = b.value("repetition_index", 0);
    run.real_ms = ToMs(b.value("real_time", 0.0), b.value("time_unit", "ns"));
    if (b.value("error_occurred", false)) run.error = b.value("error_message", "error");
    for (const auto& [key, value] : b.items()) {
      if (!value.is_number()) continue;
      if (std::find_if(std::begin(kFixed), std::end(kFixed),
                       [&](const char* k) { return key == k; }) != std::end(kFixed)) {
        continue;
      }
      run.counters[key] = value.get<double>();
    }
    runs.push_back(std::move(run));
  }
  return runs;
}

std::vector<double> PerRepetition(const std::vector<BenchmarkRun>& runs, const std::string& name,
                                  const std::string& field) {
  std::vector<const BenchmarkRun*> matching;
  for (const BenchmarkRun& r : runs) {
    if (r.name == name) matching.push_back(&r);
  }
  std::sort(matching.begin(), matching.end(), [](const BenchmarkRun* a, const BenchmarkRun* b) {
    return a->repetition < b->repetition;
  });
  std::vector<double> values;
  for (const BenchmarkRun* r : matching) {
    if (!r->error.empty()) {
      values.push_back(std::numeric_limits<double>::quiet_NaN());
    } else if (field == "real_ms") {
      values.push_back(r->real_ms);
    } else {
      auto it = r->counters.find(field);
      values.push_back(it == r->counters.end() ? std::numeric_limits<double>::quiet_NaN()
                                               : it->second);
    }
  }
  return values;
}

int RunBenchmarkExecutable(const std::string& executable, const std::vector<std::string>& arguments,
                           const std::string& json_file, const std::string& log_file) {
  std::string command = Quoted(executable);
  for (const std::string& a : arguments) command += " " + Quoted(a);
  command += " " + Quoted("--benchmark_out=" + json_file) + " --benchmark_out_format=json";
  command += " >" + Quoted(log_file) + " 2>&1";
  const int status = std::system(command.c_str());
  if (status == -1 || !WIFEXITED(status)) return -1;
  return WEXITSTATUS(status);
}

}  // namespace fleetmap::bench
