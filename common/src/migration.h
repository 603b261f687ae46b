// Numbered, forward-only schema migrations, one SQL file per backend per step
// (common/src/<backend>/migrations/NNNN_name.sql), embedded at build time.
#pragma once

#include <string>
#include <vector>

namespace fleetmap::internal {

struct Migration {
  int version;       // NNNN of the file name; versions are 1, 2, 3, ... without gaps
  const char* name;  // the file name, for error messages
  const char* sql;
};

// Throws Error(kSchemaTooNew) when a store's recorded version is newer than the latest
// migration this binary carries: an old binary must never write a newer schema.
void RefuseNewerSchema(const std::string& store, int current, int latest);

const std::vector<Migration>& SqliteMigrations();
const std::vector<Migration>& PostgresMigrations();

}  // namespace fleetmap::internal
