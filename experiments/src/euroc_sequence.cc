// Reading a EuRoC (ASL) stereo folder and its images (euroc_sequence.h).
#include "fleetmap/experiments/euroc_sequence.h"

#include <algorithm>
#include <charconv>
#include <fstream>
#include <iterator>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <string>
#include <string_view>
#include <system_error>

#include "fleetmap/common/error.h"

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

std::string_view Trim(std::string_view text) {
  const auto first = text.find_first_not_of(" \t\r");
  if (first == std::string_view::npos) return {};
  const auto last = text.find_last_not_of(" \t\r");
  return text.substr(first, last - first + 1);
}

void RequireDirectory(const fs::path& dir, const std::string& what) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) {
    throw Error(ErrorCode::kNotFound,
                what + " " + dir.string() +
                    (fs::exists(dir, ec) ? " is not a directory" : " does not exist"));
  }
}

void RequireFile(const fs::path& file, const std::string& what) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) {
    throw Error(ErrorCode::kNotFound,
                what + " " + file.string() +
                    (fs::exists(file, ec) ? " is not a regular file" : " does not exist"));
  }
}

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

bool Exists(const fs::path& file) {
  std::error_code ec;
  return fs::exists(file, ec);
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

cv::Mat DecodeMonoImage(const std::string& bytes, const std::string& what, int expected_width_px,
                        int expected_height_px) {
  if (bytes.empty()) throw Error(ErrorCode::kCorrupt, "image " + what + " is empty");
  if (bytes.size() > static_cast<std::size_t>(std::numeric_limits<int>::max())) {
    throw Error(ErrorCode::kCorrupt, "image " + what + " is too large to decode");
  }
  cv::Mat image;
  try {
    // imdecode only reads its input; cv::Mat has no const constructor over foreign data.
    const cv::Mat encoded(1, static_cast<int>(bytes.size()), CV_8UC1,
                          const_cast<char*>(bytes.data()));
    image = cv::imdecode(encoded, cv::IMREAD_GRAYSCALE);
  } catch (const cv::Exception& e) {
    throw Error(ErrorCode::kCorrupt, "image " + what + " does not decode: " + e.what());
  }
  if (image.empty()) {
    throw Error(ErrorCode::kCorrupt,
                "image " + what + " does not decode (not an image OpenCV reads, or truncated)");
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
