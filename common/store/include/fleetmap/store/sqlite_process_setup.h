// Process-wide settings of the SQLite library, for the programs that move whole maps through
// it (fleetmap-agent installing a download, fleetmapd serving one).
#pragma once

namespace fleetmap {

// Turns off SQLite's global memory statistics. Each connection here is used by one thread at a
// time (graph_store.h), but with statistics on every allocation SQLite makes still takes a
// process-wide mutex to count it: a download's install allocates per row, on the thread that
// limits the pull (sync_download_benchmark, AgentPull).
// REQUIRES: called first thing in main, before any store is opened and before other threads
// start (SQLite refuses it once initialised; it is then a no-op).
void TuneSqliteForThisProcess();

}  // namespace fleetmap
