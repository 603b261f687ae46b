// The first bytes of a file, printable, for the error that says what a file is not ("it begins
// \"PK\\x03\\x04...\""). Private to the library.
#pragma once

#include <cstdio>
#include <string>
#include <string_view>

namespace fleetmap::internal {

// At most the first 16 bytes of `bytes`, non-printable ones (and " and \) as \xNN.
inline std::string PrintableBytes(std::string_view bytes) {
  std::string out;
  for (const char c : bytes.substr(0, 16)) {
    if (c >= 0x20 && c < 0x7f && c != '"' && c != '\\') {
      out += c;
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", static_cast<unsigned char>(c));
      out += hex;
    }
  }
  return out;
}

}  // namespace fleetmap::internal
