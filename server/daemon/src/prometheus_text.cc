#include "prometheus_text.h"

#include <charconv>
#include <cmath>
#include <string>

#include "fleetmap/core/error.h"
#include "fleetmap/core/printable_text.h"

namespace fleetmap {
namespace {

bool IsNameStart(char c, bool colon_allowed) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || c == '_' ||
         (colon_allowed && c == ':');
}

// Metric names: [a-zA-Z_:][a-zA-Z0-9_:]*; label names the same without ':'.
void CheckName(std::string_view name, bool colon_allowed, std::string_view what) {
  bool valid = !name.empty() && IsNameStart(name.front(), colon_allowed);
  for (char c : name) {
    valid = valid && (IsNameStart(c, colon_allowed) || (c >= '0' && c <= '9'));
  }
  if (!valid) {
    throw Error(ErrorCode::kInvalidArgument,
                "Prometheus text: invalid " + std::string(what) + " \"" + std::string(name) + "\"");
  }
}

std::string EscapeHelp(std::string_view help) {
  std::string out;
  out.reserve(help.size());
  for (char c : help) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

}  // namespace

std::string EscapePrometheusLabelValue(std::string_view raw) {
  // Controls, bidirectional overrides and bytes that are not UTF-8 shown as escapes
  // (printable_text.h): a label is one line of valid UTF-8 whatever a robot sent.
  const std::string value = PrintableText(raw);
  std::string out;
  out.reserve(value.size());
  for (char c : value) {
    if (c == '\\') {
      out += "\\\\";
    } else if (c == '"') {
      out += "\\\"";
    } else if (c == '\n') {
      out += "\\n";
    } else {
      out += c;
    }
  }
  return out;
}

void PrometheusTextWriter::Family(std::string_view name, PrometheusMetricType type,
                                  std::string_view help) {
  CheckName(name, true, "metric name");
  family_ = name;
  text_ += "# HELP ";
  text_ += name;
  text_ += ' ';
  text_ += EscapeHelp(help);
  text_ += "\n# TYPE ";
  text_ += name;
  text_ += type == PrometheusMetricType::kCounter ? " counter\n" : " gauge\n";
}

void PrometheusTextWriter::Sample(std::string_view name, std::uint64_t value,
                                  std::initializer_list<PrometheusLabel> labels) {
  SampleLine(name, std::to_string(value), labels);
}

void PrometheusTextWriter::Sample(std::string_view name, std::int64_t value,
                                  std::initializer_list<PrometheusLabel> labels) {
  SampleLine(name, std::to_string(value), labels);
}

void PrometheusTextWriter::Sample(std::string_view name, double value,
                                  std::initializer_list<PrometheusLabel> labels) {
  if (std::isnan(value)) {
    SampleLine(name, "NaN", labels);
  } else if (std::isinf(value)) {
    SampleLine(name, value > 0 ? "+Inf" : "-Inf", labels);
  } else {
    char buffer[64];
    const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
    SampleLine(name, std::string_view(buffer, static_cast<std::size_t>(result.ptr - buffer)),
               labels);
  }
}

void PrometheusTextWriter::SampleLine(std::string_view name, std::string_view value,
                                      std::initializer_list<PrometheusLabel> labels) {
  if (name != family_) {
    throw Error(ErrorCode::kInvalidArgument, "Prometheus text: sample \"" + std::string(name) +
                                                 "\" outside its family (last declared: \"" +
                                                 family_ + "\")");
  }
  text_ += name;
  if (labels.size() > 0) {
    text_ += '{';
    bool first = true;
    for (const PrometheusLabel& label : labels) {
      CheckName(label.name, false, "label name");
      if (!first) text_ += ',';
      first = false;
      text_ += label.name;
      text_ += "=\"";
      text_ += EscapePrometheusLabelValue(label.value);
      text_ += '"';
    }
    text_ += '}';
  }
  text_ += ' ';
  text_ += value;
  text_ += '\n';
}

}  // namespace fleetmap
