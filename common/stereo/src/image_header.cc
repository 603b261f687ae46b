// PNG and JPEG headers read without decoding (image_header.h).
#include "image_header.h"

#include <array>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {
namespace {

[[noreturn]] void Bad(std::string_view codec, const std::string& why) {
  throw Error(ErrorCode::kCorrupt, "the " + std::string(codec) + " file " + why);
}

std::uint32_t BigEndian(std::string_view data, std::size_t at, int bytes) {
  std::uint32_t v = 0;
  for (int i = 0; i < bytes; ++i) v = v << 8 | static_cast<unsigned char>(data[at + i]);
  return v;
}

// CRC-32 of PNG (ISO 3309, polynomial 0xEDB88320 reflected; PNG §5.5 and Annex D).
std::uint32_t Crc32(std::string_view bytes) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t n = 0; n < 256; ++n) {
      std::uint32_t c = n;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
      t[n] = c;
    }
    return t;
  }();
  std::uint32_t c = 0xFFFFFFFFu;
  for (const char b : bytes) c = table[(c ^ static_cast<unsigned char>(b)) & 0xFF] ^ (c >> 8);
  return c ^ 0xFFFFFFFFu;
}

bool IsFrameHeader(unsigned char marker) {
  return marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
}

}  // namespace

EncodedImageHeader ReadPngHeader(std::string_view data) {
  constexpr std::size_t kIhdrEnd = 8 + 4 + 4 + 13 + 4;  // signature, length, type, data, CRC
  if (data.size() < kIhdrEnd) {
    Bad("png", "is cut short: " + std::to_string(data.size()) + " bytes, fewer than the " +
                   std::to_string(kIhdrEnd) + " of its signature and IHDR chunk");
  }
  if (BigEndian(data, 8, 4) != 13 || data.substr(12, 4) != "IHDR") {
    Bad("png", "does not begin with an IHDR chunk of 13 bytes");
  }
  if (Crc32(data.substr(12, 4 + 13)) != BigEndian(data, 29, 4)) {
    Bad("png", "has an IHDR chunk whose CRC-32 does not match");
  }
  EncodedImageHeader h;
  h.width_px = BigEndian(data, 16, 4);
  h.height_px = BigEndian(data, 20, 4);
  const auto depth = static_cast<unsigned char>(data[24]);
  const auto colour = static_cast<unsigned char>(data[25]);
  if (h.width_px == 0 || h.height_px == 0) {
    Bad("png", "declares " + std::to_string(h.width_px) + "x" + std::to_string(h.height_px) +
                   " pixels: none");
  }
  if (depth != 1 && depth != 2 && depth != 4 && depth != 8 && depth != 16) {
    Bad("png", "declares a bit depth of " + std::to_string(depth));
  }
  // OpenCV widens samples under 8 bits to 8 and gives a palette (and RGB with a transparent
  // colour) as BGR(A).
  h.bytes_per_sample = depth == 16 ? 2 : 1;
  switch (colour) {
    case 0:  // grey
      h.channels = 1;
      break;
    case 2:            // RGB
    case 3:            // palette
      h.channels = 4;  // 3, or 4 with a tRNS chunk, which comes later
      if (depth == 16) h.unsupported = "16-bit colour";
      break;
    case 4:  // grey and alpha
    case 6:  // RGB and alpha
      h.channels = 4;
      h.unsupported = "an alpha channel";
      break;
    default:
      Bad("png", "declares colour type " + std::to_string(colour) + ", which PNG has not");
  }
  return h;
}

EncodedImageHeader ReadJpegHeader(std::string_view data) {
  std::size_t at = 2;  // after SOI
  for (;;) {
    // The next marker: FF (any number of them) and a code other than 00 (a stuffed FF 00 in
    // entropy-coded data) or FF.
    while (at < data.size() && static_cast<unsigned char>(data[at]) != 0xFF) ++at;
    while (at < data.size() && static_cast<unsigned char>(data[at]) == 0xFF) ++at;
    if (at >= data.size()) Bad("jpeg", "ends before its frame header (SOFn)");
    const auto marker = static_cast<unsigned char>(data[at++]);
    if (marker == 0x00 || marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;
    if (marker == 0xD8 || marker == 0xD9 || marker == 0xDA) {
      Bad("jpeg", "has no frame header (SOFn) before its first " +
                      std::string(marker == 0xDA   ? "scan"
                                  : marker == 0xD9 ? "EOI"
                                                   : "second SOI"));
    }
    if (at + 2 > data.size()) Bad("jpeg", "ends inside a marker segment's length");
    const std::uint32_t length = BigEndian(data, at, 2);
    if (length < 2 || at + length > data.size()) {
      Bad("jpeg", "has a marker segment of " + std::to_string(length) + " bytes at byte " +
                      std::to_string(at - 2) + " running past its " + std::to_string(data.size()) +
                      " bytes");
    }
    if (IsFrameHeader(marker)) {
      if (length < 8)
        Bad("jpeg", "has a frame header (SOFn) of " + std::to_string(length) + " bytes");
      const auto precision = static_cast<unsigned char>(data[at + 2]);
      EncodedImageHeader h;
      h.height_px = BigEndian(data, at + 3, 2);
      h.width_px = BigEndian(data, at + 5, 2);
      const auto components = static_cast<unsigned char>(data[at + 7]);
      if (h.width_px == 0 || h.height_px == 0 || components == 0) {
        Bad("jpeg", "declares " + std::to_string(h.width_px) + "x" + std::to_string(h.height_px) +
                        " pixels of " + std::to_string(components) + " components: none");
      }
      // libjpeg gives one component as grey, more (YCbCr, RGB, CMYK, YCCK) as OpenCV's BGR.
      h.channels = components == 1 ? 1 : 3;
      h.bytes_per_sample = precision > 8 ? 2 : 1;
      if (h.channels == 3 && precision > 8) h.unsupported = "16-bit colour";
      return h;
    }
    at += length;
  }
}

}  // namespace fleetmap::internal
