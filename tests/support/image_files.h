// Image files as the tests write and read them: bytes of a file, and PNG files through
// fleetmap_images (fleetmap/images/image_codec.h). What fleetmap_images decodes and encodes is
// compared with OpenCV's own codecs in tests/images, the one test binary that links them.
#pragma once

#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/core/mat.hpp>
#include <string>

#include "fleetmap/images/image_codec.h"

namespace fleetmap::testing {

inline std::string ReadFileBytes(const std::filesystem::path& file) {
  std::ifstream in(file, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

inline void WriteFileBytes(const std::filesystem::path& file, const std::string& bytes) {
  std::ofstream(file, std::ios::binary | std::ios::trunc) << bytes;
}

inline void WritePngFile(const std::filesystem::path& file, const cv::Mat& pixels) {
  WriteFileBytes(file, EncodePng(pixels));
}

// The pixels of a PNG or JPEG file; an empty matrix when it does not decode, as cv::imread.
inline cv::Mat ReadImageFile(const std::filesystem::path& file, ImagePixels pixels) {
  try {
    return DecodeImage(ReadFileBytes(file), pixels, file.string());
  } catch (const Error&) {
    return {};
  }
}

}  // namespace fleetmap::testing
