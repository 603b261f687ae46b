// Replays the sync-frame fuzz target over its seed corpus with the ordinary compiler, so the
// target keeps compiling and every seed (including any crash found and added later) keeps
// passing in the normal test run. The fuzzing itself is scripts/fuzz (clang's libFuzzer).
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size);

namespace {

TEST(SyncFrameFuzzReplay, EverySeedOfTheCorpusPasses) {
  const std::filesystem::path corpus = FLEETMAP_SYNC_FRAME_CORPUS;
  int seeds = 0;
  for (const auto& entry : std::filesystem::directory_iterator(corpus)) {
    std::ifstream in(entry.path(), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    EXPECT_EQ(
        LLVMFuzzerTestOneInput(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()),
        0)
        << entry.path();
    ++seeds;
  }
  EXPECT_GE(seeds, 4) << "the seed corpus at " << corpus << " is missing";
}

}  // namespace
