// Localisation of a live frame against one experience (node): docs/ebn-core.md, the
// stereo match between frame Fq and node nk of seed 002 §III-C.
//
// Conventions (see se3.h):
// - Both landmark sets are 3-D points in metres, each in its own camera frame: the frame's
//   points in the live camera frame, the node's in the camera frame the node was saved in.
// - The result node_T_frame maps frame points into the node: p_node = node_T_frame * p_frame.
// - Descriptors are compared by Hamming distance (descriptor_matcher.h).
//
// Method: mutual-best descriptor matches with a ratio test, then RANSAC over minimal samples
// of three matched point pairs (stopping adaptively), each fitted rigidly (Eigen::umeyama, no
// scale). Which matches a hypothesis explains, and how it is refined, depends on what the
// landmarks carry:
// - 3-D residuals (neither side has a StereoCamera: the synthetic world, older maps): a match is
//   an inlier when |node_T_frame * p_frame - p_node| is below inlier_threshold_m. The best
//   hypothesis is refitted on its inliers (umeyama) and recounted; what happens when a refit
//   loses inliers is an option (least_squares_result).
// - Stereo reprojection (either side has one; seed 002 §III-C's stereo match on real images):
//   each point is carried into the other side's camera and projected to rectified pixels
//   (u_left, v, u_right), where triangulation noise is about even, unlike in metres where the
//   depth error grows as z^2 / (f b). A match is an inlier when, in every camera that is known,
//   the projected point lies in front of the camera and within reprojection_threshold_px of
//   the pixels the point was measured at (for the frame's own points: where its camera saw
//   them). The best hypothesis is then refined by Gauss-Newton on the sum of those squared
//   pixel residuals over its inliers, recounted, and refined again until the inlier set settles;
//   the last refinement always stands. A near point and a far point thus weigh by how well
//   stereo measured them, so far street structure (good for rotation) does not pull the pose.
#pragma once

#include <cstdint>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"

namespace fleetmap {

struct DescriptorMatch;  // descriptor_matcher.h

struct LocaliserOptions {
  double ratio = 0.8;           // Lowe ratio of descriptor matching, (0, 1]; 1 disables
  int max_distance = 80;        // largest descriptor distance accepted, bits [0, 256]
  int ransac_iterations = 200;  // most minimal samples drawn, >= 1 (degenerate ones count)
  // RANSAC stops early once a hypothesis with inlier ratio w makes further samples pointless:
  // after log(1 - confidence) / log(1 - w^3) samples, an all-inlier sample would have been
  // drawn with this probability. [0, 1); 0 always draws ransac_iterations samples.
  double ransac_confidence = 0.999;
  double inlier_threshold_m = 0.15;  // residual below which a match is an inlier, > 0
  int min_inliers = 12;              // success needs at least this many inliers, >= 3
  std::uint32_t seed = 1;            // RANSAC sampling; same seed and inputs, same result
  // After RANSAC the best hypothesis is refitted (least squares) on its inliers and recounted.
  // false: refits continue while the inlier set grows, and a refit that loses inliers is dropped,
  //   so the hypothesis with the most support stands, even a three-point one. The synthetic
  //   world's experiments (isotropic landmark noise) are calibrated with this.
  // true: refits continue until the inlier set stops changing and the last refit always stands,
  //   even with a few inliers fewer. Real stereo needs this: its depth error is many times its
  //   lateral error, and for a small motion a three-point fit that is centimetres off still
  //   gathers nearly every match within the threshold (visual odometry of a standing camera
  //   drifted 13 cm over the EuRoC excerpt without it; visual_odometry.h).
  bool least_squares_result = false;
  // Stereo reprojection inlier test: the largest distance, in rectified pixels of one camera,
  // between the projected (u_left, v, u_right) and the measured one, > 0. The default is the
  // 95 % point of a chi-square with 3 degrees of freedom at 1 px noise per coordinate (as stereo
  // SLAM front ends gate their matches): sqrt(7.815).
  double reprojection_threshold_px = 2.8;
  // Guided registration (Register): a frame point may match a node point within this many
  // standard deviations of where the prior puts it, at a descriptor distance of at most
  // guided_max_distance bits (the spatial gate stands in for most of the global matcher's
  // distinctiveness tests, as in a guided search after a pose prior).
  double guided_gate_sigmas = 3.0;  // > 0
  int guided_max_distance = 100;    // [0, 256]
};

struct LocalisationResult {
  bool success = false;
  Se3 node_T_frame = Se3::Identity();  // meaningful when success
  int inliers = 0;                     // inliers of the best hypothesis (0 if none was tried)
  int matches = 0;                     // descriptor matches RANSAC worked on
  bool stereo_residuals = false;       // judged by stereo reprojection (see above)
  // The uncertainty of node_T_frame (pose_covariance.h) from the final fit's residuals over its
  // inliers; meaningful when success.
  PoseCovariance covariance = PoseCovariance::Zero();
};

class Localiser {
 public:
  // Throws Error(kInvalidArgument) for options outside the ranges above.
  explicit Localiser(const LocaliserOptions& options = {});

  // Localises `frame` against `node`. Too few matches (fewer than three, or fewer than
  // min_inliers), empty sets or a failed RANSAC give success == false, never an exception.
  // REQUIRES: points_camera.size() == descriptors.size() in both, else throws
  // Error(kInvalidArgument).
  // Deterministic: the sampler is seeded from the options on every call, so a call does not
  // depend on earlier calls, and concurrent calls on one Localiser are safe.
  LocalisationResult Localise(const Landmarks& frame, const Landmarks& node) const;

  // Registers `frame` against `node` guided by a prior pose and its uncertainty: each frame
  // point is carried into the node by the prior and matched only with node points within
  // guided_gate_sigmas of where it lands (its position's standard deviation under the prior,
  // plus the inlier threshold), then the matches go through the same RANSAC and refinement as
  // Localise. A frame that the global matcher cannot localise for want of distinctive matches
  // can still register where the prior narrows each search to a few points. Same errors and
  // determinism as Localise.
  LocalisationResult Register(const Landmarks& frame, const Landmarks& node,
                              const Se3& prior_node_T_frame,
                              const PoseCovariance& prior_covariance) const;

  const LocaliserOptions& options() const { return options_; }

 private:
  LocalisationResult Solve(const Landmarks& frame, const Landmarks& node,
                           const std::vector<DescriptorMatch>& matches) const;

  LocaliserOptions options_;
};

}  // namespace fleetmap
