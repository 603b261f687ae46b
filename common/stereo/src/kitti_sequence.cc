// Reading KITTI odometry and KITTI raw stereo folders (kitti_sequence.h, stereo_sequence.h).
//
// KITTI's text files are whitespace-separated numbers, optionally behind a "KEY:" (calib.txt,
// calib_cam_to_cam.txt). Numbers are parsed with std::from_chars: no locale can turn "0.5" into
// 0 or 5. Every error names the file and its line as an editor counts them (blank lines
// included), and the field where the line has one.
#include "kitti_sequence.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <chrono>
#include <cmath>
#include <fstream>
#include <initializer_list>
#include <map>
#include <sstream>
#include <string>
#include <string_view>
#include <system_error>
#include <tuple>
#include <utility>
#include <vector>

#include "dataset_files.h"
#include "fleetmap/core/error.h"
#include "fleetmap/images/image_codec.h"
#include "fleetmap/stereo/euroc_sequence.h"

namespace fleetmap {
namespace {

namespace fs = std::filesystem;
using dataset_files::Exists;
using dataset_files::IsDirectory;
using dataset_files::IsFile;
using dataset_files::RequireDirectory;
using dataset_files::RequireFile;
using dataset_files::Trim;

// KITTI records at 10 Hz; odometry sequences without times.txt get this spacing.
constexpr std::int64_t kKittiFramePeriodNs = 100'000'000;
constexpr double kKittiRateHz = 10.0;

// A rotation read from a text file must be this close to orthonormal (KITTI prints 6-12 digits).
constexpr double kRotationTolerance = 1e-3;

using Projection = Eigen::Matrix<double, 3, 4, Eigen::RowMajor>;

std::vector<std::string_view> Words(std::string_view text) {
  std::vector<std::string_view> words;
  while (true) {
    const auto first = text.find_first_not_of(" \t\r\n");
    if (first == std::string_view::npos) break;
    text.remove_prefix(first);
    const auto end = text.find_first_of(" \t\r\n");
    words.push_back(text.substr(0, end));
    if (end == std::string_view::npos) break;
    text.remove_prefix(end);
  }
  return words;
}

bool ParseDouble(std::string_view text, double& value) {
  // from_chars takes no leading '+'; a file may well have one.
  if (!text.empty() && text.front() == '+') text.remove_prefix(1);
  const auto [end, error] = std::from_chars(text.data(), text.data() + text.size(), value);
  return !text.empty() && error == std::errc() && end == text.data() + text.size() &&
         std::isfinite(value);
}

// One non-blank line of a text file, numbered from 1.
struct TextLine {
  int number = 0;
  std::string text;  // trimmed
};

std::vector<TextLine> ReadLines(const fs::path& file, const std::string& what) {
  RequireFile(file, what);
  std::ifstream in(file);
  if (!in) throw Error(ErrorCode::kNotFound, "cannot open " + what + " " + file.string());
  std::vector<TextLine> lines;
  std::string text;
  for (int number = 1; std::getline(in, text); ++number) {
    const std::string_view trimmed = Trim(text);
    if (!trimmed.empty()) lines.push_back({number, std::string(trimmed)});
  }
  if (in.bad()) throw Error(ErrorCode::kBackend, "read error in " + file.string());
  return lines;
}

// "FILE line N (FIELD): what", or without the field for files whose lines have none.
[[noreturn]] void Malformed(const fs::path& file, int line, const std::string& field,
                            const std::string& what) {
  throw Error(ErrorCode::kInvalidArgument, file.string() + " line " + std::to_string(line) +
                                               (field.empty() ? "" : " (" + field + ")") + ": " +
                                               what);
}

// Exactly `expected` numbers from `words`.
std::vector<double> ParseNumbers(const std::vector<std::string_view>& words, std::size_t expected,
                                 const fs::path& file, int line, const std::string& field) {
  std::vector<double> values;
  for (const std::string_view word : words) {
    double value = 0;
    if (!ParseDouble(word, value)) {
      Malformed(file, line, field,
                "'" + std::string(word) + "' (value " + std::to_string(values.size() + 1) +
                    ") is not a number");
    }
    values.push_back(value);
  }
  if (values.size() != expected) {
    Malformed(file, line, field,
              "expected " + std::to_string(expected) + (expected == 1 ? " number" : " numbers") +
                  ", found " + std::to_string(values.size()));
  }
  return values;
}

// "FILE has N lines but there are M image pairs".
void RequireOneLinePerPair(const fs::path& file, std::size_t lines, std::size_t pairs) {
  if (lines != pairs) {
    throw Error(ErrorCode::kInvalidArgument,
                file.string() + " has " + std::to_string(lines) +
                    (lines == 1 ? " line" : " lines") + " but there " +
                    (pairs == 1 ? "is " : "are ") + std::to_string(pairs) +
                    (pairs == 1 ? " image pair" : " image pairs") + " (one line per pair)");
  }
}

// A 3x3 row-major rotation from a file, re-orthonormalised, or a Malformed error.
Eigen::Matrix3d CheckedRotation(const Eigen::Matrix3d& rotation, const fs::path& file, int line,
                                const std::string& field) {
  const double orthogonality =
      (rotation * rotation.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  if (orthogonality > kRotationTolerance || rotation.determinant() <= 0) {
    std::ostringstream what;
    what << "the rotation is not orthonormal (largest |R R^T - I| entry " << orthogonality
         << ", det " << rotation.determinant() << "; allowed " << kRotationTolerance << ")";
    Malformed(file, line, field, what.str());
  }
  // Re-orthonormalise so products of many poses stay rigid.
  return Eigen::Quaterniond(rotation).normalized().toRotationMatrix();
}

// The PNG files of an image folder, sorted by name (KITTI's zero-padded frame numbers).
std::vector<std::string> PngNames(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->path().extension() == ".png" && IsFile(it->path())) {
      names.push_back(it->path().filename().string());
    }
  }
  if (ec) {
    throw Error(ErrorCode::kBackend,
                "cannot list image folder " + dir.string() + ": " + ec.message());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// Pairs the PNGs of the two folders by file name; stamps are left 0 for the caller.
std::vector<StereoPairFiles> PairImages(const fs::path& left_dir, const fs::path& right_dir) {
  const std::vector<std::string> left = PngNames(left_dir);
  const std::vector<std::string> right = PngNames(right_dir);
  // A frame on one side only: name the first one missing, and where its partner is.
  for (const auto& [names, from, to] :
       {std::tuple{&left, &left_dir, &right_dir}, std::tuple{&right, &right_dir, &left_dir}}) {
    for (const std::string& name : *names) {
      if (!IsFile(*to / name)) {
        throw Error(ErrorCode::kNotFound, "image " + (*to / name).string() +
                                              " does not exist, but its partner " +
                                              (*from / name).string() + " does");
      }
    }
  }
  if (left.empty()) {
    throw Error(ErrorCode::kInvalidArgument, "no stereo pairs: " + left_dir.string() + " and " +
                                                 right_dir.string() + " hold no .png images");
  }
  std::vector<StereoPairFiles> pairs;
  for (const std::string& name : left) pairs.push_back({0, left_dir / name, right_dir / name});
  return pairs;
}

// An image's size, decoding it (a whole file, not only its header, so a damaged first pair is
// found when the sequence loads); Error(kCorrupt) if it does not decode.
cv::Size ImageSize(const fs::path& file) {
  RequireFile(file, "image");
  try {
    return DecodeImage(ReadImageBytes(file), ImagePixels::kAsStored, file.string()).size();
  } catch (const Error& e) {
    if (e.code() != ErrorCode::kCorrupt) throw;
    throw Error(ErrorCode::kCorrupt, "image " + file.string() + " does not decode: " + e.message());
  }
}

// The pair's two images must be of one size; returns it.
cv::Size PairImageSize(const StereoPairFiles& pair) {
  const cv::Size left = ImageSize(pair.left_image);
  const cv::Size right = ImageSize(pair.right_image);
  if (left != right) {
    throw Error(ErrorCode::kInvalidArgument,
                "the first pair's images differ in size: " + pair.left_image.string() + " is " +
                    std::to_string(left.width) + "x" + std::to_string(left.height) + " px, " +
                    pair.right_image.string() + " " + std::to_string(right.width) + "x" +
                    std::to_string(right.height));
  }
  return left;
}

// A rectified camera from its 3x4 projection matrix P = K [I | t]: K's focal lengths and
// principal point, no distortion. The caller places it in the rig.
PinholeCamera RectifiedCamera(const std::string& name, const Projection& P, cv::Size size) {
  PinholeCamera camera;
  camera.name = name;
  camera.width_px = size.width;
  camera.height_px = size.height;
  camera.fx = P(0, 0);
  camera.fy = P(1, 1);
  camera.cx = P(0, 2);
  camera.cy = P(1, 2);
  camera.rate_hz = kKittiRateHz;
  return camera;
}

// Where a rectified camera's centre sits, in metres along the rectified x axis, from its
// projection P = K [I | t]: P[0][3] = fx t_x + cx t_z, so t_x = (P[0][3] - cx P[2][3]) / fx.
// KITTI's colour cameras (2 and 3) have t_z of a few millimetres; ignoring it in P[0][3] gives
// cx t_z / fx of baseline error (camera 3 of sequences 04-12: 0.4692 instead of 0.4733 m, 0.9 %
// of scale on every stereo depth).
double RectifiedCentreX(const Projection& P) {
  return -(P(0, 3) - P(0, 2) * P(2, 3)) / P(0, 0);
}

// Checks a rectified pair's projection matrices and returns the baseline: for a horizontal rig
// rectified to camera 0, P_right = K [I | (-b, t_y, t_z)] with t_y, t_z zero or millimetres, so
// b is the right centre's x less the left's (RectifiedCentreX). The millimetres of t_y and t_z
// are left out of the rig: at 5 m they move a point by under 0.3 px.
double RectifiedBaseline(const Projection& left, int left_line, const std::string& left_field,
                         const Projection& right, int right_line, const std::string& right_field,
                         const fs::path& file) {
  for (const auto& [P, line, field] :
       {std::tuple{&left, left_line, &left_field}, std::tuple{&right, right_line, &right_field}}) {
    if (!((*P)(0, 0) > 0 && (*P)(1, 1) > 0)) {
      std::ostringstream what;
      what << "focal lengths " << *field << "[0][0] = " << (*P)(0, 0) << " and " << *field
           << "[1][1] = " << (*P)(1, 1) << " must be positive";
      Malformed(file, line, *field, what.str());
    }
  }
  const double baseline_m = RectifiedCentreX(right) - RectifiedCentreX(left);
  if (!(baseline_m > 0)) {
    std::ostringstream what;
    // + 0.0 prints a baseline of -0 (P[0][3] = 0) as 0.
    what << "baseline (" << right_field << "'s centre x less " << left_field
         << "'s, each -(P[0][3] - P[0][2] P[2][3]) / P[0][0]) = " << baseline_m + 0.0
         << " m is not positive (the right camera must lie to the right of the left one)";
    Malformed(file, right_line, right_field, what.str());
  }
  return baseline_m;
}

void PlaceRectifiedPair(PinholeCamera& left, PinholeCamera& right, double baseline_m) {
  left.body_T_sensor = Eigen::Isometry3d::Identity();
  right.body_T_sensor = Eigen::Isometry3d::Identity();
  right.body_T_sensor.translation() = Eigen::Vector3d(baseline_m, 0, 0);
}

// ---- KITTI odometry ----

// The first of `names` that is a folder under `dir`.
fs::path ImageFolder(const fs::path& dir, std::initializer_list<const char*> names,
                     const std::string& side) {
  for (const char* name : names) {
    if (IsDirectory(dir / name)) return dir / name;
  }
  std::string list;
  for (const char* name : names) list += (list.empty() ? "" : " or ") + std::string(name) + "/";
  throw Error(ErrorCode::kNotFound,
              dir.string() + ": no " + side + " image folder (" + list + ") in this KITTI folder");
}

struct ProjectionLine {
  int line = 0;
  Projection P = Projection::Zero();
};

// calib.txt: "P0: 12 numbers" / "P1: ..." (the benchmark's files, with P2, P3 and Tr lines too),
// or bare lines of 12 numbers, the first two being P0 and P1 (how some excerpts ship it).
std::pair<ProjectionLine, ProjectionLine> ReadOdometryCalibration(const fs::path& file) {
  std::map<std::string, ProjectionLine> found;
  int bare_lines = 0;
  for (const TextLine& line : ReadLines(file, "camera calibration")) {
    std::string_view text = line.text;
    std::string key;
    if (const auto colon = text.find(':'); colon != std::string_view::npos) {
      key = std::string(Trim(text.substr(0, colon)));
      text.remove_prefix(colon + 1);
    } else {
      // Bare lines stand in order for P0, P1 (then P2, P3: not needed).
      key = "P" + std::to_string(bare_lines++);
    }
    if (key != "P0" && key != "P1") continue;
    if (const auto seen = found.find(key); seen != found.end()) {
      Malformed(
          file, line.number, key,
          "a second " + key + " (the first is on line " + std::to_string(seen->second.line) + ")");
    }
    const std::vector<double> values = ParseNumbers(Words(text), 12, file, line.number, key);
    ProjectionLine& p = found[key];
    p.line = line.number;
    for (int i = 0; i < 12; ++i) p.P(i / 4, i % 4) = values[static_cast<std::size_t>(i)];
  }
  for (const auto& [key, what] :
       {std::pair{"P0", "the left camera's"}, std::pair{"P1", "the right camera's"}}) {
    if (found.count(key) == 0) {
      throw Error(ErrorCode::kInvalidArgument,
                  file.string() + ": no " + key + " line (" + what + " 3x4 projection matrix: \"" +
                      key + ": 12 numbers\", or line " + (std::string(key) == "P0" ? "1" : "2") +
                      " of bare numbers)");
    }
  }
  return {found["P0"], found["P1"]};
}

// times.txt: seconds since the start, one per pair, increasing.
void ReadOdometryTimes(const fs::path& file, std::vector<StereoPairFiles>& pairs) {
  const std::vector<TextLine> lines = ReadLines(file, "frame times");
  RequireOneLinePerPair(file, lines.size(), pairs.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLine& line = lines[i];
    const double seconds = ParseNumbers(Words(line.text), 1, file, line.number, "")[0];
    // int64 ns hold +-292 years; a time beyond a few centuries is not a frame time.
    if (std::abs(seconds) > 9e9) {
      Malformed(file, line.number, "", line.text + " s is out of range for a frame time");
    }
    pairs[i].stamp_ns = std::llround(seconds * 1e9);
    if (i > 0 && pairs[i].stamp_ns <= pairs[i - 1].stamp_ns) {
      Malformed(file, line.number, "",
                line.text + " does not come after line " + std::to_string(lines[i - 1].number) +
                    "'s " + lines[i - 1].text + " (times must increase)");
    }
  }
}

// poses.txt: the left camera's [R|t] per pair in the first frame's camera coordinates.
std::vector<std::optional<Eigen::Isometry3d>> ReadOdometryPoses(const fs::path& file,
                                                                std::size_t pairs) {
  const std::vector<TextLine> lines = ReadLines(file, "ground-truth poses");
  RequireOneLinePerPair(file, lines.size(), pairs);
  std::vector<Eigen::Isometry3d> world_T_left;
  for (const TextLine& line : lines) {
    const std::vector<double> v = ParseNumbers(Words(line.text), 12, file, line.number, "");
    Eigen::Matrix3d rotation;
    rotation << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    Eigen::Isometry3d pose = Eigen::Isometry3d::Identity();
    pose.linear() = CheckedRotation(rotation, file, line.number, "");
    pose.translation() = Eigen::Vector3d(v[3], v[7], v[11]);
    world_T_left.push_back(pose);
  }
  // Re-based on line 1: an excerpt cut from the middle of a sequence may keep its poses.
  const Eigen::Isometry3d first_T_world = world_T_left.front().inverse();
  std::vector<std::optional<Eigen::Isometry3d>> first_T_left;
  for (const Eigen::Isometry3d& pose : world_T_left)
    first_T_left.emplace_back(first_T_world * pose);
  return first_T_left;
}

// ---- KITTI raw ----

// One "KEY: numbers" line of calib_cam_to_cam.txt.
struct CalibrationField {
  int line = 0;
  std::vector<double> values;
};

class RawCalibration {
 public:
  explicit RawCalibration(fs::path file) : file_(std::move(file)) {
    for (const TextLine& line : ReadLines(file_, "camera calibration")) {
      const auto colon = line.text.find(':');
      if (colon == std::string::npos) {
        Malformed(file_, line.number, "", "expected \"KEY: values\", found '" + line.text + "'");
      }
      const std::string key(Trim(std::string_view(line.text).substr(0, colon)));
      const std::size_t count = ExpectedCount(key);
      if (count == 0) continue;  // calib_time, corner_dist and anything else not needed
      if (const auto seen = fields_.find(key); seen != fields_.end()) {
        Malformed(file_, line.number, key,
                  "a second " + key + " (the first is on line " +
                      std::to_string(seen->second.line) + ")");
      }
      fields_[key] = {line.number,
                      ParseNumbers(Words(std::string_view(line.text).substr(colon + 1)), count,
                                   file_, line.number, key)};
    }
  }

  const fs::path& file() const { return file_; }
  const CalibrationField* Find(const std::string& key) const {
    const auto it = fields_.find(key);
    return it == fields_.end() ? nullptr : &it->second;
  }
  // REQUIRES nothing; throws Error(kInvalidArgument) naming the key when the file lacks it.
  const CalibrationField& Get(const std::string& key, const std::string& why) const {
    const CalibrationField* field = Find(key);
    if (field == nullptr) {
      throw Error(ErrorCode::kInvalidArgument,
                  file_.string() + ": no " + key + " line (" + why + ")");
    }
    return *field;
  }
  Projection GetProjection(const std::string& key, const std::string& why) const {
    const std::vector<double>& v = Get(key, why).values;
    Projection P;
    for (int i = 0; i < 12; ++i) P(i / 4, i % 4) = v[static_cast<std::size_t>(i)];
    return P;
  }

 private:
  // How many numbers a known field holds (KITTI raw devkit's readme); 0 for other keys.
  static std::size_t ExpectedCount(const std::string& key) {
    static const std::pair<const char*, std::size_t> kFields[] = {
        {"S_rect_", 2}, {"R_rect_", 9}, {"P_rect_", 12}, {"S_", 2},
        {"K_", 9},      {"D_", 5},      {"R_", 9},       {"T_", 3}};
    for (const auto& [prefix, count] : kFields) {
      const std::string_view p(prefix);
      // The prefix then a two-digit camera number: "K_00", "P_rect_01".
      if (key.size() == p.size() + 2 && key.starts_with(p) &&
          std::isdigit(static_cast<unsigned char>(key[p.size()])) &&
          std::isdigit(static_cast<unsigned char>(key[p.size() + 1]))) {
        return count;
      }
    }
    return 0;
  }

  fs::path file_;
  std::map<std::string, CalibrationField> fields_;
};

std::string SizeText(double width, double height) {
  std::ostringstream text;
  text << width << "x" << height;
  return text.str();
}

// A raw (unrectified) camera of the rig: K_0x, D_0x and its extrinsics (R_0x, T_0x), which map
// points of the reference (camera 0, unrectified) into this camera: x_cam = R x_ref + T.
PinholeCamera RawCamera(const RawCalibration& calib, const std::string& index, cv::Size size) {
  const std::string why = "camera " + index + " of unrectified images";
  const CalibrationField& K = calib.Get("K_" + index, why);
  const CalibrationField& D = calib.Get("D_" + index, why);
  const CalibrationField& R = calib.Get("R_" + index, why);
  const CalibrationField& T = calib.Get("T_" + index, why);
  PinholeCamera camera;
  camera.name = "KITTI raw image_" + index;
  camera.width_px = size.width;
  camera.height_px = size.height;
  camera.fx = K.values[0];
  camera.cx = K.values[2];
  camera.fy = K.values[4];
  camera.cy = K.values[5];
  if (!(camera.fx > 0 && camera.fy > 0)) {
    Malformed(calib.file(), K.line, "K_" + index, "focal lengths must be positive");
  }
  std::copy(D.values.begin(), D.values.end(), camera.distortion.begin());
  Eigen::Matrix3d rotation;
  for (int i = 0; i < 9; ++i) rotation(i / 3, i % 3) = R.values[static_cast<std::size_t>(i)];
  Eigen::Isometry3d sensor_T_body = Eigen::Isometry3d::Identity();
  sensor_T_body.linear() = CheckedRotation(rotation, calib.file(), R.line, "R_" + index);
  sensor_T_body.translation() = Eigen::Vector3d(T.values[0], T.values[1], T.values[2]);
  camera.body_T_sensor = sensor_T_body.inverse();
  camera.rate_hz = kKittiRateHz;
  return camera;
}

// "2011-09-26 13:02:25.964389445" (UTC, up to 9 fraction digits) -> ns since 1970; nullopt for
// anything else. By hand: strptime and std::get_time depend on the locale.
std::optional<std::int64_t> ParseUtcTime(std::string_view text) {
  const auto digits = [&](std::size_t at, std::size_t n) -> std::optional<int> {
    if (at + n > text.size()) return std::nullopt;
    int value = 0;
    for (std::size_t i = at; i < at + n; ++i) {
      if (!std::isdigit(static_cast<unsigned char>(text[i]))) return std::nullopt;
      value = value * 10 + (text[i] - '0');
    }
    return value;
  };
  if (text.size() < 19 || text[4] != '-' || text[7] != '-' || text[10] != ' ' || text[13] != ':' ||
      text[16] != ':') {
    return std::nullopt;
  }
  const auto year = digits(0, 4), month = digits(5, 2), day = digits(8, 2);
  const auto hour = digits(11, 2), minute = digits(14, 2), second = digits(17, 2);
  if (!year || !month || !day || !hour || !minute || !second) return std::nullopt;
  const std::chrono::year_month_day date{std::chrono::year(*year),
                                         std::chrono::month(static_cast<unsigned>(*month)),
                                         std::chrono::day(static_cast<unsigned>(*day))};
  if (!date.ok() || *hour > 23 || *minute > 59 || *second > 60) return std::nullopt;
  std::int64_t fraction_ns = 0;
  if (text.size() > 19) {
    const std::size_t fraction_digits = text.size() - 20;
    if (text[19] != '.' || fraction_digits == 0 || fraction_digits > 9) return std::nullopt;
    const auto fraction = digits(20, fraction_digits);
    if (!fraction) return std::nullopt;
    fraction_ns = *fraction;
    for (std::size_t i = fraction_digits; i < 9; ++i) fraction_ns *= 10;
  }
  const std::int64_t days = std::chrono::sys_days(date).time_since_epoch().count();
  const std::int64_t seconds = ((days * 24 + *hour) * 60 + *minute) * 60 + *second;
  return seconds * 1'000'000'000 + fraction_ns;
}

void ReadRawTimestamps(const fs::path& file, std::vector<StereoPairFiles>& pairs) {
  const std::vector<TextLine> lines = ReadLines(file, "image timestamps");
  RequireOneLinePerPair(file, lines.size(), pairs.size());
  for (std::size_t i = 0; i < lines.size(); ++i) {
    const TextLine& line = lines[i];
    const std::optional<std::int64_t> stamp_ns = ParseUtcTime(line.text);
    if (!stamp_ns) {
      Malformed(file, line.number, "",
                "'" + line.text + "' is not a time \"YYYY-MM-DD HH:MM:SS.fffffffff\" (UTC)");
    }
    pairs[i].stamp_ns = *stamp_ns;
    if (i > 0 && pairs[i].stamp_ns <= pairs[i - 1].stamp_ns) {
      Malformed(file, line.number, "",
                line.text + " does not come after line " + std::to_string(lines[i - 1].number) +
                    "'s " + lines[i - 1].text + " (times must increase)");
    }
  }
}

}  // namespace

StereoSequence LoadKittiOdometrySequence(const fs::path& dir) {
  StereoSequence sequence;
  sequence.dir = dir;
  sequence.layout = StereoLayout::kKittiOdometry;
  sequence.credit = kKittiCredit;
  const fs::path left_dir = ImageFolder(dir, {"image_l", "image_0"}, "left");
  const fs::path right_dir = ImageFolder(dir, {"image_r", "image_1"}, "right");
  const fs::path calib = dir / "calib.txt";
  const auto [p0, p1] = ReadOdometryCalibration(calib);
  const double baseline_m = RectifiedBaseline(p0.P, p0.line, "P0", p1.P, p1.line, "P1", calib);

  sequence.pairs = PairImages(left_dir, right_dir);
  const cv::Size size = PairImageSize(sequence.pairs.front());
  sequence.left =
      RectifiedCamera("KITTI odometry left (" + left_dir.filename().string() + ", P0)", p0.P, size);
  sequence.right = RectifiedCamera(
      "KITTI odometry right (" + right_dir.filename().string() + ", P1)", p1.P, size);
  PlaceRectifiedPair(sequence.left, sequence.right, baseline_m);

  if (const fs::path times = dir / "times.txt"; Exists(times)) {
    ReadOdometryTimes(times, sequence.pairs);
  } else {
    for (std::size_t i = 0; i < sequence.pairs.size(); ++i) {
      sequence.pairs[i].stamp_ns = static_cast<std::int64_t>(i) * kKittiFramePeriodNs;
    }
  }
  if (const fs::path poses = dir / "poses.txt"; Exists(poses)) {
    sequence.first_T_left = ReadOdometryPoses(poses, sequence.pairs.size());
  }
  return sequence;
}

StereoSequence LoadKittiRawSequence(const fs::path& dir) {
  StereoSequence sequence;
  sequence.dir = dir;
  sequence.layout = StereoLayout::kKittiRaw;
  sequence.credit = kKittiCredit;
  const fs::path left_dir = dir / "image_00" / "data";
  const fs::path right_dir = dir / "image_01" / "data";
  RequireDirectory(left_dir, "left image folder");
  RequireDirectory(right_dir, "right image folder");
  const std::optional<fs::path> calib_file = FindKittiRawCalibration(dir);
  if (!calib_file) {
    throw Error(ErrorCode::kNotFound, "camera calibration calib_cam_to_cam.txt is neither in " +
                                          dir.string() + " nor in its parent folder");
  }
  const RawCalibration calib(*calib_file);
  sequence.pairs = PairImages(left_dir, right_dir);
  ReadRawTimestamps(dir / "image_00" / "timestamps.txt", sequence.pairs);

  // Which download: the images' size says whether they were rectified.
  const cv::Size size = PairImageSize(sequence.pairs.front());
  const auto matches = [&](const CalibrationField* s) {
    return s != nullptr && s->values[0] == size.width && s->values[1] == size.height;
  };
  const CalibrationField* rect_size = calib.Find("S_rect_00");
  const CalibrationField* raw_size = calib.Find("S_00");
  if (matches(rect_size)) {
    const std::string why = "rectified images";
    const Projection p0 = calib.GetProjection("P_rect_00", why);
    const Projection p1 = calib.GetProjection("P_rect_01", why);
    const double baseline_m =
        RectifiedBaseline(p0, calib.Get("P_rect_00", why).line, "P_rect_00", p1,
                          calib.Get("P_rect_01", why).line, "P_rect_01", calib.file());
    sequence.left = RectifiedCamera("KITTI raw image_00 (rectified, P_rect_00)", p0, size);
    sequence.right = RectifiedCamera("KITTI raw image_01 (rectified, P_rect_01)", p1, size);
    PlaceRectifiedPair(sequence.left, sequence.right, baseline_m);
  } else if (matches(raw_size)) {
    sequence.left = RawCamera(calib, "00", size);
    sequence.right = RawCamera(calib, "01", size);
  } else {
    std::string known;
    for (const auto& [field, kind] : {std::pair{rect_size, "S_rect_00 (rectified)"},
                                      std::pair{raw_size, "S_00 (unrectified)"}}) {
      if (field == nullptr) continue;
      known += (known.empty() ? "" : ", ") + std::string(kind) + " = " +
               SizeText(field->values[0], field->values[1]);
    }
    throw Error(ErrorCode::kInvalidArgument,
                calib.file().string() + ": " +
                    (known.empty() ? "no S_rect_00 or S_00 line (image sizes of the rectified and "
                                     "unrectified cameras), so the images of " +
                                         dir.string() + " cannot be matched to a calibration"
                                   : "the images (" + sequence.pairs.front().left_image.string() +
                                         ": " + SizeText(size.width, size.height) +
                                         " px) match no calibrated size: " + known));
  }
  return sequence;
}

std::optional<fs::path> FindKittiRawCalibration(const fs::path& dir) {
  fs::path here = dir.lexically_normal();
  if (!here.has_filename()) here = here.parent_path();  // "drive/" -> "drive"
  const fs::path parent = fs::absolute(here).parent_path();
  for (const fs::path& folder : {here, parent}) {
    const fs::path file = folder / "calib_cam_to_cam.txt";
    if (IsFile(file)) return file;
  }
  return std::nullopt;
}

}  // namespace fleetmap
