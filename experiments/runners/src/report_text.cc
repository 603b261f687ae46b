#include "report_text.h"

#include <cmath>
#include <cstdio>
#include <fstream>

#include "fleetmap/core/error.h"

namespace fleetmap {

std::string Fixed(double value, int decimals) {
  if (std::isnan(value)) return "-";
  char buffer[64];
  std::snprintf(buffer, sizeof buffer, "%.*f", decimals, value);
  return buffer;
}

void Save(const std::filesystem::path& file, const std::string& text) {
  std::ofstream out(file);
  out << text;
  out.close();
  if (!out) throw Error(ErrorCode::kBackend, "cannot write " + file.string());
}

}  // namespace fleetmap
