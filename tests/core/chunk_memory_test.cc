// KeepChunkMemory (chunk_memory.h): a download's megabyte chunks are served from the heap and
// their memory stays with the process for the next chunk instead of going back to the kernel.
#include "fleetmap/core/chunk_memory.h"

#include <gtest/gtest.h>
#include <malloc.h>

#include <cstring>
#include <memory>
#include <vector>

namespace fleetmap {
namespace {

TEST(ChunkMemory, ChunksComeFromTheHeapAndStayWhenFreed) {
  KeepChunkMemory(32 << 20, 64 << 20);
  const struct mallinfo2 before = mallinfo2();
  std::vector<std::unique_ptr<char[]>> chunks;
  for (int i = 0; i < 16; ++i) {
    chunks.emplace_back(new char[1 << 20]);
    std::memset(chunks.back().get(), i, 1 << 20);  // touched, as a received chunk is
  }
  const struct mallinfo2 full = mallinfo2();
  // glibc's defaults map a fresh process's first megabyte blocks with mmap (hblkhd).
  EXPECT_EQ(full.hblkhd, before.hblkhd);
  EXPECT_GE(full.arena, before.arena + (16u << 20));
  chunks.clear();
  // 16 MiB freed at the top of the heap: kept (the default trims beyond about 2 MiB).
  EXPECT_GE(mallinfo2().arena, full.arena);
}

}  // namespace
}  // namespace fleetmap
