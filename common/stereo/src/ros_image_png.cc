// sensor_msgs/Image and CompressedImage to PNG (ros_image_png.h).
#include "ros_image_png.h"

#include <cctype>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string_view>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/images/image_codec.h"
#include "fleetmap/stereo/ros_bag_import.h"
#include "image_header.h"

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

// The codec a CompressedImage's format names: "png", "jpeg", "jpg", or image_transport's
// "ENCODING; png compressed TYPE" / "ENCODING; jpeg compressed TYPE" (its compressed plugin;
// "ENCODING; compressedDepth png" is the compressedDepth plugin's own layout and not read).
// Empty for any other format.
std::string CodecOf(const std::string& format) {
  std::string f;
  for (const char c : format) f += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  const auto trimmed = [](std::string_view s) {
    while (!s.empty() && s.front() == ' ') s.remove_prefix(1);
    while (!s.empty() && s.back() == ' ') s.remove_suffix(1);
    return s;
  };
  std::string_view codec = trimmed(f);
  if (const std::size_t semicolon = codec.find(';'); semicolon != std::string_view::npos) {
    codec = trimmed(codec.substr(semicolon + 1));  // "png compressed mono8"
    const std::size_t space = codec.find(' ');
    if (space == std::string_view::npos || !codec.substr(space + 1).starts_with("compressed")) {
      return {};
    }
    codec = codec.substr(0, space);
  }
  if (codec == "png") return "png";
  if (codec == "jpeg" || codec == "jpg") return "jpeg";
  return {};
}

// PNG and JPEG (JFIF, Exif, raw) files begin so.
bool BeginsAs(std::string_view data, const std::string& codec) {
  return codec == "png" ? data.starts_with("\x89PNG\r\n\x1a\n") : data.starts_with("\xff\xd8\xff");
}

// Refuses an image of `width` x `height` pixels larger than any camera fleetmap imports, or
// than its camera's CameraInfo says (`info`, when given with a size). `what` names the image.
void CheckImageSize(const std::string& what, std::uint32_t width, std::uint32_t height,
                    const RosCameraInfo* info) {
  const std::string size = std::to_string(width) + "x" + std::to_string(height);
  if (width > kMaxRosImageSidePx || height > kMaxRosImageSidePx) {
    throw Error(ErrorCode::kInvalidArgument,
                what + " declares " + size + " pixels, more than the largest camera fleetmap " +
                    "imports (" + std::to_string(kMaxRosImageSidePx) + "x" +
                    std::to_string(kMaxRosImageSidePx) + "); refused before decoding");
  }
  if (info != nullptr && info->width > 0 && info->height > 0 &&
      (width > info->width || height > info->height)) {
    throw Error(ErrorCode::kCorrupt,
                what + " declares " + size + " pixels, more than its camera's CameraInfo (" +
                    std::to_string(info->width) + "x" + std::to_string(info->height) +
                    "); refused before decoding");
  }
}

}  // namespace

DecodedRosImage RosCompressedImageToPng(const RosCompressedImage& image,
                                        const RosCameraInfo* camera_info) {
  const std::string codec = CodecOf(image.format);
  if (codec.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                "sensor_msgs/CompressedImage format '" + image.format +
                    "' is not supported (supported: " + kSupportedRosCompressedFormats + ")");
  }
  // Only the decoder the format names sees the bytes.
  if (!BeginsAs(image.data, codec) || image.data.size() > std::size_t{INT32_MAX}) {
    throw Error(ErrorCode::kCorrupt, "sensor_msgs/CompressedImage of format '" + image.format +
                                         "': its " + std::to_string(image.data.size()) +
                                         " bytes do not begin as a " + codec + " file does");
  }
  // The size first, from the file's header: the decoders allocate what it declares.
  const std::string what = "sensor_msgs/CompressedImage of format '" + image.format + "'";
  EncodedImageHeader header;
  try {
    header = codec == "png" ? ReadPngHeader(image.data) : ReadJpegHeader(image.data);
  } catch (const Error& e) {
    throw Error(e.code(), what + ": its " + std::to_string(image.data.size()) +
                              " bytes do not decode as " + codec + " (" + e.message() + ")");
  }
  CheckImageSize(what + ": the " + codec + " file", header.width_px, header.height_px, camera_info);
  if (!header.unsupported.empty()) {
    throw Error(ErrorCode::kInvalidArgument,
                what + ": the " + codec + " file declares " + header.unsupported +
                    ", which is not supported (supported: the pixels of " +
                    kSupportedRosImageEncodings + "); refused before decoding");
  }
  cv::Mat pixels;
  try {
    pixels = DecodeImage(image.data, ImagePixels::kAsStored, what);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kCorrupt) throw;
    throw Error(ErrorCode::kCorrupt, what + ": its " + std::to_string(image.data.size()) +
                                         " bytes do not decode as " + codec + " (" + e.message() +
                                         ")");
  }
  const int type = pixels.type();
  if (type != CV_8UC1 && type != CV_16UC1 && type != CV_8UC3) {
    throw Error(ErrorCode::kInvalidArgument,
                "sensor_msgs/CompressedImage of format '" + image.format + "' decodes to " +
                    std::to_string(pixels.channels()) + " channels of " +
                    std::to_string(8 * pixels.elemSize1()) +
                    " bits, which is not supported (supported: the pixels of " +
                    kSupportedRosImageEncodings + ")");
  }
  return DecodedRosImage{EncodePng(pixels), static_cast<std::uint32_t>(pixels.cols),
                         static_cast<std::uint32_t>(pixels.rows)};
}

std::string RosImageToPng(const RosImage& image, const RosCameraInfo* camera_info) {
  const PixelFormat format = FormatOf(image.encoding);
  if (image.width == 0 || image.height == 0) {
    throw Error(ErrorCode::kCorrupt, "sensor_msgs/Image of " + std::to_string(image.width) + "x" +
                                         std::to_string(image.height) + " pixels: empty");
  }
  CheckImageSize("sensor_msgs/Image " + image.encoding, image.width, image.height, camera_info);
  const std::uint64_t row_bytes = std::uint64_t{image.width} * format.bytes_per_pixel;
  if (image.step < row_bytes) {
    throw Error(ErrorCode::kCorrupt, "sensor_msgs/Image " + image.encoding + " of width " +
                                         std::to_string(image.width) + " with step " +
                                         std::to_string(image.step) + ", shorter than a row (" +
                                         std::to_string(row_bytes) + " bytes)");
  }
  // Rows copied out packed: a step need not be a multiple of the pixel size (a mono16 row may
  // be padded by an odd byte count), which OpenCV cannot view. DecodeRosImage checked that
  // data holds step * height bytes, so the copy is no larger than the message.
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
    cv::cvtColor(pixels, pixels, cv::COLOR_RGB2BGR);  // EncodePng takes BGR
  }
  return EncodePng(pixels);
}

}  // namespace fleetmap::internal
