#include "fleetmap/ebn/localiser.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/descriptor_matcher.h"
#include "fleetmap/ebn/hamming.h"
#include "stereo_reprojection.h"

namespace fleetmap {
namespace {

// A minimal sample whose triangle is thinner than this (smallest altitude, either side) fixes
// no rotation about its long side: collinear or coincident points. Landmarks are metres apart.
constexpr double kMinSampleAltitude_m = 0.01;

// Refit-and-recount rounds after RANSAC; the inlier set usually settles after one or two.
constexpr int kMaxRefinements = 5;

// Uniform draw from [0, n) by rejection. std::uniform_int_distribution is not specified
// exactly, so it could differ between standard libraries; this keeps a seed's result portable.
std::uint32_t DrawBelow(std::mt19937& rng, std::uint32_t n) {
  const std::uint32_t limit = std::uint32_t{0xffffffff} - std::uint32_t{0xffffffff} % n;
  std::uint32_t r = 0;
  do {
    r = static_cast<std::uint32_t>(rng());
  } while (r >= limit);
  return r % n;
}

bool IsDegenerate(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const double longest = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()});
  if (longest <= 0.0) return true;
  return (b - a).cross(c - a).norm() / longest < kMinSampleAltitude_m;
}

// Rigid fit dst ~ T * src over corresponding columns (least squares, no scale).
Se3 FitRigid(const Eigen::Matrix3Xd& src, const Eigen::Matrix3Xd& dst) {
  Se3 dst_T_src = Se3::Identity();
  dst_T_src.matrix() = Eigen::umeyama(src, dst, /*with_scaling=*/false);
  return dst_T_src;
}

// The matched point pairs of one localisation attempt, column k holding match k.
struct Correspondences {
  Eigen::Matrix3Xd p_frame;
  Eigen::Matrix3Xd p_node;

  int size() const { return static_cast<int>(p_frame.cols()); }
};

std::vector<int> Inliers(const Correspondences& c, const Se3& node_T_frame, double threshold_m) {
  const Eigen::RowVectorXd squared_residual =
      ((node_T_frame.linear() * c.p_frame).colwise() + node_T_frame.translation() - c.p_node)
          .colwise()
          .squaredNorm();
  std::vector<int> inliers;
  const double threshold_sq = threshold_m * threshold_m;
  for (int k = 0; k < c.size(); ++k) {
    if (squared_residual[k] < threshold_sq) inliers.push_back(k);
  }
  return inliers;
}

Se3 FitInliers(const Correspondences& c, const std::vector<int>& inliers) {
  const auto n = static_cast<Eigen::Index>(inliers.size());
  Eigen::Matrix3Xd src(3, n);
  Eigen::Matrix3Xd dst(3, n);
  for (Eigen::Index k = 0; k < n; ++k) {
    src.col(k) = c.p_frame.col(inliers[static_cast<std::size_t>(k)]);
    dst.col(k) = c.p_node.col(inliers[static_cast<std::size_t>(k)]);
  }
  return FitRigid(src, dst);
}

// Standard adaptive RANSAC bound for three-point samples; the caller keeps the cap.
int SamplesNeeded(std::size_t inliers, std::uint32_t matches, double confidence) {
  if (confidence <= 0.0) return std::numeric_limits<int>::max();
  const double w = static_cast<double>(inliers) / matches;
  const double all_inliers = w * w * w;
  if (all_inliers >= 1.0) return 1;
  if (all_inliers <= 0.0) return std::numeric_limits<int>::max();
  const double needed = std::ceil(std::log(1.0 - confidence) / std::log(1.0 - all_inliers));
  return needed >= std::numeric_limits<int>::max() ? std::numeric_limits<int>::max()
                                                   : static_cast<int>(needed);
}

void CheckConsistent(const Landmarks& landmarks, const char* what) {
  if (landmarks.points_camera.size() != landmarks.descriptors.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string("localise: ") + what + " has " +
                    std::to_string(landmarks.points_camera.size()) + " points but " +
                    std::to_string(landmarks.descriptors.size()) + " descriptors");
  }
  if (!landmarks.levels.empty() && landmarks.levels.size() != landmarks.size()) {
    throw Error(ErrorCode::kInvalidArgument,
                std::string("localise: ") + what + " has " + std::to_string(landmarks.size()) +
                    " points but " + std::to_string(landmarks.levels.size()) + " pyramid levels");
  }
  for (const std::uint8_t level : landmarks.levels) {
    if (level > Landmarks::kMaxLevel) {
      throw Error(ErrorCode::kInvalidArgument, std::string("localise: ") + what +
                                                   " has a pyramid level above " +
                                                   std::to_string(Landmarks::kMaxLevel));
    }
  }
}

// Each match's pixel noise in one view (stereo_reprojection.h): level_scale^level of the
// keypoint it was measured at; empty (all 1) when the landmarks carry no levels.
Eigen::VectorXd MatchSigmas(const Landmarks& landmarks, const std::vector<DescriptorMatch>& matches,
                            bool frame_side) {
  if (landmarks.levels.empty() || !landmarks.stereo) return {};
  std::array<double, Landmarks::kMaxLevel + 1> sigma_of_level{};
  sigma_of_level[0] = 1.0;
  for (std::size_t l = 1; l < sigma_of_level.size(); ++l) {
    sigma_of_level[l] = sigma_of_level[l - 1] * landmarks.stereo->level_scale;
  }
  Eigen::VectorXd sigma(static_cast<Eigen::Index>(matches.size()));
  for (std::size_t k = 0; k < matches.size(); ++k) {
    const int index = frame_side ? matches[k].query_index : matches[k].train_index;
    sigma(static_cast<Eigen::Index>(k)) =
        sigma_of_level[landmarks.levels[static_cast<std::size_t>(index)]];
  }
  return sigma;
}

// The covariance of a rigid fit's node_T_frame from its point residuals (pose_covariance.h's
// left perturbation): each inlier's residual r = exp(xi) T p_frame - p_node moves by
// d r / d xi = [-[q]x, I] with q = T p_frame; the residuals' variance per coordinate is
// estimated from their sum of squares over 3 n - 6 degrees of freedom.
PoseCovariance PointCovariance(const Correspondences& c, const Se3& node_T_frame,
                               const std::vector<int>& inliers) {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double squared = 0.0;
  for (const int k : inliers) {
    const Eigen::Vector3d q = node_T_frame * Eigen::Vector3d(c.p_frame.col(k));
    squared += (q - c.p_node.col(k)).squaredNorm();
    Eigen::Matrix<double, 3, 6> j;
    j << 0, q.z(), -q.y(), 1, 0, 0,  //
        -q.z(), 0, q.x(), 0, 1, 0,   //
        q.y(), -q.x(), 0, 0, 0, 1;
    information.noalias() += j.transpose() * j;
  }
  const double dof = 3.0 * static_cast<double>(inliers.size()) - 6.0;
  const double variance = dof > 0 ? squared / dof : 0.0;
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> solver(information);
  if (solver.info() != Eigen::Success || !(solver.rcond() > 1e-12)) {
    return PoseCovariance::Identity() * 1e6;  // a fit that fixes no pose: no information
  }
  return variance * solver.solve(Eigen::Matrix<double, 6, 6>::Identity());
}

// Guided matches for Register: frame point i, carried into the node by the prior, against the
// node points within its gate; the nearest descriptor wins when it is within
// guided_max_distance and passes the ratio test against the gate's runner-up; a node point
// claimed twice goes to the nearer descriptor (ties to the lower frame index).
std::vector<DescriptorMatch> GuidedMatches(const Landmarks& frame, const Landmarks& node,
                                           const Se3& prior, const PoseCovariance& covariance,
                                           const LocaliserOptions& options) {
  std::vector<DescriptorMatch> chosen(node.size());
  for (DescriptorMatch& m : chosen) m.distance = std::numeric_limits<int>::max();
  for (std::size_t i = 0; i < frame.size(); ++i) {
    const Eigen::Vector3d q = prior * frame.points_camera[i].cast<double>();
    Se3 node_T_point = Se3::Identity();
    node_T_point.translation() = q;
    double gate = options.guided_gate_sigmas * PositionSigma(node_T_point, covariance) +
                  options.inlier_threshold_m;
    if (frame.stereo || node.stereo) {
      // A stereo point's own depth error grows as depth^2 / (focal baseline) per pixel.
      const StereoCamera& camera = node.stereo ? *node.stereo : *frame.stereo;
      gate += options.guided_gate_sigmas * q.z() * q.z() / (camera.focal_px * camera.baseline_m);
    }
    const double gate_sq = gate * gate;
    int best = -1, best_distance = 257, second = 257;
    for (std::size_t j = 0; j < node.size(); ++j) {
      if ((node.points_camera[j].cast<double>() - q).squaredNorm() > gate_sq) continue;
      const int d = HammingDistance(frame.descriptors[i], node.descriptors[j]);
      if (d < best_distance) {
        second = best_distance;
        best_distance = d;
        best = static_cast<int>(j);
      } else if (d < second) {
        second = d;
      }
    }
    if (best < 0 || best_distance > options.guided_max_distance) continue;
    if (second <= 256 && !(best_distance < options.ratio * second)) continue;
    DescriptorMatch& slot = chosen[static_cast<std::size_t>(best)];
    if (best_distance < slot.distance) {
      slot = {static_cast<int>(i), best, best_distance};
    }
  }
  std::vector<DescriptorMatch> matches;
  for (const DescriptorMatch& m : chosen) {
    if (m.query_index >= 0) matches.push_back(m);
  }
  std::sort(matches.begin(), matches.end(), [](const DescriptorMatch& a, const DescriptorMatch& b) {
    return a.query_index < b.query_index;
  });
  return matches;
}

}  // namespace

Localiser::Localiser(const LocaliserOptions& options) : options_(options) {
  const auto fail = [](const std::string& what) {
    throw Error(ErrorCode::kInvalidArgument, "localiser options: " + what);
  };
  if (!(options.ratio > 0.0 && options.ratio <= 1.0)) fail("ratio must be in (0, 1]");
  if (options.max_distance < 0 || options.max_distance > 256) {
    fail("max_distance must be in [0, 256]");
  }
  if (options.ransac_iterations < 1) fail("ransac_iterations must be >= 1");
  if (!(options.ransac_confidence >= 0.0 && options.ransac_confidence < 1.0)) {
    fail("ransac_confidence must be in [0, 1)");
  }
  if (!(options.inlier_threshold_m > 0.0)) fail("inlier_threshold_m must be > 0");
  if (!(options.reprojection_threshold_px > 0.0)) fail("reprojection_threshold_px must be > 0");
  if (options.min_inliers < 3) fail("min_inliers must be >= 3");
  if (!(options.guided_gate_sigmas > 0.0)) fail("guided_gate_sigmas must be > 0");
  if (options.guided_max_distance < 0 || options.guided_max_distance > 256) {
    fail("guided_max_distance must be in [0, 256]");
  }
}

LocalisationResult Localiser::Localise(const Landmarks& frame, const Landmarks& node) const {
  CheckConsistent(frame, "frame");
  CheckConsistent(node, "node");
  return Solve(frame, node,
               MatchDescriptors(frame.descriptors, node.descriptors,
                                {.ratio = options_.ratio, .max_distance = options_.max_distance}));
}

LocalisationResult Localiser::Register(const Landmarks& frame, const Landmarks& node,
                                       const Se3& prior_node_T_frame,
                                       const PoseCovariance& prior_covariance) const {
  CheckConsistent(frame, "frame");
  CheckConsistent(node, "node");
  if (!prior_node_T_frame.matrix().allFinite() || !IsValidPoseCovariance(prior_covariance)) {
    throw Error(ErrorCode::kInvalidArgument,
                "register: the prior pose or its covariance is not finite and positive");
  }
  return Solve(frame, node,
               GuidedMatches(frame, node, prior_node_T_frame, prior_covariance, options_));
}

LocalisationResult Localiser::Solve(const Landmarks& frame, const Landmarks& node,
                                    const std::vector<DescriptorMatch>& matches) const {
  LocalisationResult result;
  result.matches = static_cast<int>(matches.size());
  if (result.matches < options_.min_inliers) return result;  // cannot succeed; min_inliers >= 3

  Correspondences c{Eigen::Matrix3Xd(3, result.matches), Eigen::Matrix3Xd(3, result.matches)};
  for (int k = 0; k < result.matches; ++k) {
    const DescriptorMatch& m = matches[static_cast<std::size_t>(k)];
    c.p_frame.col(k) = frame.points_camera[static_cast<std::size_t>(m.query_index)].cast<double>();
    c.p_node.col(k) = node.points_camera[static_cast<std::size_t>(m.train_index)].cast<double>();
  }

  // Which residual judges a hypothesis (localiser.h): pixels when a stereo camera is known.
  std::optional<StereoReprojection> stereo;
  if (frame.stereo || node.stereo) {
    stereo.emplace(c.p_frame, c.p_node, frame.stereo, node.stereo,
                   MatchSigmas(frame, matches, /*frame_side=*/true),
                   MatchSigmas(node, matches, /*frame_side=*/false));
    result.stereo_residuals = true;
  }
  const auto inliers_of = [&](const Se3& node_T_frame) {
    return stereo ? stereo->Inliers(node_T_frame, options_.reprojection_threshold_px)
                  : Inliers(c, node_T_frame, options_.inlier_threshold_m);
  };

  // RANSAC: keep the first hypothesis with the most inliers.
  std::mt19937 rng(options_.seed);
  const auto n = static_cast<std::uint32_t>(c.size());
  Se3 best = Se3::Identity();
  std::vector<int> best_inliers;
  int iterations_needed = options_.ransac_iterations;
  for (int iteration = 0; iteration < iterations_needed; ++iteration) {
    const std::uint32_t a = DrawBelow(rng, n);
    std::uint32_t b = DrawBelow(rng, n - 1);
    if (b >= a) ++b;
    std::uint32_t lo = std::min(a, b);
    std::uint32_t hi = std::max(a, b);
    std::uint32_t s = DrawBelow(rng, n - 2);  // skip the two taken, in increasing order
    if (s >= lo) ++s;
    if (s >= hi) ++s;
    const int sample[3] = {static_cast<int>(a), static_cast<int>(b), static_cast<int>(s)};

    Eigen::Matrix3d src;
    Eigen::Matrix3d dst;
    for (int k = 0; k < 3; ++k) {
      src.col(k) = c.p_frame.col(sample[k]);
      dst.col(k) = c.p_node.col(sample[k]);
    }
    if (IsDegenerate(src.col(0), src.col(1), src.col(2)) ||
        IsDegenerate(dst.col(0), dst.col(1), dst.col(2))) {
      continue;
    }
    const Se3 hypothesis = FitRigid(src, dst);
    std::vector<int> inliers = inliers_of(hypothesis);
    if (inliers.size() > best_inliers.size()) {
      best = hypothesis;
      best_inliers = std::move(inliers);
      iterations_needed = std::min(
          iterations_needed, SamplesNeeded(best_inliers.size(), n, options_.ransac_confidence));
    }
  }

  // Refine: refit on all inliers and recount (options.least_squares_result says which refit
  // stands). The reported count is always that of the reported transform.
  // In stereo mode the refinement is Gauss-Newton in pixels and always stands: it is the fit the
  // noise model asks for, and the three-point hypothesis is only its starting point.
  const bool keep_refit = stereo || options_.least_squares_result;
  for (int round = 0; round < kMaxRefinements && best_inliers.size() >= 3; ++round) {
    const Se3 refined = stereo ? stereo->Refine(best, best_inliers) : FitInliers(c, best_inliers);
    std::vector<int> inliers = inliers_of(refined);
    if (!keep_refit && inliers.size() < best_inliers.size()) break;
    if (stereo && inliers.size() < 3) break;  // a refinement that ran away; keep the last
    const bool settled =
        keep_refit ? inliers == best_inliers : inliers.size() == best_inliers.size();
    best = refined;
    best_inliers = std::move(inliers);
    if (settled) break;
  }

  result.inliers = static_cast<int>(best_inliers.size());
  result.success = result.inliers >= options_.min_inliers;
  if (result.success) {
    result.node_T_frame = best;
    result.covariance =
        stereo ? stereo->Covariance(best, best_inliers) : PointCovariance(c, best, best_inliers);
  }
  return result;
}

}  // namespace fleetmap
