// Numbered, forward-only schema migrations, one SQL file per backend per step
// (common/store/src/<backend>/migrations/NNNN_name.sql), embedded at build time.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace fleetmap::internal {

struct Migration {
  int version;       // NNNN of the file name; versions are 1, 2, 3, ... without gaps
  const char* name;  // the file name, for error messages
  const char* sql;
};

// The schema version a store records, checked, from its fleetmap_schema rows as text: each
// backend casts the column to text, so whatever a newer or damaged store holds arrives here
// unconverted (a cast to int read 4294967300 as 4); nullopt stands for a NULL. No rows reads as
// 0 (a store whose first migration never committed); of several rows the highest counts.
// Throws Error(kCorrupt) naming `store` for a value that is not a decimal integer or is
// negative, and Error(kSchemaTooNew) for one above `latest`: an old binary must never write a
// newer schema. The result is in [0, latest].
int CheckedSchemaVersion(const std::string& store,
                         const std::vector<std::optional<std::string>>& rows, int latest);

const std::vector<Migration>& SqliteMigrations();
const std::vector<Migration>& PostgresMigrations();

}  // namespace fleetmap::internal
