// sensor_msgs/Image to PNG (ros_image_png.h).
#include "ros_image_png.h"

#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "fleetmap/core/error.h"

namespace fleetmap::internal {
namespace {

struct PixelFormat {
  int cv_type;
  int bytes_per_pixel;
};

PixelFormat FormatOf(const std::string& encoding) {
  if (encoding == "mono8") return {CV_8UC1, 1};
  if (encoding == "mono16") return {CV_16UC1, 2};
  if (encoding == "rgb8" || encoding == "bgr8") return {CV_8UC3, 3};
  throw Error(ErrorCode::kInvalidArgument,
              "image encoding '" + encoding +
                  "' is not supported (supported: " + kSupportedRosImageEncodings + ")");
}

}  // namespace

std::string RosImageToPng(const RosImage& image) {
  const PixelFormat format = FormatOf(image.encoding);
  if (image.width == 0 || image.height == 0) {
    throw Error(ErrorCode::kCorrupt, "sensor_msgs/Image of " + std::to_string(image.width) + "x" +
                                         std::to_string(image.height) + " pixels: empty");
  }
  const std::uint64_t row_bytes = std::uint64_t{image.width} * format.bytes_per_pixel;
  if (image.step < row_bytes) {
    throw Error(ErrorCode::kCorrupt, "sensor_msgs/Image " + image.encoding + " of width " +
                                         std::to_string(image.width) + " with step " +
                                         std::to_string(image.step) + ", shorter than a row (" +
                                         std::to_string(row_bytes) + " bytes)");
  }
  // Rows copied out packed: a step need not be a multiple of the pixel size (a mono16 row may
  // be padded by an odd byte count), which OpenCV cannot view. DecodeRosImage checked that
  // data holds step * height bytes.
  cv::Mat pixels(static_cast<int>(image.height), static_cast<int>(image.width), format.cv_type);
  for (int r = 0; r < pixels.rows; ++r) {
    std::memcpy(pixels.ptr(r), image.data.data() + std::size_t{image.step} * r, row_bytes);
  }
  if (image.encoding == "mono16" && image.is_bigendian) {
    for (int r = 0; r < pixels.rows; ++r) {
      auto* row = pixels.ptr<std::uint16_t>(r);
      for (int c = 0; c < pixels.cols; ++c) {
        row[c] = static_cast<std::uint16_t>((row[c] >> 8) | (row[c] << 8));
      }
    }
  } else if (image.encoding == "rgb8") {
    cv::cvtColor(pixels, pixels, cv::COLOR_RGB2BGR);  // imencode takes BGR
  }
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", pixels, png)) {
    throw Error(ErrorCode::kBackend, "cannot encode a " + image.encoding + " image of " +
                                         std::to_string(image.width) + "x" +
                                         std::to_string(image.height) + " as PNG");
  }
  return std::string(png.begin(), png.end());
}

}  // namespace fleetmap::internal
