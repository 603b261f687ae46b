// PNG through libpng: the decoder behind DecodeImage (fleetmap/images/image_codec.h), which
// also defines EncodePng.
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>

#include "fleetmap/images/image_codec.h"

namespace fleetmap::images_internal {

// Whether `bytes` begin with the PNG signature.
bool IsPng(std::string_view bytes);

// DecodeImage for a PNG file.
cv::Mat DecodePng(std::string_view bytes, ImagePixels pixels, const std::string& what);

}  // namespace fleetmap::images_internal
