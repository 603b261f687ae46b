// The two KITTI readers behind LoadStereoSequence (stereo_sequence.h describes the layouts and
// the errors); private to fleetmap_runners.
#pragma once

#include <filesystem>
#include <optional>

#include "fleetmap/stereo/stereo_sequence.h"

namespace fleetmap {

// Whom the KITTI licence (CC BY-NC-SA 3.0) asks to credit.
inline constexpr const char* kKittiCredit =
    "KITTI, Geiger, Lenz, Urtasun (KIT, TTI-C), CC BY-NC-SA 3.0";

// REQUIRES: `dir` is a directory. Throw as LoadStereoSequence.
StereoSequence LoadKittiOdometrySequence(const std::filesystem::path& dir);
StereoSequence LoadKittiRawSequence(const std::filesystem::path& dir);

// DIR/calib_cam_to_cam.txt, else DIR/../calib_cam_to_cam.txt (where the raw download puts it,
// beside the date's drive folders); std::nullopt when neither is a file.
std::optional<std::filesystem::path> FindKittiRawCalibration(const std::filesystem::path& dir);

}  // namespace fleetmap
