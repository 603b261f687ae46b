// A reader of TUM RGB-D trajectory files, written for the tests from the format's description:
// '#' lines are comments; every other line is "timestamp tx ty tz qx qy qz qw", eight numbers.
// A line with another number of fields or a field that is not a number throws
// std::runtime_error quoting it.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "text_fields.h"

namespace fleetmap::testing {

struct TumPose {
  std::string timestamp_text;  // as written, to check it digit by digit
  double timestamp_s = 0;
  Eigen::Vector3d translation;
  Eigen::Quaterniond rotation;
};

struct TumTrajectory {
  std::vector<std::string> comments;  // without the '#'
  std::vector<TumPose> poses;
};

inline TumTrajectory ReadTum(const std::string& text) {
  TumTrajectory trajectory;
  std::istringstream lines(text);
  std::string line;
  while (std::getline(lines, line)) {
    if (line.empty()) continue;
    if (line[0] == '#') {
      trajectory.comments.push_back(line.substr(1));
      continue;
    }
    const std::vector<std::string> fields = SplitFields(line);
    if (fields.size() != 8) throw std::runtime_error("tum: 8 fields wanted: '" + line + "'");
    std::vector<double> values;
    for (const std::string& field : fields) {
      values.push_back(WholeNumber(field, "tum line '" + line + "'"));
    }
    TumPose pose;
    pose.timestamp_text = fields[0];
    pose.timestamp_s = values[0];
    pose.translation = {values[1], values[2], values[3]};
    pose.rotation = Eigen::Quaterniond(values[7], values[4], values[5], values[6]);
    trajectory.poses.push_back(pose);
  }
  return trajectory;
}

}  // namespace fleetmap::testing
