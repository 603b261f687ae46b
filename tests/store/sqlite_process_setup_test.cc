// TuneSqliteForThisProcess (sqlite_process_setup.h): called first, SQLite keeps no global
// memory statistics, so no allocation takes its process-wide mutex. A binary of its own: the
// call only works before SQLite is first used in the process.
#include "fleetmap/store/sqlite_process_setup.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include "fleetmap/store/graph_store.h"
#include "random_robot_map.h"
#include "scratch_dir.h"

namespace fleetmap::testing {
namespace {

TEST(SqliteProcessSetup, AStoreWritesWithoutMemoryStatistics) {
  TuneSqliteForThisProcess();
  ScratchDir dir{"fleetmap-sqlite-setup"};
  auto store = GraphStore::Open("sqlite:" + (dir / "map.db").string());
  store->Put(RandomRobotMap(Uuid::Generate(), 50, 1));
  EXPECT_EQ(store->Stats().nodes, 50);
  // With statistics on (SQLite's default) this counts every byte SQLite holds: the open
  // connection's schema and page cache, some hundreds of kB.
  EXPECT_EQ(sqlite3_memory_used(), 0);
}

}  // namespace
}  // namespace fleetmap::testing
