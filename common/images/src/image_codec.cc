#include "fleetmap/images/image_codec.h"

#include "fleetmap/core/error.h"
#include "image_limits.h"
#include "jpeg_decoder.h"
#include "png_codec.h"

namespace fleetmap {

namespace images_internal {

void CheckImageSize(std::uint64_t width_px, std::uint64_t height_px, const std::string& what) {
  if (width_px == 0 || height_px == 0 || width_px > kMaxSidePx || height_px > kMaxSidePx ||
      width_px * height_px > kMaxPixels) {
    throw Error(ErrorCode::kCorrupt, what + ": the file declares " + std::to_string(width_px) +
                                         "x" + std::to_string(height_px) +
                                         " pixels, which is empty or beyond " +
                                         std::to_string(kMaxPixels) + " pixels");
  }
}

}  // namespace images_internal

cv::Mat DecodeImage(std::string_view bytes, ImagePixels pixels, const std::string& what) {
  if (images_internal::IsPng(bytes)) return images_internal::DecodePng(bytes, pixels, what);
  if (images_internal::IsJpeg(bytes)) return images_internal::DecodeJpeg(bytes, pixels, what);
  throw Error(ErrorCode::kCorrupt, what + ": its " + std::to_string(bytes.size()) +
                                       " bytes are neither a PNG nor a JPEG file");
}

}  // namespace fleetmap
