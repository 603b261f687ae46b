// One stereo sequence type over the EuRoC and KITTI layouts (stereo_sequence.h).
#include "fleetmap/stereo/stereo_sequence.h"

#include <algorithm>
#include <cmath>
#include <system_error>

#include "dataset_files.h"
#include "fleetmap/core/error.h"
#include "kitti_sequence.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using dataset_files::IsDirectory;
using dataset_files::IsFile;

constexpr const char* kEurocCredit = "EuRoC MAV dataset, ASL, ETH Zurich";

constexpr StereoLayout kLayouts[] = {StereoLayout::kEuroc, StereoLayout::kKittiOdometry,
                                     StereoLayout::kKittiRaw};

// Ground truth at each pair's stamp (euroc_sequence.h's csv), re-based on the first covered pair.
std::vector<std::optional<Eigen::Isometry3d>> EurocGroundTruth(const fs::path& csv,
                                                               const StereoSequence& sequence) {
  const std::vector<EurocBodyPose> poses = ReadEurocGroundTruth(csv);
  std::vector<std::optional<Eigen::Isometry3d>> world_T_left;
  world_T_left.reserve(sequence.pairs.size());
  for (const StereoPairFiles& pair : sequence.pairs) {
    const std::optional<Eigen::Isometry3d> world_T_body = InterpolateBodyPose(poses, pair.stamp_ns);
    world_T_left.push_back(world_T_body ? std::optional(*world_T_body * sequence.left.body_T_sensor)
                                        : std::nullopt);
  }
  const auto reference = std::find_if(world_T_left.begin(), world_T_left.end(),
                                      [](const auto& pose) { return pose.has_value(); });
  if (reference == world_T_left.end()) return world_T_left;  // all nullopt: covers no image
  const Eigen::Isometry3d first_T_world = (*reference)->inverse();
  for (std::optional<Eigen::Isometry3d>& pose : world_T_left) {
    if (pose) pose = first_T_world * *pose;
  }
  return world_T_left;
}

StereoSequence LoadEuroc(const fs::path& dir) {
  std::error_code ignored;  // an unreadable folder reads as no ground truth
  EurocSequence euroc = LoadEurocSequence(dir);
  StereoSequence sequence;
  sequence.dir = dir;
  sequence.layout = StereoLayout::kEuroc;
  sequence.credit = kEurocCredit;
  sequence.left = std::move(euroc.left);
  sequence.right = std::move(euroc.right);
  sequence.pairs = std::move(euroc.pairs);
  if (const fs::path csv = dir / kEurocGroundTruthCsv; fs::exists(csv, ignored)) {
    sequence.first_T_left = EurocGroundTruth(csv, sequence);
  }
  return sequence;
}

}  // namespace

bool StereoSequence::has_ground_truth() const {
  return std::any_of(first_T_left.begin(), first_T_left.end(),
                     [](const auto& pose) { return pose.has_value(); });
}

std::string LayoutName(StereoLayout layout) {
  switch (layout) {
    case StereoLayout::kEuroc:
      return "euroc";
    case StereoLayout::kKittiOdometry:
      return "kitti-odometry";
    case StereoLayout::kKittiRaw:
      return "kitti-raw";
  }
  return "unknown";
}

std::string LayoutFamily(StereoLayout layout) {
  return layout == StereoLayout::kEuroc ? "euroc" : "kitti";
}

StereoLayout ParseStereoLayout(const std::string& name) {
  std::string names;
  for (const StereoLayout layout : kLayouts) {
    if (name == LayoutName(layout)) return layout;
    names += (names.empty() ? "" : ", ") + LayoutName(layout);
  }
  throw Error(ErrorCode::kInvalidArgument,
              "unknown stereo dataset layout '" + name + "' (known: " + names + ")");
}

bool HasStereoLayout(const fs::path& dir, StereoLayout layout) {
  switch (layout) {
    case StereoLayout::kEuroc:
      return IsDirectory(dir / "cam0") && IsDirectory(dir / "cam1");
    case StereoLayout::kKittiOdometry:
      return (IsDirectory(dir / "image_l") || IsDirectory(dir / "image_0")) &&
             (IsDirectory(dir / "image_r") || IsDirectory(dir / "image_1")) &&
             IsFile(dir / "calib.txt");
    case StereoLayout::kKittiRaw:
      return IsDirectory(dir / "image_00" / "data") && IsDirectory(dir / "image_01" / "data") &&
             FindKittiRawCalibration(dir).has_value();
  }
  return false;
}

StereoLayout DetectStereoLayout(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                "stereo sequence " + dir.string() +
                    (fs::exists(dir, ec) ? " is not a directory" : " does not exist"));
  }
  for (const StereoLayout layout : kLayouts) {
    if (HasStereoLayout(dir, layout)) return layout;
  }
  throw Error(ErrorCode::kInvalidArgument,
              dir.string() +
                  " is not a stereo sequence folder of a known layout: looked for cam0/ and cam1/ "
                  "(euroc), (image_l/ or image_0/) and (image_r/ or image_1/) with calib.txt "
                  "(kitti-odometry), image_00/data/ and image_01/data/ with calib_cam_to_cam.txt "
                  "here or in the parent folder (kitti-raw)");
}

StereoSequence LoadStereoSequence(const fs::path& dir, std::optional<StereoLayout> layout) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                "stereo sequence " + dir.string() +
                    (fs::exists(dir, ec) ? " is not a directory" : " does not exist"));
  }
  // Detected only when not given: a named layout must not depend on what else the folder holds.
  switch (layout ? *layout : DetectStereoLayout(dir)) {
    case StereoLayout::kEuroc:
      return LoadEuroc(dir);
    case StereoLayout::kKittiOdometry:
      return LoadKittiOdometrySequence(dir);
    case StereoLayout::kKittiRaw:
      return LoadKittiRawSequence(dir);
  }
  throw Error(ErrorCode::kInvalidArgument, "unknown stereo dataset layout");
}

std::optional<double> GroundTruthSpeedMps(const StereoSequence& sequence, int pair) {
  const int count = static_cast<int>(sequence.pairs.size());
  if (pair < 0 || pair >= count || sequence.first_T_left.size() != sequence.pairs.size()) {
    return std::nullopt;
  }
  const int other = pair + 1 < count ? pair + 1 : pair - 1;
  if (other < 0) return std::nullopt;
  const auto& a = sequence.first_T_left[static_cast<std::size_t>(pair)];
  const auto& b = sequence.first_T_left[static_cast<std::size_t>(other)];
  if (!a || !b) return std::nullopt;
  const double dt_s = std::abs(static_cast<double>(sequence.pairs[other].stamp_ns -
                                                   sequence.pairs[pair].stamp_ns)) *
                      1e-9;
  if (!(dt_s > 0)) return std::nullopt;
  return (b->translation() - a->translation()).norm() / dt_s;
}

}  // namespace fleetmap
