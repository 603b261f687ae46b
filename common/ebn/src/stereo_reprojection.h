// Residuals of matched landmarks in rectified stereo pixels, for the localiser's stereo mode
// (localiser.h): the inlier test and the Gauss-Newton refinement of node_T_frame.
//
// Conventions: a camera projects a point q of its rectified left frame to
// (u_left, v, u_right) = f (q.x, q.y, q.x - b) / q.z, without the principal point, which
// cancels in every residual. The pose is perturbed on the left, node_T_frame <- exp(xi) *
// node_T_frame with xi = (omega, v) (rotation vector, translation), as in Sophus.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "fleetmap/core/graph.h"
#include "fleetmap/core/se3.h"

namespace fleetmap {

// Each measurement has its own pixel noise sigma (in units of a level-0 pixel): a keypoint
// found at pyramid level l was located in an image shrunk by scale^l, so its position is that
// many times less certain (ORB-SLAM weighs its residuals the same way). Thresholds and weights
// below are per sigma.
class StereoReprojection {
 public:
  // Column k of p_frame and p_node is match k. At least one camera is set. frame_sigma and
  // node_sigma hold each match's pixel noise in that view (>= 1), or are empty for 1.
  StereoReprojection(const Eigen::Matrix3Xd& p_frame, const Eigen::Matrix3Xd& p_node,
                     const std::optional<StereoCamera>& frame_camera,
                     const std::optional<StereoCamera>& node_camera,
                     Eigen::VectorXd frame_sigma = {}, Eigen::VectorXd node_sigma = {});

  // The matches node_T_frame explains: in every known camera the point lies in front and
  // projects within threshold_px x its sigma (Euclidean over u_left, v, u_right) of its
  // measurement.
  std::vector<int> Inliers(const Se3& node_T_frame, double threshold_px) const;

  // Gauss-Newton from node_T_frame on the summed squared pixel residuals of `inliers` (at
  // least three), each weighted by 1 / sigma^2; returns the refined pose, or node_T_frame when
  // the system is singular.
  Se3 Refine(const Se3& node_T_frame, const std::vector<int>& inliers) const;

  // The covariance of node_T_frame (pose_covariance.h) at a fit over `inliers`: the inverse of
  // the weighted normal matrix, scaled by the weighted residuals' variance per pixel.
  PoseCovariance Covariance(const Se3& node_T_frame, const std::vector<int>& inliers) const;

 private:
  struct View {
    Eigen::Matrix3d rect_R_points;
    double focal_px = 0, baseline_m = 0;
    Eigen::Matrix3Xd measured;         // (u_left, v, u_right) of each match's own point
    Eigen::VectorXd inverse_variance;  // 1 / sigma^2 per match
  };
  static View MakeView(const StereoCamera& camera, const Eigen::Matrix3Xd& points,
                       const Eigen::VectorXd& sigma);
  // The weighted normal equations at `pose` over `inliers`: h += J^T W J, g += J^T W e, and the
  // weighted squared residuals and their count.
  struct Normal {
    Eigen::Matrix<double, 6, 6> h = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    double squared = 0.0;
    int residuals = 0;
  };
  Normal Linearise(const Se3& pose, const std::vector<int>& inliers) const;

  const Eigen::Matrix3Xd& p_frame_;
  const Eigen::Matrix3Xd& p_node_;
  std::optional<View> frame_view_, node_view_;
};

}  // namespace fleetmap
