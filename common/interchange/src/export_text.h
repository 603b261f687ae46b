// How the text formats write numbers and free text.
#pragma once

#include <string>
#include <string_view>

namespace fleetmap::interchange_internal {

// Appends the shortest decimal text that reads back to exactly `value` (std::to_chars): no
// precision is lost on the way out, and no digits are spent beyond that.
void AppendNumber(std::string& out, double value);

// `text` on one line: each line break (CR or LF) becomes a space, so free text cannot end a
// comment line early and start a line the format would read as data.
std::string OneLine(std::string_view text);

}  // namespace fleetmap::interchange_internal
