// A stereo image sequence from any of the dataset layouts the real-image front end reads, as one
// type: calibrated cameras ready for StereoRectifier, the image pairs in time order, and ground
// truth where the folder has it.
//
// Layouts (DetectStereoLayout tells them apart by their folders):
// - "euroc": the EuRoC MAV (ASL) layout of euroc_sequence.h: cam0/, cam1/ with sensor.yaml and
//   data.csv; ground truth from state_groundtruth_estimate0/data.csv when present.
// - "kitti-odometry": the KITTI odometry benchmark's sequence folder, already rectified:
//     image_l/ or image_0/  NNNNNN.png   (left, sorted by name)
//     image_r/ or image_1/  NNNNNN.png   (right, the same names)
//     calib.txt   "P0: 12 numbers" and "P1: 12 numbers" (3x4 projection matrices, row-major),
//                 or the same two lines without the "P0:"/"P1:" keys; P2, P3 and Tr are ignored
//     times.txt   optional: seconds since the sequence's start, one line per pair
//     poses.txt   optional: 12 numbers per line, the left camera's 3x4 [R|t] (row-major) in
//                 the first frame's camera coordinates, one line per pair
// - "kitti-raw": a KITTI raw recording (a drive's "sync" or "extract" folder):
//     image_00/data/*.png, image_01/data/*.png   (left, right grey cameras, the same names)
//     image_00/timestamps.txt                    ("2011-09-26 13:02:25.964389445" UTC per pair)
//     calib_cam_to_cam.txt in DIR or DIR/..      (the raw download keeps it beside the drives)
//   The images are either rectified ("synced+rectified": their size is S_rect_0x) or not
//   ("unsynced+unrectified": S_0x); see LoadStereoSequence.
//
// Conventions: camera frames as stereo_calibration.h (x right, y down, z forward, metres);
// poses are Eigen::Isometry3d with frames in their names (first_T_left maps points of the left
// camera at a pair into the left camera at the first pair).
#pragma once

#include <Eigen/Geometry>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_calibration.h"

namespace fleetmap {

enum class StereoLayout { kEuroc, kKittiOdometry, kKittiRaw };

// "euroc", "kitti-odometry", "kitti-raw".
std::string LayoutName(StereoLayout layout);

// The inverse of LayoutName. Throws Error(kInvalidArgument) listing the names for anything else.
StereoLayout ParseStereoLayout(const std::string& name);

// The dataset a layout belongs to: "euroc" or "kitti" (both KITTI layouts), as `fleetmap images
// ingest` names the platform by default.
std::string LayoutFamily(StereoLayout layout);

// Whether DIR has the folders and files that DetectStereoLayout looks for to detect `layout`.
// False for a missing DIR.
bool HasStereoLayout(const std::filesystem::path& dir, StereoLayout layout);

// Looks at DIR: cam0/ + cam1/ -> euroc; (image_l|image_0)/ + (image_r|image_1)/ + calib.txt ->
// kitti-odometry; image_00/data/ + image_01/data/ + calib_cam_to_cam.txt in DIR or DIR/.. ->
// kitti-raw (tried in that order). Throws Error(kNotFound) when DIR does not exist or is not a
// directory, Error(kInvalidArgument) saying what was looked for when nothing matches.
StereoLayout DetectStereoLayout(const std::filesystem::path& dir);

struct StereoSequence {
  std::filesystem::path dir;
  StereoLayout layout = StereoLayout::kEuroc;
  // Whom to credit where results on this data are shown (both datasets' licences ask for it).
  std::string credit;
  // Ready for StereoRectifier. Rectified KITTI images: each camera's intrinsics from its
  // projection matrix, zero distortion, left.body_T_sensor identity and right.body_T_sensor a
  // translation of +baseline along x, so rectifying them again changes nothing.
  PinholeCamera left, right;
  std::vector<StereoPairFiles> pairs;  // increasing stamps, at least one
  // Ground truth: the left camera's pose at each pair in the reference pair's left camera frame
  // (p_reference = first_T_left[i] * p_left_i); one entry per pair when the folder has ground
  // truth, empty when it has none; std::nullopt for a pair the ground truth does not cover.
  // The reference is pair 0 where it is covered (always for KITTI odometry); for EuRoC, whose
  // ground truth may start after the first image, it is the first covered pair, whose entry is
  // then the identity.
  std::vector<std::optional<Eigen::Isometry3d>> first_T_left;

  // True when at least one pair has a ground-truth pose.
  bool has_ground_truth() const;
};

// Loads the sequence in DIR; `layout` std::nullopt detects it (DetectStereoLayout).
//
// EuRoC: LoadEurocSequence; ground truth (euroc_sequence.h) interpolated at each image stamp
// (InterpolateBodyPose: nullopt outside the csv's span or across a gap over 50 ms), composed
// with cam0's T_BS into world_T_left, then re-based on the first covered pair.
//
// KITTI odometry: without times.txt the stamps are i * 100 ms from 0 (KITTI's 10 Hz), with it
// round(t * 1e9) ns; either way they count from the sequence's start (1970-01-01 as UTC: the
// benchmark does not say when it was recorded). The image size is read from the first left
// image. poses.txt is re-based on its first line (identity in KITTI's files, but a cut-out
// excerpt need not start at one); each rotation must be orthonormal within 1e-3.
//
// KITTI raw: stamps from image_00/timestamps.txt (UTC, to the ns). Rectified images get
// cameras from P_rect_00 and P_rect_01 (baseline -P_rect_01[0][3] / P_rect_01[0][0]) with zero
// distortion; unrectified ones from K_0x, D_0x (k1 k2 p1 p2 k3) and the extrinsics R_0x, T_0x
// (x_cam = R_0x x_ref + T_0x, the reference being unrectified camera 0), so body_T_sensor is
// (R_0x, T_0x)^-1 and StereoRectifier does the rectification. No ground truth: the GPS/IMU
// (oxts) poses of the raw recordings are not read.
//
// Throws Error(kNotFound) for a missing directory, image folder, calibration file or image,
// naming it (an image present on one side only is named with the side it is missing from);
// Error(kInvalidArgument) for malformed content, naming the file, the line and the field:
// "DIR/calib.txt line 2 (P1): expected 12 numbers, found 11", "DIR/poses.txt line 7: 'x' is
// not a number", "DIR/times.txt line 3: 0.2 does not come after line 2's 0.3 (times must
// increase)", "DIR/poses.txt has 50 lines but there are 51 image pairs"; Error(kCorrupt) for a
// first image that does not decode; what LoadEurocSequence and ReadEurocGroundTruth throw.
StereoSequence LoadStereoSequence(const std::filesystem::path& dir,
                                  std::optional<StereoLayout> layout = std::nullopt);

// The vehicle's speed at `pair` from the ground truth: the distance to the next pair's pose (the
// previous one's for the last pair) over their stamps' difference, in m/s; std::nullopt without
// ground truth at either pair, or for a pair out of range.
std::optional<double> GroundTruthSpeedMps(const StereoSequence& sequence, int pair);

}  // namespace fleetmap
