#include "fleetmap/core/printable_text.h"

#include <algorithm>
#include <cstdint>

namespace fleetmap {
namespace {

constexpr std::string_view kReplacement = "\xEF\xBF\xBD";  // U+FFFD

// The sequence whose lead byte is text[at]: the length it announces (0: not a lead byte) and
// how many of its bytes, the lead included, are as RFC 3629 allows (no overlong forms, no
// surrogates, nothing above U+10FFFF). Whole when the two agree.
struct Prefix {
  std::size_t length = 0;
  std::size_t fitting = 0;
};

Prefix PrefixAt(std::string_view text, std::size_t at) {
  const auto lead = static_cast<unsigned char>(text[at]);
  if (lead < 0x80) return {1, 1};
  Prefix prefix;
  unsigned char low = 0x80, high = 0xBF;  // the second byte's range
  if (lead >= 0xC2 && lead <= 0xDF) {
    prefix.length = 2;
  } else if (lead >= 0xE0 && lead <= 0xEF) {
    prefix.length = 3;
    if (lead == 0xE0) low = 0xA0;
    if (lead == 0xED) high = 0x9F;
  } else if (lead >= 0xF0 && lead <= 0xF4) {
    prefix.length = 4;
    if (lead == 0xF0) low = 0x90;
    if (lead == 0xF4) high = 0x8F;
  } else {
    return prefix;
  }
  prefix.fitting = 1;
  while (prefix.fitting < prefix.length && at + prefix.fitting < text.size()) {
    const auto next = static_cast<unsigned char>(text[at + prefix.fitting]);
    const bool fits = prefix.fitting == 1 ? next >= low && next <= high : (next & 0xC0) == 0x80;
    if (!fits) break;
    ++prefix.fitting;
  }
  return prefix;
}

// The length of the well-formed sequence at text[at] and its code point; 0 when the bytes there
// are not one.
std::size_t SequenceAt(std::string_view text, std::size_t at, char32_t& code) {
  const Prefix prefix = PrefixAt(text, at);
  if (prefix.length == 0 || prefix.fitting < prefix.length) return 0;
  const auto lead = static_cast<unsigned char>(text[at]);
  code = prefix.length == 1 ? lead : lead & (0xFF >> (prefix.length + 1));
  for (std::size_t i = 1; i < prefix.length; ++i) {
    code = (code << 6) | (static_cast<unsigned char>(text[at + i]) & 0x3F);
  }
  return prefix.length;
}

// Where the bytes at text[at] are not a well-formed sequence: how many of them one U+FFFD
// replaces, the maximal subpart of a sequence (Unicode's recommended practice, as nlohmann's
// replacing writer does): a lead byte and the continuation bytes that could still follow it.
std::size_t InvalidRun(std::string_view text, std::size_t at) {
  return std::max<std::size_t>(PrefixAt(text, at).fitting, 1);
}

// Characters shown escaped although valid: they end a line or reorder what a reader sees.
bool HiddenEffect(char32_t code) {
  return (code >= 0x80 && code <= 0x9F) || code == 0x061C || code == 0x200E || code == 0x200F ||
         code == 0x2028 || code == 0x2029 || (code >= 0x202A && code <= 0x202E) ||
         (code >= 0x2066 && code <= 0x2069);
}

constexpr char kHex[] = "0123456789abcdef";

}  // namespace

bool IsValidUtf8(std::string_view text) {
  char32_t code = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t length = SequenceAt(text, at, code);
    if (length == 0) return false;
    at += length;
  }
  return true;
}

std::string ValidUtf8(std::string_view text) {
  if (IsValidUtf8(text)) return std::string(text);
  std::string out;
  out.reserve(text.size() + 8);
  char32_t code = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t length = SequenceAt(text, at, code);
    if (length == 0) {
      out += kReplacement;
      at += InvalidRun(text, at);
    } else {
      out.append(text.substr(at, length));
      at += length;
    }
  }
  return out;
}

std::string ReceivedText(std::string_view text, std::size_t max_bytes) {
  std::string valid = ValidUtf8(text);
  if (valid.size() <= max_bytes) return valid;
  std::size_t cut = max_bytes;
  // Back over continuation bytes to the start of the character the cap falls in.
  while (cut > 0 && (static_cast<unsigned char>(valid[cut]) & 0xC0) == 0x80) --cut;
  valid.resize(cut);
  return valid;
}

std::string PrintableText(std::string_view text) {
  std::string out;
  out.reserve(text.size() + 8);
  char32_t code = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t length = SequenceAt(text, at, code);
    const auto byte = static_cast<unsigned char>(text[at]);
    if (length == 0) {
      out += "\\x";
      out += kHex[byte >> 4];
      out += kHex[byte & 0x0f];
      ++at;
      continue;
    }
    if (length == 1) {
      switch (byte) {
        case '\n':
          out += "\\n";
          break;
        case '\r':
          out += "\\r";
          break;
        case '\t':
          out += "\\t";
          break;
        case '\\':
          out += "\\\\";
          break;
        default:
          if (byte < 0x20 || byte == 0x7f) {
            out += "\\x";
            out += kHex[byte >> 4];
            out += kHex[byte & 0x0f];
          } else {
            out += static_cast<char>(byte);
          }
      }
    } else if (HiddenEffect(code)) {
      out += "\\u";
      for (int shift = 12; shift >= 0; shift -= 4) out += kHex[(code >> shift) & 0xF];
    } else {
      out.append(text.substr(at, length));
    }
    at += length;
  }
  return out;
}

std::string EscapeHiddenInJson(std::string text) {
  // Every character concerned starts with 0xC2, 0xD8 or 0xE2: most texts are returned as given.
  if (text.find_first_of("\xC2\xD8\xE2") == std::string::npos) return text;
  std::string out;
  out.reserve(text.size() + 16);
  char32_t code = 0;
  for (std::size_t at = 0; at < text.size();) {
    const std::size_t length = SequenceAt(text, at, code);
    if (length > 1 && HiddenEffect(code)) {
      out += "\\u";
      for (int shift = 12; shift >= 0; shift -= 4) out += kHex[(code >> shift) & 0xF];
    } else {
      out.append(text, at, std::max<std::size_t>(length, 1));
    }
    at += std::max<std::size_t>(length, 1);
  }
  return out;
}

}  // namespace fleetmap
