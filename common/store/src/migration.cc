#include "migration.h"

#include <algorithm>
#include <charconv>
#include <cstdint>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {

namespace {

[[noreturn]] void ThrowTooNew(const std::string& store, const std::string& version, int latest) {
  throw Error(ErrorCode::kSchemaTooNew, "store " + store + " has schema version " + version +
                                            ", newer than this fleetmap (knows up to " +
                                            std::to_string(latest) + "); use a newer fleetmap");
}

}  // namespace

int CheckedSchemaVersion(const std::string& store,
                         const std::vector<std::optional<std::string>>& rows, int latest) {
  std::int64_t highest = 0;
  for (const std::optional<std::string>& row : rows) {
    const auto corrupt = [&](const std::string& what) {
      return Error(ErrorCode::kCorrupt, "store " + store + ": fleetmap_schema.version " + what +
                                            "; it is not a fleetmap store this binary can "
                                            "open (restore it from a copy)");
    };
    if (!row) throw corrupt("is NULL");
    const std::string& text = *row;
    std::int64_t version = 0;
    const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), version);
    const bool digits = !text.empty() && std::all_of(text.begin(), text.end(),
                                                     [](char c) { return c >= '0' && c <= '9'; });
    // Digits past 64 bits are still a version, only one far newer than this binary.
    if (digits && ec == std::errc::result_out_of_range) ThrowTooNew(store, text, latest);
    if (ec != std::errc() || end != text.data() + text.size()) {
      throw corrupt("'" + text.substr(0, 40) + "' is not a whole number");
    }
    if (version < 0) throw corrupt("'" + text + "' is negative");
    highest = std::max(highest, version);
  }
  if (highest > latest) ThrowTooNew(store, std::to_string(highest), latest);
  return static_cast<int>(highest);
}

}  // namespace fleetmap::internal
