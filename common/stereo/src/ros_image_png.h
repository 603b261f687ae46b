// A sensor_msgs/Image (fleetmap/rosbag/sensor_msgs.h) as the PNG bytes a stereo log stores
// (stereo_image_log.h stores images as PNG, encoding "png"): lossless, so every pixel value of
// the bag comes back from the log. Private to the library.
#pragma once

#include <string>

#include "fleetmap/rosbag/sensor_msgs.h"

namespace fleetmap::internal {

// The image encodings RosImageToPng reads, for messages: the ones stereo cameras publish.
inline constexpr const char* kSupportedRosImageEncodings = "mono8, mono16, rgb8, bgr8";

// mono8 and mono16 become grey PNGs (8 and 16 bit; a big-endian mono16 is byte-swapped),
// rgb8 and bgr8 colour PNGs holding the same colours. Rows are read `step` bytes apart, so
// padding at row ends is dropped. Throws Error(kInvalidArgument) for another encoding, naming it
// and the supported ones; Error(kCorrupt) for an empty image or a step shorter than a row.
std::string RosImageToPng(const RosImage& image);

}  // namespace fleetmap::internal
