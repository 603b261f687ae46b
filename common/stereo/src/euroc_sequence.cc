// Reading a EuRoC (ASL) stereo folder and its images (euroc_sequence.h).
#include "fleetmap/stereo/euroc_sequence.h"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <string_view>
#include <system_error>

#include "dataset_files.h"
#include "fleetmap/core/error.h"
#include "fleetmap/images/image_codec.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;

// One image row of a camera's data.csv.
struct CsvRow {
  int line = 0;  // 1-based, counting the header and blank lines, as an editor shows it
  std::int64_t stamp_ns = 0;
  fs::path image;  // DIR/camN/data/<filename>
};

// One camera folder: "cam0" or "cam1" under the sequence directory.
struct CameraFolder {
  std::string name;  // "cam0"
  fs::path dir;      // DIR/cam0
  std::string csv_name() const { return name + "/data.csv"; }
};

using dataset_files::Exists;
using dataset_files::RequireDirectory;
using dataset_files::RequireFile;
using dataset_files::Trim;

// Parses DIR/camN/data.csv: '#' lines are comments (the header), blank lines are skipped, every
// other line is "timestamp_ns,filename" with stamps strictly increasing.
std::vector<CsvRow> ReadCameraCsv(const fs::path& sequence_dir, const CameraFolder& camera) {
  const fs::path csv = camera.dir / "data.csv";
  RequireFile(csv, "image list");
  std::ifstream in(csv);
  if (!in) throw Error(ErrorCode::kNotFound, "cannot open image list " + csv.string());
  const auto fail = [&](int line, const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, sequence_dir.string() + ": " + camera.csv_name() +
                                                 " line " + std::to_string(line) + ": " + what);
  };
  std::vector<CsvRow> rows;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    const std::string_view row = Trim(text);
    if (row.empty() || row.front() == '#') continue;
    const auto comma = row.find(',');
    if (comma == std::string_view::npos) {
      fail(line, "'" + std::string(row) + "' is not \"timestamp_ns,filename\" (no comma)");
    }
    const std::string_view stamp_text = Trim(row.substr(0, comma));
    const std::string_view name = Trim(row.substr(comma + 1));
    CsvRow parsed;
    parsed.line = line;
    const auto [end, error] =
        std::from_chars(stamp_text.data(), stamp_text.data() + stamp_text.size(), parsed.stamp_ns);
    if (stamp_text.empty() || error != std::errc() ||
        end != stamp_text.data() + stamp_text.size()) {
      fail(line,
           "timestamp '" + std::string(stamp_text) + "' is not an integer number of nanoseconds");
    }
    if (name.empty()) fail(line, "no image file name after the timestamp");
    if (name.find_first_of(",/\\") != std::string_view::npos || name == "." || name == "..") {
      fail(line, "'" + std::string(name) + "' is not the name of a file in " + camera.name +
                     "/data/ (expected \"timestamp_ns,filename\")");
    }
    if (!rows.empty() && parsed.stamp_ns <= rows.back().stamp_ns) {
      fail(line, "timestamp " + std::to_string(parsed.stamp_ns) + " does not come after line " +
                     std::to_string(rows.back().line) + "'s " +
                     std::to_string(rows.back().stamp_ns) + " (stamps must increase)");
    }
    parsed.image = camera.dir / "data" / std::string(name);
    rows.push_back(std::move(parsed));
  }
  if (in.bad()) throw Error(ErrorCode::kBackend, "read error in " + csv.string());
  return rows;
}

void RequireListedImage(const CameraFolder& camera, const CsvRow& row) {
  if (!Exists(row.image)) {
    throw Error(ErrorCode::kNotFound, "image " + row.image.string() + " (listed in " +
                                          camera.csv_name() + " line " + std::to_string(row.line) +
                                          ") does not exist");
  }
}

}  // namespace

EurocSequence LoadEurocSequence(const fs::path& dir) {
  RequireDirectory(dir, "EuRoC sequence");
  const CameraFolder left{"cam0", dir / "cam0"};
  const CameraFolder right{"cam1", dir / "cam1"};
  for (const CameraFolder* camera : {&left, &right}) {
    RequireDirectory(camera->dir, "camera folder");
    RequireFile(camera->dir / "sensor.yaml", "camera calibration");
  }

  EurocSequence sequence;
  sequence.dir = dir;
  sequence.left = LoadEurocCamera(left.dir / "sensor.yaml");
  sequence.right = LoadEurocCamera(right.dir / "sensor.yaml");
  const std::vector<CsvRow> left_rows = ReadCameraCsv(dir, left);
  const std::vector<CsvRow> right_rows = ReadCameraCsv(dir, right);

  // Rows pair up by position and must carry the same stamp: the two cameras of a EuRoC rig are
  // triggered together, so a difference means a dropped frame or a mixed-up folder, and pairing
  // by nearest stamp would silently triangulate images taken at different times.
  const std::size_t common = std::min(left_rows.size(), right_rows.size());
  for (std::size_t i = 0; i < common; ++i) {
    const CsvRow& l = left_rows[i];
    const CsvRow& r = right_rows[i];
    if (l.stamp_ns != r.stamp_ns) {
      throw Error(ErrorCode::kInvalidArgument,
                  dir.string() + ": timestamps differ between the cameras: " + left.csv_name() +
                      " line " + std::to_string(l.line) + ": " + std::to_string(l.stamp_ns) +
                      " but " + right.csv_name() + " line " + std::to_string(r.line) + ": " +
                      std::to_string(r.stamp_ns));
    }
  }
  // Rows past the other camera's last one: tolerated only when their images are absent too, as
  // in a cut-down copy of a sequence (euroc-v1_01-micro's cam1/data.csv still lists 4 images
  // past the 95 copied). Such rows describe nothing that could be read, so they are dropped;
  // an extra row with its image present is a frame without a partner and refused.
  const bool left_longer = left_rows.size() > right_rows.size();
  const std::vector<CsvRow>& longer = left_longer ? left_rows : right_rows;
  for (std::size_t i = common; i < longer.size(); ++i) {
    if (Exists(longer[i].image)) {
      const CameraFolder& l = left_longer ? left : right;
      const CameraFolder& s = left_longer ? right : left;
      const std::vector<CsvRow>& shorter = left_longer ? right_rows : left_rows;
      throw Error(ErrorCode::kInvalidArgument,
                  dir.string() + ": the cameras list different numbers of images: " + l.csv_name() +
                      " has " + std::to_string(longer.size()) + " rows, " + s.csv_name() + " " +
                      std::to_string(shorter.size()) + "; " + l.csv_name() + " line " +
                      std::to_string(longer[i].line) + " (" + std::to_string(longer[i].stamp_ns) +
                      ") has no partner in " + s.csv_name());
    }
  }

  if (common == 0) {
    throw Error(ErrorCode::kInvalidArgument,
                dir.string() + ": no stereo pairs: " +
                    (left_rows.empty() ? left.csv_name() : right.csv_name()) + " lists no images");
  }
  sequence.pairs.reserve(common);
  for (std::size_t i = 0; i < common; ++i) {
    RequireListedImage(left, left_rows[i]);
    RequireListedImage(right, right_rows[i]);
    sequence.pairs.push_back({left_rows[i].stamp_ns, left_rows[i].image, right_rows[i].image});
  }
  return sequence;
}

std::vector<EurocBodyPose> ReadEurocGroundTruth(const fs::path& csv) {
  RequireFile(csv, "ground truth");
  std::ifstream in(csv);
  if (!in) throw Error(ErrorCode::kNotFound, "cannot open ground truth " + csv.string());
  const auto fail = [&](int line, const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument,
                csv.string() + " line " + std::to_string(line) + ": " + what);
  };
  // The fields this reads, in the csv's order (the header's names, shortened).
  static constexpr const char* kFields[] = {"timestamp", "p_RS_R_x", "p_RS_R_y", "p_RS_R_z",
                                            "q_RS_w",    "q_RS_x",   "q_RS_y",   "q_RS_z"};
  std::vector<EurocBodyPose> poses;
  int previous_line = 0;
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    std::string_view row = Trim(text);
    if (row.empty() || row.front() == '#') continue;
    std::vector<std::string_view> fields;
    while (fields.size() < std::size(kFields)) {
      const auto comma = row.find(',');
      fields.push_back(Trim(row.substr(0, comma)));
      if (comma == std::string_view::npos) break;
      row.remove_prefix(comma + 1);
    }
    if (fields.size() < std::size(kFields)) {
      fail(line,
           "expected at least 8 comma-separated fields (timestamp, position, quaternion "
           "w x y z), found " +
               std::to_string(fields.size()));
    }
    EurocBodyPose pose;
    const std::string_view stamp = fields[0];
    const auto [stamp_end, stamp_error] =
        std::from_chars(stamp.data(), stamp.data() + stamp.size(), pose.stamp_ns);
    if (stamp.empty() || stamp_error != std::errc() || stamp_end != stamp.data() + stamp.size()) {
      fail(line, "timestamp '" + std::string(stamp) + "' is not an integer number of nanoseconds");
    }
    double v[7];
    for (std::size_t i = 1; i < std::size(kFields); ++i) {
      const std::string_view f = fields[i];
      const auto [end, error] = std::from_chars(f.data(), f.data() + f.size(), v[i - 1]);
      if (f.empty() || error != std::errc() || end != f.data() + f.size() ||
          !std::isfinite(v[i - 1])) {
        fail(line, std::string(kFields[i]) + ": '" + std::string(f) + "' is not a number");
      }
    }
    if (!poses.empty() && pose.stamp_ns <= poses.back().stamp_ns) {
      fail(line, "timestamp " + std::to_string(pose.stamp_ns) + " does not come after line " +
                     std::to_string(previous_line) + "'s " + std::to_string(poses.back().stamp_ns) +
                     " (stamps must increase)");
    }
    const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    // The dataset prints quaternions to 6 digits or more; a norm further from 1 is not a rotation.
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      fail(line, "quaternion (q_RS_w, q_RS_x, q_RS_y, q_RS_z) has norm " +
                     std::to_string(q.norm()) + ", not 1");
    }
    pose.world_T_body.linear() = q.normalized().toRotationMatrix();
    pose.world_T_body.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
    poses.push_back(pose);
    previous_line = line;
  }
  if (in.bad()) throw Error(ErrorCode::kBackend, "read error in " + csv.string());
  if (poses.empty()) {
    throw Error(ErrorCode::kInvalidArgument, csv.string() + ": no ground-truth rows");
  }
  return poses;
}

std::optional<Eigen::Isometry3d> InterpolateBodyPose(const std::vector<EurocBodyPose>& poses,
                                                     std::int64_t stamp_ns) {
  // The first row at or after the stamp.
  const auto after = std::lower_bound(
      poses.begin(), poses.end(), stamp_ns,
      [](const EurocBodyPose& pose, std::int64_t stamp) { return pose.stamp_ns < stamp; });
  if (after == poses.end()) return std::nullopt;
  if (after->stamp_ns == stamp_ns) return after->world_T_body;
  if (after == poses.begin()) return std::nullopt;
  const EurocBodyPose& before = *std::prev(after);
  const std::int64_t gap_ns = after->stamp_ns - before.stamp_ns;
  if (gap_ns > kEurocGroundTruthMaxGapNs) return std::nullopt;
  const double a = static_cast<double>(stamp_ns - before.stamp_ns) / static_cast<double>(gap_ns);
  const Eigen::Quaterniond q0(before.world_T_body.linear());
  const Eigen::Quaterniond q1(after->world_T_body.linear());
  Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
  pose.linear() = q0.slerp(a, q1).toRotationMatrix();
  pose.translation() =
      (1.0 - a) * before.world_T_body.translation() + a * after->world_T_body.translation();
  return pose;
}

cv::Mat DecodeMonoImage(const std::string& bytes, const std::string& what, int expected_width_px,
                        int expected_height_px) {
  if (bytes.empty()) throw Error(ErrorCode::kCorrupt, "image " + what + " is empty");
  if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    throw Error(ErrorCode::kCorrupt, "image " + what + " is too large to decode");
  }
  cv::Mat image;
  try {
    image = DecodeImage(bytes, ImagePixels::kGray8, what);
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kCorrupt) throw;
    throw Error(ErrorCode::kCorrupt, "image " + what + " does not decode: " + e.message());
  }
  if (image.cols != expected_width_px || image.rows != expected_height_px) {
    throw Error(ErrorCode::kInvalidArgument,
                "image " + what + " is " + std::to_string(image.cols) + "x" +
                    std::to_string(image.rows) + " px, but the camera's calibration says " +
                    std::to_string(expected_width_px) + "x" + std::to_string(expected_height_px));
  }
  return image;
}

cv::Mat ReadMonoImage(const fs::path& file, int expected_width_px, int expected_height_px) {
  return DecodeMonoImage(ReadImageBytes(file), file.string(), expected_width_px,
                         expected_height_px);
}

std::string ReadImageBytes(const fs::path& file) {
  RequireFile(file, "image");
  std::ifstream in(file, std::ios::binary);
  if (!in) throw Error(ErrorCode::kNotFound, "cannot open image " + file.string());
  std::string bytes{std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  if (in.bad()) throw Error(ErrorCode::kBackend, "read error in image " + file.string());
  return bytes;
}

}  // namespace fleetmap
