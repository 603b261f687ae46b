#include "jpeg_decoder.h"

// jpeglib.h needs size_t and FILE declared before it.
#include <cstddef>
#include <cstdio>
// clang-format off
#include <jpeglib.h>
#include <jerror.h>
// clang-format on

#include <csetjmp>

#include "fleetmap/core/error.h"
#include "image_limits.h"

namespace fleetmap::images_internal {
namespace {

// libjpeg's error manager with where to jump on an error and the first message. libjpeg ends
// a failed call through error_exit, which must not return: it longjmps to the setjmp of the
// function that made the call, so those functions hold no object with a destructor, and this
// struct is plain data. `manager` comes first: libjpeg hands back a pointer to it.
struct JpegFailure {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char error[JMSG_LENGTH_MAX];
  char damage[JMSG_LENGTH_MAX];  // the first warning that the data is cut short or damaged
};

[[noreturn]] void OnJpegError(j_common_ptr jpeg) {
  auto* failure = reinterpret_cast<JpegFailure*>(jpeg->err);
  (*jpeg->err->format_message)(jpeg, failure->error);
  std::longjmp(failure->jump, 1);
}

// libjpeg goes on after a warning, filling what it could not read with grey. Bytes between
// markers (JWRN_EXTRANEOUS_DATA), which some cameras write, cost no pixel; every other warning
// means pixels that are not the file's, so it is kept and the file refused.
void OnJpegMessage(j_common_ptr jpeg, int level) {
  auto* failure = reinterpret_cast<JpegFailure*>(jpeg->err);
  if (level >= 0 || jpeg->err->msg_code == JWRN_EXTRANEOUS_DATA) return;
  if (failure->damage[0] == '\0') (*jpeg->err->format_message)(jpeg, failure->damage);
}

bool ReadJpegHeader(jpeg_decompress_struct* jpeg, JpegFailure* failure, std::string_view bytes) {
  if (setjmp(failure->jump)) return false;
  jpeg_mem_src(jpeg, reinterpret_cast<const unsigned char*>(bytes.data()),
               static_cast<unsigned long>(bytes.size()));
  jpeg_read_header(jpeg, TRUE);
  return true;
}

// Reads the pixels into the rows of `image` (grey or BGR, as OpenCV's JPEG decoder asks
// libjpeg for them).
bool ReadJpegPixels(jpeg_decompress_struct* jpeg, JpegFailure* failure, cv::Mat* image) {
  if (setjmp(failure->jump)) return false;
  const bool colour = image->channels() == 3;
  jpeg->out_color_space = colour ? JCS_EXT_BGR : JCS_GRAYSCALE;
  jpeg->out_color_components = colour ? 3 : 1;
  jpeg_start_decompress(jpeg);
  if (jpeg->output_width != static_cast<JDIMENSION>(image->cols) ||
      jpeg->output_height != static_cast<JDIMENSION>(image->rows) ||
      jpeg->output_components != image->channels()) {
    // Not what the header said: no row is written (jpeg_destroy_decompress ends the rest).
    std::snprintf(failure->error, sizeof failure->error, "%s",
                  "the decoded size differs from the header's");
    return false;
  }
  while (jpeg->output_scanline < jpeg->output_height) {
    JSAMPROW row = image->ptr(static_cast<int>(jpeg->output_scanline));
    jpeg_read_scanlines(jpeg, &row, 1);
  }
  jpeg_finish_decompress(jpeg);
  return true;
}

}  // namespace

bool IsJpeg(std::string_view bytes) {
  return bytes.size() >= 3 && static_cast<unsigned char>(bytes[0]) == 0xFF &&
         static_cast<unsigned char>(bytes[1]) == 0xD8 &&
         static_cast<unsigned char>(bytes[2]) == 0xFF;
}

cv::Mat DecodeJpeg(std::string_view bytes, ImagePixels pixels, const std::string& what) {
  if (bytes.size() > std::size_t{0xFFFFFFFFu}) {
    throw Error(ErrorCode::kCorrupt, what + ": a JPEG file of " + std::to_string(bytes.size()) +
                                         " bytes is beyond what libjpeg reads");
  }
  jpeg_decompress_struct jpeg{};
  JpegFailure failure{};
  jpeg.err = jpeg_std_error(&failure.manager);
  failure.manager.error_exit = OnJpegError;
  failure.manager.emit_message = OnJpegMessage;
  jpeg_create_decompress(&jpeg);
  struct Release {
    jpeg_decompress_struct* jpeg;
    ~Release() { jpeg_destroy_decompress(jpeg); }
  } release{&jpeg};

  const auto corrupt = [&](const char* message) {
    return Error(ErrorCode::kCorrupt,
                 what + ": the JPEG file does not decode (" + std::string(message) + ")");
  };
  if (!ReadJpegHeader(&jpeg, &failure, bytes)) throw corrupt(failure.error);
  if (jpeg.jpeg_color_space == JCS_CMYK || jpeg.jpeg_color_space == JCS_YCCK) {
    throw Error(ErrorCode::kInvalidArgument,
                what + ": a CMYK JPEG file, which is not supported (supported: grey and colour)");
  }
  CheckImageSize(jpeg.image_width, jpeg.image_height, what + ": the JPEG file");
  const bool colour =
      pixels == ImagePixels::kBgr8 || (pixels == ImagePixels::kAsStored && jpeg.num_components > 1);
  cv::Mat image(static_cast<int>(jpeg.image_height), static_cast<int>(jpeg.image_width),
                colour ? CV_8UC3 : CV_8UC1);
  if (!ReadJpegPixels(&jpeg, &failure, &image)) throw corrupt(failure.error);
  if (failure.damage[0] != '\0') throw corrupt(failure.damage);
  return image;
}

}  // namespace fleetmap::images_internal
