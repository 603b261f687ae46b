// Text from outside (a robot's name, an author, an agent's error string, a channel, a file's
// field) made safe where it is received and where it is shown: cut on a character boundary
// and valid UTF-8 when stored, one line of printable characters when shown, JSON that a stray
// byte cannot break, and markup (HTML, SVG, GraphML) that it cannot open or close. Beside them,
// the one way every program shows a number of bytes to a person.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

namespace fleetmap {

// `text` with what is not well-formed UTF-8 (a stray continuation byte, a sequence cut short,
// an overlong form, a surrogate, a code point above U+10FFFF) replaced by U+FFFD, one for each
// maximal subpart of a sequence (as nlohmann's replacing writer). Cheap when `text` is valid.
std::string ValidUtf8(std::string_view text);
bool IsValidUtf8(std::string_view text);

// ValidUtf8(text) cut to at most `max_bytes` on a character boundary: what a server keeps of a
// client's text under a byte cap, never half a character.
std::string ReceivedText(std::string_view text, std::size_t max_bytes);

// `text` as one line of printable characters, distinct inputs staying distinct: C0 controls,
// DEL and backslash written as C escapes (\n, \t, \\, \x1b); C1 controls (U+0080-U+009F, among
// them U+0085 NEXT LINE and U+009B, a terminal's CSI), line and paragraph separators, and the
// bidirectional controls that reorder what a reader sees (U+202A-U+202E, U+2066-U+2069, U+200E,
// U+200F, U+061C) written as \u0085, \u202e; a byte that is not UTF-8 as \xff. The result is
// valid UTF-8. Cheap when nothing needs escaping.
std::string PrintableText(std::string_view text);

// Serialised JSON (valid UTF-8) with the characters PrintableText escapes although valid (C1
// controls, line separators, bidirectional controls) written as JSON's \uXXXX escapes: the
// same JSON to a parser, nothing hidden from a person reading it.
std::string EscapeHiddenInJson(std::string text);

// `json` serialised (nlohmann::json or ordered_json) with any invalid UTF-8 in its strings
// replaced by U+FFFD rather than thrown about (a report holding one robot's bad bytes must not
// abort a listing of the whole fleet), and EscapeHiddenInJson. `indent` as nlohmann's dump
// (-1: one line).
template <typename Json>
std::string JsonText(const Json& json, int indent = -1) {
  return EscapeHiddenInJson(json.dump(indent, ' ', false, Json::error_handler_t::replace));
}

// Appends `text` as XML or HTML character data or as an attribute value (quoted with " or '):
// &, <, >, " and ' as &amp; &lt; &gt; &quot; &#39; (references that XML 1.0, HTML 4 and HTML5
// all read), and the control characters XML 1.0 does not allow at all (C0 but tab, LF and CR;
// not even as references) as spaces. Bytes are otherwise copied: for text shown to a person,
// pass it through PrintableText first.
void AppendMarkupEscaped(std::string& out, std::string_view text);

// `bytes` for a person, in binary (IEC) units: below 1 KiB the exact count ("512 B"), else one
// decimal in the largest unit of KiB, MiB, GiB and TiB (1024 times the one before) that keeps
// the number at 1 or more ("1.5 KiB", "2.4 MiB", "1.0 GiB"; past that, TiB: "2048.0 TiB").
std::string BytesText(std::uint64_t bytes);

}  // namespace fleetmap
