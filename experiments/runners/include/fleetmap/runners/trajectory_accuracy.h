// How far an estimated trajectory (visual odometry) is from the ground truth, by the measures
// stereo VO is usually reported with:
// - translational and rotational drift as the KITTI odometry benchmark defines them: for every
//   start frame and every sub-path length L, the first frame at least L metres of ground-truth
//   travel further on; the error of the estimated relative motion against the true one,
//   |t(err)| / L in percent and angle(err) / L in deg/m, averaged over all such sub-paths;
// - absolute trajectory error: the RMS distance between estimated and true positions after the
//   rigid motion (no scale: stereo measures it) that best aligns them (Umeyama).
// Poses follow se3.h: first_T_camera maps a frame's camera points into the first frame's.
#pragma once

#include <vector>

#include "fleetmap/core/se3.h"

namespace fleetmap {

struct TrajectoryAccuracy {
  int sub_paths = 0;  // drift samples; 0 when the path is shorter than any L
  double translational_drift_percent = 0;
  double rotational_drift_deg_per_m = 0;
  double ate_rmse_m = 0;          // after alignment
  double truth_length_m = 0;      // ground-truth path length
  std::vector<double> lengths_m;  // the sub-path lengths used
};

// Sub-path lengths for a path of `truth_length_m`: a path of at least 800 m gets KITTI's own
// 100, 200, ..., 800 m; a shorter one (an excerpt) the same idea at its own scale, every
// `step_m` up to its length (10, 20, 30, ... m by default). Empty when the path is shorter than
// step_m.
inline constexpr double kKittiLongestSubPath_m = 800.0;
std::vector<double> SubPathLengths(double truth_length_m, double step_m = 10.0);

// REQUIRES: estimated.size() == truth.size() (one pose per frame, the same frames), else
// Error(kInvalidArgument). With fewer than two frames everything is 0.
TrajectoryAccuracy MeasureTrajectory(const std::vector<Se3>& estimated,
                                     const std::vector<Se3>& truth,
                                     const std::vector<double>& lengths_m);

}  // namespace fleetmap
