// A sensor_msgs/Image or CompressedImage (fleetmap/rosbag/sensor_msgs.h) as the PNG bytes a
// stereo log stores (stereo_image_log.h stores images as PNG, encoding "png"): lossless, so every
// pixel value of the bag (of the decoded CompressedImage) comes back from the log. Private to the
// library.
#pragma once

#include <cstdint>
#include <string>

#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap::internal {

// The image encodings RosImageToPng reads, for messages: the ones stereo cameras publish.
inline constexpr const char* kSupportedRosImageEncodings = "mono8, mono16, rgb8, bgr8";

// Both functions refuse, before decoding or copying a pixel, an image larger than any camera
// fleetmap imports (a side over kMaxRosImageSidePx, ros_bag_import.h: Error(kInvalidArgument))
// or than its camera's `camera_info` says (when given with a width and height:
// Error(kCorrupt)), naming both sizes. So the pixels one image decodes to take at most
// kMaxRosImageSidePx^2 x 4 bytes (256 MiB; 4: the most bytes a pixel of an image the header
// allows, an 8-bit BGRA PNG, which is then refused), whatever its file declares.

// mono8 and mono16 become grey PNGs (8 and 16 bit; a big-endian mono16 is byte-swapped),
// rgb8 and bgr8 colour PNGs holding the same colours. Rows are read `step` bytes apart, so
// padding at row ends is dropped. Throws Error(kInvalidArgument) for another encoding, naming it
// and the supported ones; Error(kCorrupt) for an empty image or a step shorter than a row.
std::string RosImageToPng(const RosImage& image, const RosCameraInfo* camera_info = nullptr);

// The CompressedImage formats RosCompressedImageToPng reads, for messages.
inline constexpr const char* kSupportedRosCompressedFormats =
    "png, jpeg (jpg), and image_transport's \"ENCODING; png compressed TYPE\" and \"ENCODING; "
    "jpeg compressed TYPE\"";

struct DecodedRosImage {
  std::string png;
  std::uint32_t width_px = 0, height_px = 0;
};

// A CompressedImage decoded (OpenCV's PNG or JPEG decoder, chosen by `format`, pixels as stored:
// no EXIF rotation) and stored as a PNG of the same pixels as RosImageToPng would store the
// equivalent Image: grey 8 or 16 bit, or colour 8 bit. The size is read from the file's header
// first (image_header.h: PNG's IHDR, JPEG's SOFn) and checked as above; OpenCV's own limit
// (OPENCV_IO_MAX_IMAGE_PIXELS, 2^30 pixels) is far above any camera. Throws
// Error(kInvalidArgument) for a format not among kSupportedRosCompressedFormats (naming it) and
// for pixels of another kind (16-bit colour, alpha; refused from the header when it says so);
// Error(kCorrupt) for data that does not begin as its format's files do, whose header is
// damaged, or that OpenCV cannot decode.
DecodedRosImage RosCompressedImageToPng(const RosCompressedImage& image,
                                        const RosCameraInfo* camera_info = nullptr);

}  // namespace fleetmap::internal
