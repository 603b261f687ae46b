#include "png_codec.h"

#include <png.h>
#include <zlib.h>

#include <bit>
#include <cstdio>
#include <cstring>
#include <vector>

#include "fleetmap/core/error.h"
#include "image_limits.h"

namespace fleetmap {
namespace images_internal {
namespace {

// What libpng's callbacks share with the code that called libpng: the bytes read or written
// and the first error's message. libpng leaves a failed call by longjmp to the setjmp of the
// function that made it, so those functions hold no object with a destructor (skipping one
// would be undefined), and this struct is plain data.
struct PngStream {
  const unsigned char* data = nullptr;  // reading: the file
  std::size_t size = 0;
  std::size_t offset = 0;
  std::string* out = nullptr;  // writing: the file so far
  char error[192] = {};
};

[[noreturn]] void OnPngError(png_structp png, png_const_charp message) {
  auto* stream = static_cast<PngStream*>(png_get_error_ptr(png));
  std::snprintf(stream->error, sizeof stream->error, "%s", message);
  png_longjmp(png, 1);
}

// A warning (a damaged ancillary chunk, say) changes no pixel that is returned.
void OnPngWarning(png_structp, png_const_charp) {}

void ReadFromStream(png_structp png, png_bytep out, png_size_t length) {
  auto* stream = static_cast<PngStream*>(png_get_io_ptr(png));
  if (length > stream->size - stream->offset) png_error(png, "the file ends early");
  std::memcpy(out, stream->data + stream->offset, length);
  stream->offset += length;
}

void WriteToStream(png_structp png, png_bytep data, png_size_t length) {
  auto* stream = static_cast<PngStream*>(png_get_io_ptr(png));
  try {
    stream->out->append(reinterpret_cast<const char*>(data), length);
  } catch (const std::exception&) {  // no exception may cross libpng's C frames
    png_error(png, "out of memory for the encoded file");
  }
}

void FlushStream(png_structp) {}

// The header's facts that decide the decoded matrix's type.
struct PngLayout {
  png_uint_32 width = 0;
  png_uint_32 height = 0;
  int bit_depth = 0;
  int colour_type = 0;
  bool transparency = false;  // a tRNS chunk
};

// The matrix type cv::imdecode gives a PNG of `layout` for each mode.
int DecodedType(const PngLayout& layout, ImagePixels pixels) {
  if (pixels == ImagePixels::kGray8) return CV_8UC1;
  if (pixels == ImagePixels::kBgr8) return CV_8UC3;
  int channels = 1;
  switch (layout.colour_type) {
    case PNG_COLOR_TYPE_RGB:
    case PNG_COLOR_TYPE_PALETTE:
      channels = layout.transparency ? 4 : 3;
      break;
    case PNG_COLOR_TYPE_GRAY_ALPHA:
    case PNG_COLOR_TYPE_RGB_ALPHA:
      channels = 4;
      break;
    default:
      channels = 1;
  }
  return CV_MAKETYPE(layout.bit_depth == 16 ? CV_16U : CV_8U, channels);
}

bool ReadPngHeader(png_structp png, png_infop info, PngStream* stream, PngLayout* layout) {
  if (setjmp(png_jmpbuf(png))) return false;
  png_set_read_fn(png, stream, ReadFromStream);
  png_read_info(png, info);
  layout->width = png_get_image_width(png, info);
  layout->height = png_get_image_height(png, info);
  layout->bit_depth = png_get_bit_depth(png, info);
  layout->colour_type = png_get_color_type(png, info);
  layout->transparency = png_get_valid(png, info, PNG_INFO_tRNS) != 0;
  return true;
}

// Reads the pixels into `rows` (one pointer per row of a matrix of `type`), with the transforms
// OpenCV's PNG decoder sets for that type, so the two agree pixel for pixel.
bool ReadPngPixels(png_structp png, png_infop info, const PngLayout& layout, int type,
                   png_bytepp rows, std::size_t row_bytes) {
  if (setjmp(png_jmpbuf(png))) return false;
  const int channels = CV_MAT_CN(type);
  const bool colour = channels > 1;
  if (CV_MAT_DEPTH(type) == CV_8U && layout.bit_depth == 16) {
    png_set_strip_16(png);
  } else if constexpr (std::endian::native == std::endian::little) {
    png_set_swap(png);  // PNG stores 16-bit samples big-endian
  }
  if (channels < 4) {
    png_set_strip_alpha(png);
  } else {
    png_set_tRNS_to_alpha(png);
  }
  if (layout.colour_type == PNG_COLOR_TYPE_PALETTE) png_set_palette_to_rgb(png);
  if ((layout.colour_type & PNG_COLOR_MASK_COLOR) == 0 && layout.bit_depth < 8) {
    png_set_expand_gray_1_2_4_to_8(png);
  }
  if ((layout.colour_type & PNG_COLOR_MASK_COLOR) != 0 && colour) {
    png_set_bgr(png);
  } else if (colour) {
    png_set_gray_to_rgb(png);
  } else {
    png_set_rgb_to_gray(png, 1, 0.299, 0.587);  // OpenCV's weights (and the PNG spec's)
  }
  png_set_interlace_handling(png);
  png_read_update_info(png, info);
  // The transforms must give exactly a row of the matrix: png_read_image writes whole rows.
  if (png_get_rowbytes(png, info) != row_bytes) png_error(png, "unexpected decoded row size");
  png_read_image(png, rows);
  png_read_end(png, nullptr);
  return true;
}

bool WritePng(png_structp png, png_infop info, const cv::Mat& pixels, png_bytepp rows) {
  if (setjmp(png_jmpbuf(png))) return false;
  int colour_type = PNG_COLOR_TYPE_GRAY;
  if (pixels.channels() == 3) colour_type = PNG_COLOR_TYPE_RGB;
  if (pixels.channels() == 4) colour_type = PNG_COLOR_TYPE_RGB_ALPHA;
  // OpenCV's defaults, tuned for speed: the SUB filter, zlib's fastest level, run lengths.
  png_set_filter(png, PNG_FILTER_TYPE_BASE, PNG_FILTER_SUB);
  png_set_compression_level(png, Z_BEST_SPEED);
  png_set_compression_strategy(png, Z_RLE);
  png_set_IHDR(png, info, static_cast<png_uint_32>(pixels.cols),
               static_cast<png_uint_32>(pixels.rows), pixels.depth() == CV_16U ? 16 : 8,
               colour_type, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_write_info(png, info);
  if (pixels.channels() > 1) png_set_bgr(png);
  if (pixels.depth() == CV_16U && std::endian::native == std::endian::little) png_set_swap(png);
  png_write_image(png, rows);
  png_write_end(png, info);
  return true;
}

}  // namespace

bool IsPng(std::string_view bytes) {
  return bytes.size() >= 8 &&
         png_sig_cmp(reinterpret_cast<png_const_bytep>(bytes.data()), 0, 8) == 0;
}

cv::Mat DecodePng(std::string_view bytes, ImagePixels pixels, const std::string& what) {
  PngStream stream;
  stream.data = reinterpret_cast<const unsigned char*>(bytes.data());
  stream.size = bytes.size();
  png_structp png =
      png_create_read_struct(PNG_LIBPNG_VER_STRING, &stream, OnPngError, OnPngWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  struct Release {
    png_structp* png;
    png_infop* info;
    ~Release() { png_destroy_read_struct(png, *info != nullptr ? info : nullptr, nullptr); }
  } release{&png, &info};
  if (info == nullptr) throw Error(ErrorCode::kBackend, what + ": libpng could not start");

  const auto corrupt = [&] {
    return Error(ErrorCode::kCorrupt,
                 what + ": the PNG file does not decode (" + std::string(stream.error) + ")");
  };
  PngLayout layout;
  if (!ReadPngHeader(png, info, &stream, &layout)) throw corrupt();
  CheckImageSize(layout.width, layout.height, what + ": the PNG file");
  cv::Mat image(static_cast<int>(layout.height), static_cast<int>(layout.width),
                DecodedType(layout, pixels));
  std::vector<png_bytep> rows(image.rows);
  for (int r = 0; r < image.rows; ++r) rows[r] = image.ptr(r);
  if (!ReadPngPixels(png, info, layout, image.type(), rows.data(), image.cols * image.elemSize())) {
    throw corrupt();
  }
  return image;
}

}  // namespace images_internal

std::string EncodePng(const cv::Mat& pixels) {
  const int depth = pixels.depth();
  const int channels = pixels.channels();
  if (pixels.empty() || (depth != CV_8U && depth != CV_16U) ||
      (channels != 1 && channels != 3 && channels != 4) || pixels.dims != 2) {
    throw Error(ErrorCode::kInvalidArgument,
                "cannot encode as PNG a matrix of " + std::to_string(pixels.cols) + "x" +
                    std::to_string(pixels.rows) + " with " + std::to_string(channels) +
                    " channels of " + std::to_string(8 * pixels.elemSize1()) +
                    " bits (PNG takes 8 or 16 bits, 1, 3 or 4 channels)");
  }
  std::string file;
  images_internal::PngStream stream;
  stream.out = &file;
  png_structp png = png_create_write_struct(
      PNG_LIBPNG_VER_STRING, &stream, images_internal::OnPngError, images_internal::OnPngWarning);
  png_infop info = png != nullptr ? png_create_info_struct(png) : nullptr;
  struct Release {
    png_structp* png;
    png_infop* info;
    ~Release() { png_destroy_write_struct(png, *info != nullptr ? info : nullptr); }
  } release{&png, &info};
  if (info == nullptr) throw Error(ErrorCode::kBackend, "libpng could not start");
  png_set_write_fn(png, &stream, images_internal::WriteToStream, images_internal::FlushStream);
  // libpng reads the rows only; its API takes them as non-const.
  std::vector<png_bytep> rows(pixels.rows);
  for (int r = 0; r < pixels.rows; ++r) rows[r] = const_cast<png_bytep>(pixels.ptr(r));
  if (!images_internal::WritePng(png, info, pixels, rows.data())) {
    throw Error(ErrorCode::kBackend, "cannot encode an image as PNG: " + std::string(stream.error));
  }
  return file;
}

}  // namespace fleetmap
