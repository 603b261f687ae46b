// JPEG files for the tests that read them (image_transport's compressed images, a camera
// folder holding something other than PNG), written with libjpeg's own encoder: fleetmap only
// decodes JPEG. A binary that includes this links JPEG::JPEG.
#pragma once

#include <cstddef>
#include <cstdio>
#include <cstdlib>
// clang-format off
#include <jpeglib.h>
// clang-format on

#include <opencv2/core/mat.hpp>
#include <string>

namespace fleetmap::testing {

// `pixels` (CV_8UC1 grey, CV_8UC3 BGR or CV_8UC4 CMYK) as a JPEG file of `quality` (1-100).
// libjpeg's default error handler ends the test program with its message on an error.
inline std::string EncodeJpegForTest(const cv::Mat& pixels, int quality = 95) {
  jpeg_compress_struct jpeg{};
  jpeg_error_mgr errors{};
  jpeg.err = jpeg_std_error(&errors);
  jpeg_create_compress(&jpeg);
  unsigned char* out = nullptr;
  unsigned long out_size = 0;
  jpeg_mem_dest(&jpeg, &out, &out_size);
  jpeg.image_width = static_cast<JDIMENSION>(pixels.cols);
  jpeg.image_height = static_cast<JDIMENSION>(pixels.rows);
  jpeg.input_components = pixels.channels();
  jpeg.in_color_space = pixels.channels() == 4   ? JCS_CMYK
                        : pixels.channels() == 3 ? JCS_EXT_BGR
                                                 : JCS_GRAYSCALE;
  jpeg_set_defaults(&jpeg);
  jpeg_set_quality(&jpeg, quality, TRUE);
  jpeg_start_compress(&jpeg, TRUE);
  while (jpeg.next_scanline < jpeg.image_height) {
    // libjpeg reads the row only; its API takes it as non-const.
    JSAMPROW row = const_cast<JSAMPROW>(pixels.ptr(static_cast<int>(jpeg.next_scanline)));
    jpeg_write_scanlines(&jpeg, &row, 1);
  }
  jpeg_finish_compress(&jpeg);
  std::string file(reinterpret_cast<const char*>(out), out_size);
  jpeg_destroy_compress(&jpeg);
  std::free(out);
  return file;
}

}  // namespace fleetmap::testing
