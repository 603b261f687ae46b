// Chunk decompression for ROS bags and MCAP files (chunk_decompression.h).
#include "chunk_decompression.h"

#include <bzlib.h>
#include <lz4frame.h>
#include <zstd.h>

#include <climits>
#include <memory>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {
namespace {

[[noreturn]] void Undecodable(const std::string& context, const std::string& why) {
  throw Error(ErrorCode::kCorrupt, context + ": " + why);
}

// Decompressed output is gathered one scratch buffer at a time, so memory follows the bytes the
// data really decompress to, never the size the chunk's header claims: a small bag claiming a
// 1 GiB chunk is refused after its few real bytes. Output beyond the claim
// is refused as it appears.
constexpr std::size_t kScratchBytes = std::size_t{1} << 16;

// Appends `n` bytes of `scratch` to `out`, refusing output beyond the chunk's `size`.
void AppendWithin(std::string& out, const char* scratch, std::size_t n, std::uint64_t size,
                  std::string_view codec, const std::string& context) {
  if (n > size - out.size()) {
    Undecodable(context, std::string(codec) + " data decompress to more than the chunk's size " +
                             std::to_string(size));
  }
  out.append(scratch, n);
}

std::string Bz2(std::string_view compressed, std::uint32_t size, const std::string& context) {
  if (compressed.size() > UINT_MAX) Undecodable(context, "bz2 data over 4 GiB");
  bz_stream stream{};
  if (BZ2_bzDecompressInit(&stream, 0, 0) != BZ_OK) {
    throw Error(ErrorCode::kBackend, context + ": cannot set up a bz2 decompressor");
  }
  const std::unique_ptr<bz_stream, decltype(&BZ2_bzDecompressEnd)> end(&stream,
                                                                       &BZ2_bzDecompressEnd);
  stream.next_in = const_cast<char*>(compressed.data());
  stream.avail_in = static_cast<unsigned int>(compressed.size());
  std::string out;
  std::unique_ptr<char[]> scratch(new char[kScratchBytes]);
  for (;;) {
    stream.next_out = scratch.get();
    stream.avail_out = static_cast<unsigned int>(kScratchBytes);
    const unsigned int in_before = stream.avail_in;
    const int rc = BZ2_bzDecompress(&stream);
    if (rc != BZ_OK && rc != BZ_STREAM_END) {
      Undecodable(context, "bz2 data do not decompress (libbz2 error " + std::to_string(rc) + ")");
    }
    const std::size_t produced = kScratchBytes - stream.avail_out;
    AppendWithin(out, scratch.get(), produced, size, "bz2", context);
    if (rc == BZ_STREAM_END) break;
    if (produced == 0 && stream.avail_in == in_before) {  // no progress: the input is used up
      Undecodable(context, "bz2 data end inside their stream (libbz2 error " +
                               std::to_string(BZ_UNEXPECTED_EOF) + ")");
    }
  }
  if (out.size() != size) {
    Undecodable(context, "bz2 data decompress to " + std::to_string(out.size()) +
                             " bytes, not the chunk's size " + std::to_string(size));
  }
  return out;
}

std::string Lz4(std::string_view compressed, std::uint64_t size, const std::string& context) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
    throw Error(ErrorCode::kBackend, context + ": cannot create an LZ4 decompression context");
  }
  const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> dctx(
      raw, &LZ4F_freeDecompressionContext);
  std::string out;
  std::unique_ptr<char[]> scratch(new char[kScratchBytes]);
  std::size_t in_done = 0;
  std::size_t hint = 1;
  while (hint != 0) {
    std::size_t in_bytes = compressed.size() - in_done;
    std::size_t out_bytes = kScratchBytes;
    hint = LZ4F_decompress(dctx.get(), scratch.get(), &out_bytes, compressed.data() + in_done,
                           &in_bytes, nullptr);
    if (LZ4F_isError(hint)) {
      Undecodable(context, std::string("lz4 data do not decompress: ") + LZ4F_getErrorName(hint));
    }
    in_done += in_bytes;
    AppendWithin(out, scratch.get(), out_bytes, size, "lz4", context);
    if (in_bytes == 0 && out_bytes == 0) break;  // no progress: the input is used up
  }
  if (hint != 0) Undecodable(context, "lz4 frame cut short (the chunk ends inside it)");
  if (in_done != compressed.size()) {
    Undecodable(context, std::to_string(compressed.size() - in_done) +
                             " bytes after the end of the lz4 frame");
  }
  if (out.size() != size) {
    Undecodable(context, "lz4 data decompress to " + std::to_string(out.size()) +
                             " bytes, not the chunk's size " + std::to_string(size));
  }
  return out;
}

std::string Zstd(std::string_view compressed, std::uint64_t size, const std::string& context) {
  const std::unique_ptr<ZSTD_DCtx, decltype(&ZSTD_freeDCtx)> dctx(ZSTD_createDCtx(),
                                                                  &ZSTD_freeDCtx);
  if (!dctx) throw Error(ErrorCode::kBackend, context + ": cannot create a zstd decompressor");
  std::string out;
  std::unique_ptr<char[]> scratch(new char[kScratchBytes]);
  ZSTD_inBuffer in{compressed.data(), compressed.size(), 0};
  for (;;) {
    ZSTD_outBuffer piece{scratch.get(), kScratchBytes, 0};
    const std::size_t hint = ZSTD_decompressStream(dctx.get(), &piece, &in);
    if (ZSTD_isError(hint)) {
      Undecodable(context, std::string("zstd data do not decompress: ") + ZSTD_getErrorName(hint));
    }
    AppendWithin(out, scratch.get(), piece.pos, size, "zstd", context);
    // 0: a frame ended and all of it is flushed. That may happen in the call that fills the
    // buffer exactly (a chunk of a multiple of kScratchBytes), so it ends the chunk when the
    // input is used up, whether or not the buffer is full; asking again would start a next frame
    // from no input and hear "more input", which is not a cut.
    if (hint == 0 && in.pos == in.size) break;
    // Mid-frame with the input used up and room left in the buffer: nothing more can come out.
    if (in.pos == in.size && piece.pos < piece.size) {
      Undecodable(context, "zstd frame cut short (the chunk ends inside it)");
    }
  }
  if (out.size() != size) {
    Undecodable(context, "zstd data decompress to " + std::to_string(out.size()) +
                             " bytes, not the chunk's size " + std::to_string(size));
  }
  return out;
}

}  // namespace

std::string DecompressChunk(std::string_view compression, std::string_view compressed,
                            std::uint32_t size, const std::string& context) {
  if (compression == "none") {
    if (compressed.size() != size) {
      Undecodable(context, "uncompressed chunk of " + std::to_string(compressed.size()) +
                               " bytes, but its header says " + std::to_string(size));
    }
    return std::string(compressed);
  }
  if (compression == "bz2") return Bz2(compressed, size, context);
  if (compression == "lz4") return Lz4(compressed, size, context);
  throw Error(ErrorCode::kInvalidArgument,
              context + ": unsupported compression '" + std::string(compression) +
                  "' (supported: " + kSupportedChunkCompressions + ")");
}

std::string DecompressMcapChunk(std::string_view compression, std::string_view compressed,
                                std::uint64_t size, const std::string& context) {
  if (compression.empty()) {
    if (compressed.size() != size) {
      Undecodable(context, "uncompressed chunk of " + std::to_string(compressed.size()) +
                               " bytes, but its uncompressed size says " + std::to_string(size));
    }
    return std::string(compressed);
  }
  if (compression == "lz4") return Lz4(compressed, size, context);
  if (compression == "zstd") return Zstd(compressed, size, context);
  throw Error(ErrorCode::kInvalidArgument, context + ": unsupported compression '" +
                                               std::string(compression) +
                                               "' (supported: " + kSupportedMcapCompressions + ")");
}

}  // namespace fleetmap::internal
