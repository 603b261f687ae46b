// What a PNG or JPEG file says of its image before anything is decoded: its size, and the pixels
// a decoder would make of it. Read so that the import (ros_image_png.h) refuses an image too
// large for any camera before a decoder allocates it: a file of a few hundred bytes can declare
// 32768 x 32768 pixels, and libpng and libjpeg allocate what the header declares, then fill what
// the data does not give. Private to the library.
//
// PNG (ISO/IEC 15948, W3C PNG 2nd ed.): the 8-byte signature, then the IHDR chunk, always first
// (§5.6): length 13, "IHDR", width and height (4 bytes each, big-endian), bit depth, colour type,
// compression, filter, interlace, then the CRC-32 of type and data (§5.5). The CRC is checked so
// that a damaged header is told from an unsupported one; it is no defence against a file made to
// declare a size, whose maker computes it.
//
// JPEG (ITU-T T.81 §B.1.1, B.2.2): SOI (FF D8), then marker segments, each FF, a marker code and
// (but for RSTn, TEM) a 2-byte big-endian length counting itself; the frame header SOFn (C0-C3,
// C5-C7, C9-CB, CD-CF) holds the sample precision, the number of lines, the samples per line and
// the number of components. The first SOFn is the one libjpeg decodes (a second is an error to
// it), and it comes before the first scan (SOS); bytes between segments that are not a marker
// are skipped as libjpeg skips them.
#pragma once

#include <cstdint>
#include <string>
#include <string_view>

namespace fleetmap::internal {

struct EncodedImageHeader {
  std::uint32_t width_px = 0, height_px = 0;
  // What DecodeImage(kAsStored) (fleetmap/images/image_codec.h) makes of the file: channels of
  // pixels and bytes a sample, at most (a PNG palette with transparency becomes 4 channels).
  int channels = 0;
  int bytes_per_sample = 0;
  // Non-empty: pixels the import does not store (alpha, 16-bit colour), said so.
  std::string unsupported;
};

// The header of a PNG file (`data` begins with PNG's signature). Throws Error(kCorrupt) when the
// IHDR chunk is not there, is cut short, does not match its CRC-32, or declares no pixels (a
// width or height of 0) or an unknown bit depth or colour type.
EncodedImageHeader ReadPngHeader(std::string_view data);

// The frame header of a JPEG file (`data` begins with FF D8 FF). Throws Error(kCorrupt) when
// no frame header comes before the first scan or the end of the data, a segment runs past the
// end, or it declares no pixels (0 lines: a height given later by a DNL marker, which libjpeg
// does not read either) or no components.
EncodedImageHeader ReadJpegHeader(std::string_view data);

}  // namespace fleetmap::internal
