// Stereo images as raw sensor data (seed 000 §5.1): `fleetmap images ingest DIR` copies a stereo
// sequence (stereo_sequence.h: EuRoC, KITTI odometry or KITTI raw) into one record file of
// fleetmap.v1.StereoImagePair records in the repository's platform/sensor/date layout
// (record_layout.h), and indexes it (sensor_ingest.h) so the pairs can be found by time like any
// other datum.
//
// The images are stored as the dataset holds them (PNG bytes, encoding "png"), each decoded
// once on the way in so an unreadable or wrongly sized image is refused before the log appears.
// Cameras are named "SENSOR/cam0" (left) and "SENSOR/cam1" (right) in the records, after the
// EuRoC folders, as sensors.proto's "bumblebee/left". The two cameras' calibrations are kept
// beside the record file, named after it (StereoCalibrationPath: FILE.cam0.yaml, FILE.cam1.yaml),
// as EuRoC sensor.yaml files that LoadEurocCamera reads: a EuRoC folder's own files copied byte
// for byte, and for KITTI the cameras LoadStereoSequence made of calib.txt or
// calib_cam_to_cam.txt written out (WriteEurocCamera). So each log keeps the calibration it was
// recorded with (a rig recalibrated between sessions gets new files, not overwritten ones) and
// can be rectified without the original folder. Reindexing (ReindexRoot) reads only *.rec files,
// so the calibration files are not data. Ground truth is not stored.
//
// Writing is all or nothing for the files: records go to a hidden temporary file beside the
// final one (".NAME.rec.partial-PID", never picked up as a log), which is fsynced and renamed
// into place only when every image has checked; on any error, what was written (files and the
// directories created for them) is removed.
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <string>

#include "fleetmap/records/sensor_ingest.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/store/sensor_index.h"

namespace fleetmap {

// The calibration copy of camera `camera_index` (0 left, 1 right) beside `record_file`:
// ".../NAME.rec" -> ".../NAME.cam0.yaml".
std::filesystem::path StereoCalibrationPath(const std::filesystem::path& record_file,
                                            int camera_index);

struct StereoImageIngestResult {
  std::filesystem::path record_file;                          // the written log, absolute
  std::filesystem::path left_calibration, right_calibration;  // sensor.yaml of each camera
  std::int64_t pairs = 0;
  std::uint64_t bytes = 0;  // of the record file
  IngestResult index;       // what indexing the file added
};

// Writes every pair of `sequence` to a new record file under `root` (created if missing) at
// RecordFilePath(platform, sensor, first stamp) and indexes it in `index` as data of `sensor` on
// `platform` (names as CheckLayoutName allows), one datum per pair. Every image is read once,
// decoded and checked (DecodeMonoImage's errors, naming the file) before the log is renamed into
// place; on any error nothing is left under the root and no data row is added (a platform or
// sensor row that indexing added before a mount conflict may stay). A record file of the same
// name already present is refused with Error(kConflict) (ingesting twice would index the pairs
// twice under another file). Error(kInvalidArgument) for bad names, an empty sequence, cameras
// of different sizes, or an image that decodes but is not a PNG. `progress` gets (pairs done,
// pairs in all) while checking and writing.
StereoImageIngestResult IngestStereoImages(
    const StereoSequence& sequence, SensorIndex& index, const std::filesystem::path& root,
    const std::string& platform, const std::string& sensor,
    const std::function<void(std::int64_t done, std::int64_t total)>& progress = {});

}  // namespace fleetmap
