#include "fleetmap/core/chunk_memory.h"

#include <malloc.h>

namespace fleetmap {

void KeepChunkMemory(std::size_t heap_block_bytes, std::size_t keep_bytes) {
  // Fixing either threshold also turns off glibc's dynamic adjustment of both; each alone
  // gained half as much as the two together (measured with GLIBC_TUNABLES).
  mallopt(M_MMAP_THRESHOLD, static_cast<int>(heap_block_bytes));
  mallopt(M_TRIM_THRESHOLD, static_cast<int>(keep_bytes));
}

}  // namespace fleetmap
