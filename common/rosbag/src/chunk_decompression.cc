// Chunk decompression for ROS bags (chunk_decompression.h).
#include "chunk_decompression.h"

#include <bzlib.h>
#include <lz4frame.h>

#include <climits>
#include <memory>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {
namespace {

[[noreturn]] void Undecodable(const std::string& context, const std::string& why) {
  throw Error(ErrorCode::kCorrupt, context + ": " + why);
}

std::string Bz2(std::string_view compressed, std::uint32_t size, const std::string& context) {
  if (compressed.size() > UINT_MAX) Undecodable(context, "bz2 data over 4 GiB");
  // One byte of room past `size`, so a chunk that holds more than it says is caught.
  std::string out(std::size_t{size} + 1, '\0');
  unsigned int produced = size + 1;
  const int rc =
      BZ2_bzBuffToBuffDecompress(out.data(), &produced, const_cast<char*>(compressed.data()),
                                 static_cast<unsigned int>(compressed.size()), 0, 0);
  if (rc == BZ_OUTBUFF_FULL) {
    Undecodable(context,
                "bz2 data decompress to more than the chunk's size " + std::to_string(size));
  }
  if (rc != BZ_OK) {
    Undecodable(context, "bz2 data do not decompress (libbz2 error " + std::to_string(rc) + ")");
  }
  if (produced != size) {
    Undecodable(context, "bz2 data decompress to " + std::to_string(produced) +
                             " bytes, not the chunk's size " + std::to_string(size));
  }
  out.resize(size);
  return out;
}

std::string Lz4(std::string_view compressed, std::uint32_t size, const std::string& context) {
  LZ4F_dctx* raw = nullptr;
  if (LZ4F_isError(LZ4F_createDecompressionContext(&raw, LZ4F_VERSION))) {
    throw Error(ErrorCode::kBackend, context + ": cannot create an LZ4 decompression context");
  }
  const std::unique_ptr<LZ4F_dctx, decltype(&LZ4F_freeDecompressionContext)> dctx(
      raw, &LZ4F_freeDecompressionContext);
  std::string out(std::size_t{size} + 1, '\0');  // room for one byte too many, as Bz2
  std::size_t in_done = 0, out_done = 0;
  std::size_t hint = 1;
  while (in_done < compressed.size() && hint != 0) {
    std::size_t in_bytes = compressed.size() - in_done;
    std::size_t out_bytes = out.size() - out_done;
    hint = LZ4F_decompress(dctx.get(), out.data() + out_done, &out_bytes,
                           compressed.data() + in_done, &in_bytes, nullptr);
    if (LZ4F_isError(hint)) {
      Undecodable(context, std::string("lz4 data do not decompress: ") + LZ4F_getErrorName(hint));
    }
    in_done += in_bytes;
    out_done += out_bytes;
    if (in_bytes == 0 && out_bytes == 0) break;  // no progress: the output is full
  }
  if (hint != 0) Undecodable(context, "lz4 frame cut short (the chunk ends inside it)");
  if (in_done != compressed.size()) {
    Undecodable(context, std::to_string(compressed.size() - in_done) +
                             " bytes after the end of the lz4 frame");
  }
  if (out_done != size) {
    Undecodable(context,
                "lz4 data decompress to " +
                    (out_done > size ? std::string("more than") : std::to_string(out_done)) +
                    " bytes, not the chunk's size " + std::to_string(size));
  }
  out.resize(size);
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

}  // namespace fleetmap::internal
