// Stereo pixel residuals for the localiser (stereo_reprojection.h).
#include "stereo_reprojection.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <cmath>
#include <limits>

namespace fleetmap {
namespace {

// A point this close to the camera plane (or behind it) cannot have been measured by stereo.
constexpr double kMinDepth_m = 1e-3;

// Gauss-Newton steps per refinement; it converges in a handful from a RANSAC hypothesis.
constexpr int kMaxIterations = 10;
constexpr double kConverged = 1e-10;  // squared step norm (rad^2 + m^2)

Eigen::Vector3d Project(double f, double b, const Eigen::Vector3d& q) {
  const double inv_z = 1.0 / q.z();
  return {f * q.x() * inv_z, f * q.y() * inv_z, f * (q.x() - b) * inv_z};
}

// d(u_left, v, u_right) / dq at q.
Eigen::Matrix3d ProjectJacobian(double f, double b, const Eigen::Vector3d& q) {
  const double inv_z = 1.0 / q.z();
  Eigen::Matrix3d j;
  j << f * inv_z, 0, -f * q.x() * inv_z * inv_z,  //
      0, f * inv_z, -f * q.y() * inv_z * inv_z,   //
      f * inv_z, 0, -f * (q.x() - b) * inv_z * inv_z;
  return j;
}

}  // namespace

StereoReprojection::View StereoReprojection::MakeView(const StereoCamera& camera,
                                                      const Eigen::Matrix3Xd& points,
                                                      const Eigen::VectorXd& sigma) {
  View view;
  view.inverse_variance = sigma.size() == 0 ? Eigen::VectorXd::Ones(points.cols())
                                            : Eigen::VectorXd(sigma.array().square().inverse());
  const auto& q = camera.rect_q_camera;
  view.rect_R_points = Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized().toRotationMatrix();
  view.focal_px = camera.focal_px;
  view.baseline_m = camera.baseline_m;
  view.measured.resize(3, points.cols());
  for (Eigen::Index k = 0; k < points.cols(); ++k) {
    const Eigen::Vector3d rect = view.rect_R_points * points.col(k);
    // Triangulated points lie in front; a bad one (z <= 0) simply never becomes an inlier.
    view.measured.col(k) = rect.z() > kMinDepth_m
                               ? Project(view.focal_px, view.baseline_m, rect)
                               : Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  }
  return view;
}

StereoReprojection::StereoReprojection(const Eigen::Matrix3Xd& p_frame,
                                       const Eigen::Matrix3Xd& p_node,
                                       const std::optional<StereoCamera>& frame_camera,
                                       const std::optional<StereoCamera>& node_camera,
                                       Eigen::VectorXd frame_sigma, Eigen::VectorXd node_sigma)
    : p_frame_(p_frame), p_node_(p_node) {
  if (frame_camera) frame_view_ = MakeView(*frame_camera, p_frame, frame_sigma);
  if (node_camera) node_view_ = MakeView(*node_camera, p_node, node_sigma);
}

std::vector<int> StereoReprojection::Inliers(const Se3& node_T_frame, double threshold_px) const {
  const double threshold_sq = threshold_px * threshold_px;
  const auto explains = [threshold_sq](const View& view, const Eigen::Vector3d& p, Eigen::Index k) {
    const Eigen::Vector3d q = view.rect_R_points * p;
    if (!(q.z() > kMinDepth_m)) return false;
    return (Project(view.focal_px, view.baseline_m, q) - view.measured.col(k)).squaredNorm() *
               view.inverse_variance(k) <
           threshold_sq;
  };
  const Se3 frame_T_node = node_T_frame.inverse();
  std::vector<int> inliers;
  for (Eigen::Index k = 0; k < p_frame_.cols(); ++k) {
    if (node_view_ && !explains(*node_view_, node_T_frame * Eigen::Vector3d(p_frame_.col(k)), k)) {
      continue;
    }
    if (frame_view_ && !explains(*frame_view_, frame_T_node * Eigen::Vector3d(p_node_.col(k)), k)) {
      continue;
    }
    inliers.push_back(static_cast<int>(k));
  }
  return inliers;
}

StereoReprojection::Normal StereoReprojection::Linearise(const Se3& pose,
                                                         const std::vector<int>& inliers) const {
  Normal normal;
  const Eigen::Matrix3d r = pose.linear();
  const Eigen::Vector3d t = pose.translation();
  const auto add = [&](const View& view, const Eigen::Vector3d& q,
                       const Eigen::Matrix<double, 3, 6>& dq_dxi, Eigen::Index k) {
    if (!(q.z() > kMinDepth_m)) return;
    const Eigen::Vector3d e = Project(view.focal_px, view.baseline_m, q) - view.measured.col(k);
    const Eigen::Matrix<double, 3, 6> j =
        ProjectJacobian(view.focal_px, view.baseline_m, q) * dq_dxi;
    const double w = view.inverse_variance(k);
    normal.h.noalias() += w * (j.transpose() * j);
    normal.g.noalias() += w * (j.transpose() * e);
    normal.squared += w * e.squaredNorm();
    normal.residuals += 3;
  };
  for (int index : inliers) {
    const Eigen::Index k = index;
    if (node_view_) {
      // s = pose * p_frame; exp(xi) moves it by omega x s + v.
      const Eigen::Vector3d s = r * p_frame_.col(k) + t;
      Eigen::Matrix<double, 3, 6> ds;
      ds << -Skew(s), Eigen::Matrix3d::Identity();
      add(*node_view_, node_view_->rect_R_points * s, node_view_->rect_R_points * ds, k);
    }
    if (frame_view_) {
      // s = pose^-1 * p_node; pose^-1 exp(-xi) moves it by R^T (p x omega - v).
      const Eigen::Vector3d p = p_node_.col(k);
      const Eigen::Vector3d s = r.transpose() * (p - t);
      Eigen::Matrix<double, 3, 6> ds;
      ds << r.transpose() * Skew(p), -r.transpose();
      add(*frame_view_, frame_view_->rect_R_points * s, frame_view_->rect_R_points * ds, k);
    }
  }
  return normal;
}

Se3 StereoReprojection::Refine(const Se3& node_T_frame, const std::vector<int>& inliers) const {
  Se3 pose = node_T_frame;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    const Normal normal = Linearise(pose, inliers);
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal.h);
    if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-12)) break;
    const Eigen::Matrix<double, 6, 1> xi = -solver.solve(normal.g);
    if (!xi.allFinite()) break;
    Se3 step = Se3::Identity();
    const Eigen::Vector3d omega = xi.head<3>();
    const double angle = omega.norm();
    if (angle > 0) step.linear() = Eigen::AngleAxisd(angle, omega / angle).toRotationMatrix();
    step.translation() = xi.tail<3>();
    pose = step * pose;
    if (xi.squaredNorm() < kConverged) break;
  }
  return pose;
}

PoseCovariance StereoReprojection::Covariance(const Se3& node_T_frame,
                                              const std::vector<int>& inliers) const {
  const Normal normal = Linearise(node_T_frame, inliers);
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(normal.h);
  if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-12)) {
    return PoseCovariance::Identity() * 1e6;  // a fit that fixes no pose: no information
  }
  const int dof = normal.residuals - 6;
  const double variance = dof > 0 ? normal.squared / dof : 1.0;
  return variance * solver.solve(Eigen::Matrix<double, 6, 6>::Identity());
}

}  // namespace fleetmap
