// How a process that streams maps in chunks (fleetmapd serving downloads, fleetmap-agent
// installing them) asks glibc's allocator to keep freed memory for the next chunk.
//
// A download moves a map through memory a megabyte at a time: a chunk is read or received,
// its nodes encoded or decoded, and all of it freed once sent or written. glibc's default
// thresholds are dynamic: blocks of about a chunk's size go to mmap or, once freed at the top
// of the heap, back to the kernel, so the next chunk faults the same megabytes in again,
// zeroed. Per 542 MB pull that was about a third of the agent's CPU and a quarter of the
// server's (sync_download_benchmark, AgentPull: agent 5.5-6.5 CPU s and server 2.0-2.4 without,
// about 3 and 1.3-1.6 with).
#pragma once

#include <cstddef>

namespace fleetmap {

// Serves blocks below `heap_block_bytes` from the heap and keeps up to `keep_bytes` of freed
// heap instead of returning it to the kernel. Process-wide: call once, first thing in main.
// What a process holds stays bounded by what it has in flight (its chunk queues), plus at most
// `keep_bytes` and what fragments among heap blocks.
void KeepChunkMemory(std::size_t heap_block_bytes, std::size_t keep_bytes);

}  // namespace fleetmap
