// A stereo sequence in the EuRoC MAV layout (ASL format), as ../shared/data/euroc-v1_01-micro
// holds it:
//   DIR/cam0/sensor.yaml, DIR/cam0/data.csv, DIR/cam0/data/<stamp>.png   (left)
//   DIR/cam1/sensor.yaml, DIR/cam1/data.csv, DIR/cam1/data/<stamp>.png   (right)
// data.csv: a header line starting with '#', then "timestamp_ns,filename" per image.
//
// Loading checks everything a long run would otherwise trip over halfway: both calibrations,
// every listed file's existence, and that the two cameras list the same timestamps row by row.
// Images are decoded only when read (ReadMonoImage), so loading is fast.
//
// Ground truth, where a EuRoC folder has it: DIR/state_groundtruth_estimate0/data.csv, a '#'
// header, then per row "timestamp_ns, p_RS_R_x, p_RS_R_y, p_RS_R_z [m], q_RS_w, q_RS_x, q_RS_y,
// q_RS_z, ..." (velocity and biases follow and are ignored): the body (IMU) frame's pose in the
// world frame R at 200 Hz, quaternion Hamilton (w, x, y, z). stereo_sequence.h turns it into
// camera poses at the image stamps.
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap {

struct StereoPairFiles {
  std::int64_t stamp_ns = 0;  // UTC ns, the same in both cameras
  std::filesystem::path left_image, right_image;
};

struct EurocSequence {
  std::filesystem::path dir;
  PinholeCamera left, right;           // cam0, cam1
  std::vector<StereoPairFiles> pairs;  // in increasing stamp order
};

// Rows pair up by position and must carry the same stamp. A camera's rows past the other's last
// row are dropped when their images are absent too (a cut-down copy of a sequence: the micro
// excerpt's cam1/data.csv lists 4 images past the 95 copied); an extra row whose image exists
// is a frame without a partner and refused.
//
// Throws Error(kNotFound) naming the path for a missing directory, yaml, csv or image (with
// the csv line that lists it); Error(kInvalidArgument) naming DIR, the csv and the line for a
// malformed csv row, stamps that do not increase, a different number of rows in the two
// cameras, or a row whose two stamps differ ("DIR: timestamps differ between the cameras:
// cam0/data.csv line 12: 1403715273812142976 but cam1/data.csv line 12: ..."), or no pair
// at all; calibration errors as LoadEurocCamera.
EurocSequence LoadEurocSequence(const std::filesystem::path& dir);

// DIR/state_groundtruth_estimate0/data.csv, relative to the sequence folder.
inline constexpr const char* kEurocGroundTruthCsv = "state_groundtruth_estimate0/data.csv";

struct EurocBodyPose {
  std::int64_t stamp_ns = 0;
  Eigen::Isometry3d world_T_body = Eigen::Isometry3d::Identity();
};

// Reads a EuRoC ground-truth csv (format above); rows in increasing stamp order, quaternions
// normalised. Throws Error(kNotFound) for a missing file; Error(kInvalidArgument) naming the file
// and line for a row with fewer than 8 fields, a field that is not a number, stamps that do not
// increase, or a quaternion whose norm is not 1 within 1e-3; and for a file without rows.
std::vector<EurocBodyPose> ReadEurocGroundTruth(const std::filesystem::path& csv);

// The ground-truth gap beyond which InterpolateBodyPose gives no pose: ten rows at 200 Hz.
inline constexpr std::int64_t kEurocGroundTruthMaxGapNs = 50'000'000;

// world_T_body at `stamp_ns`: position linear and rotation slerped between the two rows around
// it (a row's own pose at its stamp). std::nullopt outside the rows' span, or when the two rows
// are more than kEurocGroundTruthMaxGapNs apart (a gap in the recording: interpolating across it
// would invent motion). REQUIRES: `poses` increasing in stamp, as ReadEurocGroundTruth gives.
std::optional<Eigen::Isometry3d> InterpolateBodyPose(const std::vector<EurocBodyPose>& poses,
                                                     std::int64_t stamp_ns);

// Reads an image file as single-channel 8-bit (colour is converted to grey). Throws
// Error(kNotFound) for a missing file, Error(kCorrupt) naming the file when it does not decode,
// and Error(kInvalidArgument) when its size is not expected_width_px x expected_height_px.
cv::Mat ReadMonoImage(const std::filesystem::path& file, int expected_width_px,
                      int expected_height_px);

// An image file's bytes as stored (for logging them undecoded). Throws Error(kNotFound) for a
// missing or unopenable file, Error(kBackend) on a read error.
std::string ReadImageBytes(const std::filesystem::path& file);

// The same as ReadMonoImage for image bytes held in memory (a record's payload); `what` names them
// in errors.
cv::Mat DecodeMonoImage(const std::string& bytes, const std::string& what, int expected_width_px,
                        int expected_height_px);

}  // namespace fleetmap
