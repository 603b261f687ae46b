// JPEG through libjpeg(-turbo): the decoder behind DecodeImage (fleetmap/images/image_codec.h).
#pragma once

#include <opencv2/core/mat.hpp>
#include <string>
#include <string_view>

#include "fleetmap/images/image_codec.h"

namespace fleetmap::images_internal {

// Whether `bytes` begin as a JPEG file does (the SOI marker and the next marker's 0xFF).
bool IsJpeg(std::string_view bytes);

// DecodeImage for a JPEG file.
cv::Mat DecodeJpeg(std::string_view bytes, ImagePixels pixels, const std::string& what);

}  // namespace fleetmap::images_internal
