#include "export_text.h"

#include <charconv>

namespace fleetmap::interchange_internal {

void AppendNumber(std::string& out, double value) {
  char text[32];  // the longest shortest form of a double is 24 characters
  const std::to_chars_result result = std::to_chars(text, text + sizeof text, value);
  out.append(text, result.ptr);
}

std::string OneLine(std::string_view text) {
  std::string line(text);
  for (char& c : line) {
    if (c == '\n' || c == '\r') c = ' ';
  }
  return line;
}

}  // namespace fleetmap::interchange_internal
