// The frame decoder under arbitrary bytes (sync_frame.h): what a session does with whatever a
// peer sends. The bytes arrive in pieces whose sizes come from the input itself, so splits land
// inside prefixes and bodies. Properties checked:
// - the decoder returns frames or throws fleetmap::Error; nothing else escapes, nothing crashes;
// - a frame it returns has a body and survives re-encoding: decode(encode(f)) == f.
// Built as a libFuzzer target by scripts/fuzz (clang), and replayed over the seed corpus by the
// ordinary test suite (sync_frame_fuzz_replay) so it keeps compiling and its seeds keep passing.
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string_view>

#include "fleetmap/core/error.h"
#include "fleetmap/wire/sync_frame.h"

namespace {

void Check(bool condition) {
  if (!condition) std::abort();  // a property failed: libFuzzer records the input
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using fleetmap::SyncFrameDecoder;
  if (size == 0) return 0;
  const std::string_view input(reinterpret_cast<const char*>(data), size);
  // A small cap, so the fuzzer also reaches "over the cap" with short inputs.
  SyncFrameDecoder decoder(1 << 16);
  const std::size_t piece = 1 + static_cast<std::uint8_t>(input[0]) % 32;
  try {
    for (std::size_t at = 1; at < input.size(); at += piece) {
      decoder.Append(input.substr(at, piece));
      while (std::optional<fleetmap::v1::SyncFrame> frame = decoder.Next()) {
        Check(frame->body_case() != fleetmap::v1::SyncFrame::BODY_NOT_SET);
        const std::string encoded = fleetmap::EncodeSyncFrame(*frame);
        const fleetmap::v1::SyncFrame again = fleetmap::DecodeSyncFrameBody(
            std::string_view(encoded).substr(fleetmap::kSyncFrameLengthBytes));
        Check(again.SerializeAsString() == frame->SerializeAsString());
      }
    }
  } catch (const fleetmap::Error&) {
    // Refused input: what a session turns into an ErrorFrame and a close.
  }
  return 0;
}
