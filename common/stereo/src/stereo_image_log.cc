// A stereo sequence (EuRoC or KITTI) into one record file of the sensor-data repository
// (stereo_image_log.h, seed 000 §5.1).
#include "fleetmap/stereo/stereo_image_log.h"

#include <string_view>
#include <system_error>

#include "fleetmap/core/error.h"
#include "fleetmap/records/record_layout.h"
#include "fleetmap/sensors.pb.h"
#include "written_paths.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using internal::StagedRecordFile;
using internal::WrittenPaths;

constexpr std::string_view kPngSignature("\x89PNG\r\n\x1a\n", 8);

// Reads, decodes and checks one image; returns its bytes as stored.
std::string CheckedImageBytes(const fs::path& file, const PinholeCamera& camera) {
  std::string bytes = ReadImageBytes(file);
  DecodeMonoImage(bytes, file.string(), camera.width_px, camera.height_px);
  // Records say "png"; a JPEG or BMP that merely carries the name would be mislabelled.
  if (!std::string_view(bytes).starts_with(kPngSignature)) {
    throw Error(
        ErrorCode::kInvalidArgument,
        "image " + file.string() + " decodes but is not a PNG (EuRoC and KITTI folders hold PNG)");
  }
  return bytes;
}

void CopyCalibration(const fs::path& from, const fs::path& to, WrittenPaths& written) {
  std::error_code ec;
  // A copy left beside no log by an ingest that was killed is overwritten.
  fs::copy_file(from, to, fs::copy_options::overwrite_existing, ec);
  if (ec) {
    throw Error(ErrorCode::kBackend,
                "cannot copy " + from.string() + " to " + to.string() + ": " + ec.message());
  }
  written.AddFile(to);
}

// The calibration of camera `index` (0 left, 1 right) beside the log: EuRoC's own sensor.yaml as
// it is (comments and all), anything else written in that shape from the loaded camera.
void StoreCalibration(const StereoSequence& sequence, int index, const fs::path& to,
                      WrittenPaths& written) {
  if (sequence.layout == StereoLayout::kEuroc) {
    CopyCalibration(sequence.dir / ("cam" + std::to_string(index)) / "sensor.yaml", to, written);
    return;
  }
  written.AddFile(to);
  WriteEurocCamera(index == 0 ? sequence.left : sequence.right, to);
}

}  // namespace

fs::path StereoCalibrationPath(const fs::path& record_file, int camera_index) {
  fs::path file = record_file;
  return file.replace_extension(".cam" + std::to_string(camera_index) + ".yaml");
}

StereoImageIngestResult IngestStereoImages(
    const StereoSequence& sequence, SensorIndex& index, const fs::path& root,
    const std::string& platform, const std::string& sensor,
    const std::function<void(std::int64_t done, std::int64_t total)>& progress) {
  CheckLayoutName(platform, "platform");
  CheckLayoutName(sensor, "sensor");
  if (sequence.pairs.empty()) {
    throw Error(ErrorCode::kInvalidArgument, LayoutName(sequence.layout) + " sequence " +
                                                 sequence.dir.string() +
                                                 " has no stereo pairs to ingest");
  }
  const PinholeCamera& left = sequence.left;
  const PinholeCamera& right = sequence.right;
  if (left.width_px != right.width_px || left.height_px != right.height_px) {
    throw Error(ErrorCode::kInvalidArgument,
                LayoutName(sequence.layout) + " sequence " + sequence.dir.string() +
                    ": the left camera is " + std::to_string(left.width_px) + "x" +
                    std::to_string(left.height_px) + " px but the right " +
                    std::to_string(right.width_px) + "x" + std::to_string(right.height_px) +
                    "; a stereo pair record holds one image size");
  }

  StereoImageIngestResult result;
  // Refused before any image is read when the log is there already; StagedRecordFile checks
  // again at its first record and when it publishes.
  if (const fs::path existing =
          fs::absolute(root) / RecordFilePath(platform, sensor, sequence.pairs.front().stamp_ns);
      fs::exists(existing)) {
    throw Error(ErrorCode::kConflict,
                "record file " + existing.lexically_normal().string() +
                    " already exists: this sequence (or another whose first pair falls in the "
                    "same second) was ingested before");
  }
  WrittenPaths written;
  StagedRecordFile log(root, platform, sensor, written);
  {
    const std::string type = v1::StereoImagePair::descriptor()->full_name();
    const auto total = static_cast<std::int64_t>(sequence.pairs.size());
    v1::StereoImagePair record;
    record.set_left_camera(sensor + "/cam0");
    record.set_right_camera(sensor + "/cam1");
    record.set_encoding("png");
    record.set_width_px(static_cast<std::uint32_t>(left.width_px));
    record.set_height_px(static_cast<std::uint32_t>(left.height_px));
    std::string payload;
    for (std::int64_t i = 0; i < total; ++i) {
      const StereoPairFiles& pair = sequence.pairs[static_cast<std::size_t>(i)];
      record.set_stamp_ns(pair.stamp_ns);
      record.set_left_image(CheckedImageBytes(pair.left_image, left));
      record.set_right_image(CheckedImageBytes(pair.right_image, right));
      record.SerializeToString(&payload);
      log.Append(pair.stamp_ns, type, payload);
      if (progress) progress(i + 1, total);
    }
  }
  result.record_file = log.final_path();
  result.left_calibration = StereoCalibrationPath(result.record_file, 0);
  result.right_calibration = StereoCalibrationPath(result.record_file, 1);
  StoreCalibration(sequence, 0, result.left_calibration, written);
  StoreCalibration(sequence, 1, result.right_calibration, written);
  log.Publish();

  result.pairs = static_cast<std::int64_t>(sequence.pairs.size());
  result.bytes = fs::file_size(result.record_file);
  result.index = IngestRecordFile(index, root, result.record_file, platform, sensor);
  written.Keep();
  return result;
}

}  // namespace fleetmap
