// Numbered, forward-only schema migrations, one SQL file per backend per step
// (common/src/<backend>/migrations/NNNN_name.sql), embedded at build time.
#pragma once

#include <vector>

namespace fleetmap::internal {

struct Migration {
  int version;       // NNNN of the file name; versions are 1, 2, 3, ... without gaps
  const char* name;  // the file name, for error messages
  const char* sql;
};

const std::vector<Migration>& SqliteMigrations();
const std::vector<Migration>& PostgresMigrations();

}  // namespace fleetmap::internal
