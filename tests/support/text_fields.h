// What the tests' readers of text formats (g2o_reader.h, tum_reader.h, graphml_reader.h) share:
// a line split into whitespace-separated fields, and a field read as a number only when all of
// it is one ("1.5x" and "" are refused, where std::stod would stop early or throw a
// logic_error).
#pragma once

#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <vector>

namespace fleetmap::testing {

inline std::vector<std::string> SplitFields(const std::string& line) {
  std::istringstream words(line);
  std::vector<std::string> fields;
  std::string word;
  while (words >> word) fields.push_back(word);
  return fields;
}

// `field` as a Number (double or long long); std::runtime_error "<context>: '<field>' is not a
// number" (or "an integer") otherwise.
template <typename Number>
Number WholeField(const std::string& field, const std::string& context) {
  constexpr bool kInteger = std::is_integral_v<Number>;
  std::size_t used = 0;
  Number value{};
  try {
    if constexpr (kInteger) {
      value = std::stoll(field, &used);
    } else {
      value = std::stod(field, &used);
    }
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != field.size()) {
    throw std::runtime_error(context + ": '" + field + "' is not " +
                             (kInteger ? "an integer" : "a number"));
  }
  return value;
}

inline double WholeNumber(const std::string& field, const std::string& context) {
  return WholeField<double>(field, context);
}

inline long long WholeInteger(const std::string& field, const std::string& context) {
  return WholeField<long long>(field, context);
}

}  // namespace fleetmap::testing
