// PNG and JPEG files to and from OpenCV matrices, through libpng and libjpeg directly.
//
// Why not OpenCV's imgcodecs: on Debian it links GDAL, DICOM, HEIF and some ninety other shared
// libraries, and every process that links it loads them all when it starts. That cost about
// 90 ms of CPU per start (`fleetmap --help`: 155 ms with imgcodecs linked, 26 ms for a program
// linking the same libraries without it), paid by every robot tool, every test case and every
// `fleetmap` a script runs.
//
// Pixels follow OpenCV's conventions: colour channels in BGR(A) order, 16-bit samples in host
// order, rows top to bottom. Each mode decodes to the pixels cv::imdecode gives with the flag
// named beside it (tests/images compares the two on every layout).
//
// Threading: the functions keep no state; any thread may call them at once.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>

namespace fleetmap {

enum class ImagePixels {
  // IMREAD_UNCHANGED: a PNG as stored: 8 or 16 bit, grey (1 channel), BGR (3) or BGRA (4; grey
  // with alpha, and colour or a palette with transparency, become BGRA); grey below 8 bits is
  // scaled to 8. A JPEG: 8-bit grey or BGR.
  kAsStored,
  // IMREAD_GRAYSCALE: 8-bit grey. Colour becomes 0.299 R + 0.587 G + 0.114 B; 16-bit samples
  // keep their high byte; alpha is dropped.
  kGray8,
  // IMREAD_COLOR: 8-bit BGR. Grey is copied to the three channels; alpha is dropped.
  kBgr8,
};

// The pixels of a PNG or JPEG file's bytes (told apart by their signature), in `pixels`' form.
// `what` names the file in errors. Throws Error(kCorrupt) when the bytes are neither a PNG nor
// a JPEG file, or one that is cut short or damaged (a JPEG libjpeg would only warn about is
// refused too); Error(kInvalidArgument) for a JPEG in CMYK or YCCK.
cv::Mat DecodeImage(std::string_view bytes, ImagePixels pixels, const std::string& what);

// `pixels` as a PNG file's bytes: CV_8U or CV_16U with 1 (grey), 3 (BGR) or 4 (BGRA) channels,
// compressed as OpenCV writes PNG files (zlib level 1, run-length strategy). The bytes depend
// only on the pixels. Throws Error(kInvalidArgument) for an empty matrix or another type.
std::string EncodePng(const cv::Mat& pixels);

}  // namespace fleetmap
