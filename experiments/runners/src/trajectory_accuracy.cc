// Drift and absolute trajectory error against ground truth (trajectory_accuracy.h).
#include "fleetmap/runners/trajectory_accuracy.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>

#include "fleetmap/core/error.h"

namespace fleetmap {

std::vector<double> SubPathLengths(double truth_length_m, double step_m) {
  std::vector<double> lengths;
  if (truth_length_m >= kKittiLongestSubPath_m) {
    for (double l = 100; l <= kKittiLongestSubPath_m; l += 100) lengths.push_back(l);
    return lengths;
  }
  if (!(step_m > 0)) return lengths;
  for (double l = step_m; l <= truth_length_m + 1e-9; l += step_m) lengths.push_back(l);
  return lengths;
}

TrajectoryAccuracy MeasureTrajectory(const std::vector<Se3>& estimated,
                                     const std::vector<Se3>& truth,
                                     const std::vector<double>& lengths_m) {
  if (estimated.size() != truth.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                "trajectory accuracy: " + std::to_string(estimated.size()) +
                    " estimated poses but " + std::to_string(truth.size()) + " true ones");
  }
  TrajectoryAccuracy a;
  a.lengths_m = lengths_m;
  const std::size_t n = truth.size();
  if (n < 2) return a;

  // Distance travelled along the ground truth up to each frame.
  std::vector<double> travelled(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    travelled[i] = travelled[i - 1] + (truth[i].translation() - truth[i - 1].translation()).norm();
  }
  a.truth_length_m = travelled.back();

  // Lengths in increasing order, so each start frame scans forward once: O(n (n + lengths)),
  // not O(n^2 lengths), for drives of thousands of frames.
  std::vector<double> lengths = lengths_m;
  std::sort(lengths.begin(), lengths.end());
  double t_sum = 0, r_sum = 0;
  for (std::size_t first = 0; first < n; ++first) {
    std::size_t last = first;
    for (double length : lengths) {
      while (last < n && travelled[last] < travelled[first] + length) ++last;
      if (last == n) break;
      const Se3 true_motion = truth[first].inverse() * truth[last];
      const Se3 estimated_motion = estimated[first].inverse() * estimated[last];
      const Se3 error = estimated_motion.inverse() * true_motion;
      t_sum += error.translation().norm() / length;
      r_sum += RotationAngle(error) / length;
      ++a.sub_paths;
    }
  }
  if (a.sub_paths > 0) {
    a.translational_drift_percent = 100.0 * t_sum / a.sub_paths;
    a.rotational_drift_deg_per_m = r_sum / a.sub_paths * 180.0 / 3.14159265358979323846;
  }

  Eigen::Matrix3Xd est(3, static_cast<Eigen::Index>(n)), tru(3, static_cast<Eigen::Index>(n));
  for (std::size_t i = 0; i < n; ++i) {
    est.col(static_cast<Eigen::Index>(i)) = estimated[i].translation();
    tru.col(static_cast<Eigen::Index>(i)) = truth[i].translation();
  }
  const Eigen::Matrix4d truth_T_est = Eigen::umeyama(est, tru, /*with_scaling=*/false);
  const Eigen::Matrix3Xd aligned =
      (truth_T_est.topLeftCorner<3, 3>() * est).colwise() + truth_T_est.topRightCorner<3, 1>();
  a.ate_rmse_m = std::sqrt((aligned - tru).colwise().squaredNorm().mean());
  return a;
}

}  // namespace fleetmap
