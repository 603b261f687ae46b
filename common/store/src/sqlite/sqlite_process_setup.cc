#include "fleetmap/store/sqlite_process_setup.h"

#include <sqlite3.h>

namespace fleetmap {

void TuneSqliteForThisProcess() {
  // SQLITE_MISUSE once the library is initialised: then it keeps its statistics, which costs
  // time, never correctness.
  sqlite3_config(SQLITE_CONFIG_MEMSTATUS, 0);
}

}  // namespace fleetmap
