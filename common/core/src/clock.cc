#include "fleetmap/core/clock.h"

#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

bool IsDigit(char c) {
  return c >= '0' && c <= '9';
}

}  // namespace

int ParseTimeOfDay(std::string_view text, std::string_view what) {
  const auto refuse = [&] {
    return Error(ErrorCode::kInvalidArgument, std::string(what) + " '" + std::string(text) +
                                                  "' is not a time of day: expected " +
                                                  kTimeOfDayGrammar);
  };
  const std::size_t colon = text.find(':');
  if (colon != 1 && colon != 2) throw refuse();
  const std::string_view hours_text = text.substr(0, colon);
  const std::string_view minutes_text = text.substr(colon + 1);
  if (minutes_text.size() != 2) throw refuse();
  int hours = 0;
  for (const char c : hours_text) {
    if (!IsDigit(c)) throw refuse();
    hours = hours * 10 + (c - '0');
  }
  int minutes = 0;
  for (const char c : minutes_text) {
    if (!IsDigit(c)) throw refuse();
    minutes = minutes * 10 + (c - '0');
  }
  if (hours > 23 || minutes > 59) throw refuse();
  return hours * 60 + minutes;
}

}  // namespace fleetmap
