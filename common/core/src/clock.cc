#include "fleetmap/core/clock.h"

#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {
namespace {

bool IsDigit(char c) {
  return c >= '0' && c <= '9';
}

Error NotATimeOfDay(std::string_view text, std::string_view what, const char* grammar) {
  return Error(ErrorCode::kInvalidArgument, std::string(what) + " '" + std::string(text) +
                                                "' is not a time of day: expected " + grammar);
}

}  // namespace

int ParseTimeOfDay(std::string_view text, std::string_view what) {
  const auto refuse = [&] { return NotATimeOfDay(text, what, kTimeOfDayGrammar); };
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

int ParseDailyTime(std::string_view text, std::string_view what) {
  const auto refuse = [&] { return NotATimeOfDay(text, what, kDailyTimeGrammar); };
  const std::size_t first_colon = text.find(':');
  const std::size_t second_colon =
      first_colon == std::string_view::npos ? first_colon : text.find(':', first_colon + 1);
  int seconds = 0;
  if (second_colon != std::string_view::npos) {
    const std::string_view seconds_text = text.substr(second_colon + 1);
    if (seconds_text.size() != 2 || !IsDigit(seconds_text[0]) || !IsDigit(seconds_text[1])) {
      throw refuse();
    }
    seconds = (seconds_text[0] - '0') * 10 + (seconds_text[1] - '0');
    if (seconds > 59) throw refuse();
  }
  try {
    return ParseTimeOfDay(text.substr(0, second_colon), what) * 60 + seconds;
  } catch (const Error&) {
    throw refuse();
  }
}

}  // namespace fleetmap
