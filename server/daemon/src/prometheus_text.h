// Writes the Prometheus text exposition format, version 0.0.4
// (https://prometheus.io/docs/instrumenting/exposition_formats/): for each metric family a
// `# HELP` and a `# TYPE` line, then its samples `name{label="value",...} value`, one a line,
// each line ending in '\n'. Label values are escaped as the format requires (backslash,
// double quote and line feed); HELP text escapes backslash and line feed.
//
// Threading: a writer is used by one thread. Throws Error(kInvalidArgument) for a metric or
// label name the format does not allow, and for a sample whose name does not belong to the
// family declared last (the format wants a family's samples together, after its TYPE).
#pragma once

#include <cstdint>
#include <initializer_list>
#include <string>
#include <string_view>

namespace fleetmap {

enum class PrometheusMetricType { kGauge, kCounter };

struct PrometheusLabel {
  std::string_view name;
  std::string_view value;
};

class PrometheusTextWriter {
 public:
  // Starts a family: its HELP and TYPE lines.
  void Family(std::string_view name, PrometheusMetricType type, std::string_view help);

  // One sample of the family declared last. Integers are written exactly; doubles in the
  // shortest form that reads back the same, NaN as "NaN" and infinities as "+Inf"/"-Inf".
  void Sample(std::string_view name, std::uint64_t value,
              std::initializer_list<PrometheusLabel> labels = {});
  void Sample(std::string_view name, std::int64_t value,
              std::initializer_list<PrometheusLabel> labels = {});
  void Sample(std::string_view name, double value,
              std::initializer_list<PrometheusLabel> labels = {});

  // The text written so far.
  const std::string& text() const { return text_; }

 private:
  void SampleLine(std::string_view name, std::string_view value,
                  std::initializer_list<PrometheusLabel> labels);

  std::string text_;
  std::string family_;
};

// A label value as PrintableText shows it (one line of valid UTF-8: controls, bidirectional
// overrides and stray bytes as visible escapes), escaped for the inside of its double quotes:
// `\` → `\\`, `"` → `\"`.
std::string EscapePrometheusLabelValue(std::string_view value);

}  // namespace fleetmap
