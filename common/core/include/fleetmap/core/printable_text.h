// Text from outside (a robot's name, an author, an agent's error string, a file's field) made
// safe to print on one line of a log or a table: a newline in it cannot forge a second log
// line, and an escape sequence cannot move a terminal's cursor or change its colours.
#pragma once

#include <string>
#include <string_view>

namespace fleetmap {

// `text` with every C0 control character, DEL and backslash written as a C escape (\n, \t,
// \\, \x1b), so the result is one line of printable bytes (UTF-8 above 0x7f is kept as it is)
// and distinct inputs stay distinct. Cheap when nothing needs escaping.
std::string PrintableText(std::string_view text);

}  // namespace fleetmap
