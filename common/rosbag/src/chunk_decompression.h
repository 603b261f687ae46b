// Decompressing a chunk of a ROS bag (bag_reader.h): "none", "bz2" (libbz2) or "lz4" (rosbag's
// roslz4 writes the LZ4 frame format, read with liblz4's frame API); and of an MCAP file
// (mcap_reader.h): "" (none), "lz4" (the LZ4 frame format too) or "zstd" (libzstd's streaming
// API; one or more Zstandard frames). Private to the library.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace fleetmap::internal {

// The compressions DecompressChunk knows, for error messages: "none, bz2, lz4".
inline constexpr const char* kSupportedChunkCompressions = "none, bz2, lz4";

// Decompresses `compressed` into exactly `size` bytes. Throws Error(kInvalidArgument) naming an
// unsupported `compression` (and the supported ones), Error(kCorrupt) prefixed by `context`
// when the bytes do not decompress or decompress to another size than `size`. Memory follows
// what the bytes really decompress to: `size` is a claim, checked, never allocated up front.
std::string DecompressChunk(std::string_view compression, std::string_view compressed,
                            std::uint32_t size, const std::string& context);

// The compressions DecompressMcapChunk knows, for error messages.
inline constexpr const char* kSupportedMcapCompressions = "none (\"\"), lz4, zstd";

// As DecompressChunk, for an MCAP chunk's `compression` ("", "lz4" or "zstd").
std::string DecompressMcapChunk(std::string_view compression, std::string_view compressed,
                                std::uint64_t size, const std::string& context);

}  // namespace fleetmap::internal
