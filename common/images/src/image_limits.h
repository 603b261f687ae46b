// The largest image the decoders allocate for: OpenCV's own limits (CV_IO_MAX_IMAGE_WIDTH,
// CV_IO_MAX_IMAGE_PIXELS), so that what cv::imdecode read, DecodeImage reads. A file's header
// alone could otherwise make the decoder allocate gigabytes.
#pragma once

#include <cstdint>
#include <string>

namespace fleetmap::images_internal {

inline constexpr std::uint64_t kMaxSidePx = std::uint64_t{1} << 20;
inline constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 30;

// Throws Error(kCorrupt) naming `what` when width x height is empty or beyond the limits.
void CheckImageSize(std::uint64_t width_px, std::uint64_t height_px, const std::string& what);

}  // namespace fleetmap::images_internal
