// The EBN localiser and what it stands on: Hamming kernels, descriptor matching, RANSAC.
#include "fleetmap/ebn/localiser.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <set>
#include <tuple>

#include "fleetmap/core/error.h"
#include "fleetmap/ebn/descriptor_matcher.h"
#include "fleetmap/ebn/hamming.h"
#include "landmark_scene.h"

namespace fleetmap {
namespace {

using testing::MakeDescriptorSets;
using testing::MakeLandmarkScene;
using testing::RandomDescriptors;
using testing::SceneSpec;

// --- Hamming kernels -------------------------------------------------------------------------

// Straight from the definition: sort every candidate by (distance, index).
HammingNeighbours ReferenceNeighbours(const std::vector<Descriptor256>& queries,
                                      const std::vector<Descriptor256>& train) {
  HammingNeighbours out;
  out.per_query.resize(queries.size());
  out.per_train.resize(train.size());
  for (std::size_t i = 0; i < queries.size(); ++i) {
    std::vector<std::pair<int, int>> ranked;  // (distance, index)
    for (std::size_t j = 0; j < train.size(); ++j) {
      ranked.emplace_back(HammingDistance(queries[i], train[j]), static_cast<int>(j));
    }
    std::sort(ranked.begin(), ranked.end());
    if (ranked.size() > 0) out.per_query[i].best = {ranked[0].second, ranked[0].first};
    if (ranked.size() > 1) out.per_query[i].second = {ranked[1].second, ranked[1].first};
  }
  for (std::size_t j = 0; j < train.size(); ++j) {
    for (std::size_t i = 0; i < queries.size(); ++i) {
      const int d = HammingDistance(queries[i], train[j]);
      if (d < out.per_train[j].distance) out.per_train[j] = {static_cast<int>(i), d};
    }
  }
  return out;
}

TEST(Hamming, DistanceCountsDifferingBits) {
  std::mt19937 rng(1);
  const Descriptor256 a = testing::RandomDescriptor(rng);
  Descriptor256 complement;
  for (std::size_t b = 0; b < a.size(); ++b) complement[b] = static_cast<std::uint8_t>(~a[b]);
  EXPECT_EQ(HammingDistance(a, a), 0);
  EXPECT_EQ(HammingDistance(a, complement), 256);
  EXPECT_EQ(HammingDistance(a, testing::FlipBits(a, 37, rng)), 37);
}

// Sizes around the AVX2 kernel's eight-lane steps, and low-entropy descriptors (only the first
// byte random) so that most distances tie and tie-breaking is exercised. On a CPU without AVX2
// the scalar kernel and the fallback are still checked, not skipped (a skipped test fails the
// run, scripts/test).
TEST(Hamming, KernelsAgreeWithDefinition) {
  const bool avx2 = HammingKernelAvailable(HammingKernel::kAvx2);
  if (!avx2) {
    EXPECT_EQ(SelectedHammingKernel(), HammingKernel::kScalar);
    std::printf("[ note ] CPU without AVX2: the AVX2 kernel is not compared here\n");
  }
  const std::vector<std::pair<std::size_t, std::size_t>> sizes = {
      {0, 5}, {5, 0}, {1, 1}, {2, 1}, {1, 2}, {3, 7}, {9, 8}, {17, 9}, {100, 203}, {500, 500}};
  std::uint32_t seed = 1;
  for (const auto& [n, m] : sizes) {
    for (const bool low_entropy : {false, true}) {
      auto sets = MakeDescriptorSets(n, m, std::min(n, m) / 3, 12, seed++);
      if (low_entropy) {
        for (auto* set : {&sets.queries, &sets.train}) {
          for (auto& d : *set) std::fill(d.begin() + 1, d.end(), 0);
        }
      }
      SCOPED_TRACE(::testing::Message() << n << " x " << m << (low_entropy ? " ties" : ""));
      const HammingNeighbours scalar =
          FindHammingNeighbours(sets.queries, sets.train, HammingKernel::kScalar);
      EXPECT_EQ(scalar, ReferenceNeighbours(sets.queries, sets.train));
      EXPECT_EQ(FindHammingNeighbours(sets.queries, sets.train), scalar);  // kAuto
      if (avx2) {
        EXPECT_EQ(FindHammingNeighbours(sets.queries, sets.train, HammingKernel::kAvx2), scalar);
      }
    }
  }
}

// --- Descriptor matching ---------------------------------------------------------------------

MatchOptions CrossCheckOnly() {
  return {.ratio = 1.0, .max_distance = 256};
}

TEST(DescriptorMatcher, CrossCheckEqualsOpenCvBruteForce) {
  for (std::uint32_t seed = 1; seed <= 5; ++seed) {
    const auto sets = MakeDescriptorSets(500, 500, 150, 40, seed);
    std::set<std::tuple<int, int, int>> ours;
    for (const DescriptorMatch& m : MatchDescriptors(sets.queries, sets.train, CrossCheckOnly())) {
      ours.emplace(m.query_index, m.train_index, m.distance);
    }

    // cv::Mat views of the descriptor arrays: one row of 32 bytes per descriptor.
    const cv::Mat query_mat(500, 32, CV_8U, const_cast<Descriptor256*>(sets.queries.data()));
    const cv::Mat train_mat(500, 32, CV_8U, const_cast<Descriptor256*>(sets.train.data()));
    std::vector<cv::DMatch> cv_matches;
    cv::BFMatcher(cv::NORM_HAMMING, /*crossCheck=*/true).match(query_mat, train_mat, cv_matches);
    std::set<std::tuple<int, int, int>> theirs;
    for (const cv::DMatch& m : cv_matches) {
      theirs.emplace(m.queryIdx, m.trainIdx, static_cast<int>(std::lround(m.distance)));
    }

    SCOPED_TRACE(::testing::Message() << "seed " << seed);
    EXPECT_GE(ours.size(), 150u);  // at least the planted pairs
    EXPECT_EQ(ours, theirs);

    // The data is not tie-free: some mutual bests tie with the query's runner-up, so the
    // equality above also pins down tie-breaking (lowest index, as OpenCV's strict <).
    const HammingNeighbours neighbours = FindHammingNeighbours(sets.queries, sets.train);
    int tied = 0;
    for (const auto& [query, train, distance] : ours) {
      tied += neighbours.per_query[static_cast<std::size_t>(query)].second.distance == distance;
    }
    EXPECT_GT(tied, 0);
  }
}

TEST(DescriptorMatcher, KeepsOnlyMutualBest) {
  std::mt19937 rng(3);
  const Descriptor256 t = testing::RandomDescriptor(rng);
  // Both queries are nearest to the one train descriptor; only the closer is its nearest.
  const std::vector<Descriptor256> queries = {testing::FlipBits(t, 9, rng),
                                              testing::FlipBits(t, 4, rng)};
  const std::vector<Descriptor256> train = {t};
  const auto matches = MatchDescriptors(queries, train, CrossCheckOnly());
  ASSERT_EQ(matches.size(), 1u);
  EXPECT_EQ(matches[0], (DescriptorMatch{1, 0, 4}));
}

TEST(DescriptorMatcher, RatioTestRejectsAmbiguousQueries) {
  std::mt19937 rng(4);
  const Descriptor256 q = testing::RandomDescriptor(rng);
  const std::vector<Descriptor256> queries = {q};
  // Equidistant train descriptors: a tie, which goes to the lower index without the ratio test.
  const std::vector<Descriptor256> tied = {testing::FlipBits(q, 10, rng),
                                           testing::FlipBits(q, 10, rng)};
  EXPECT_TRUE(MatchDescriptors(queries, tied).empty());
  const auto without_ratio = MatchDescriptors(queries, tied, CrossCheckOnly());
  ASSERT_EQ(without_ratio.size(), 1u);
  EXPECT_EQ(without_ratio[0].train_index, 0);

  // 8 < 0.8 x 12 passes; 8 < 0.8 x 10 does not.
  Descriptor256 at8 = q, at10 = q, at12 = q;
  for (int bit = 0; bit < 12; ++bit) {
    const auto byte = static_cast<std::size_t>(bit);  // one bit in each of the first bytes
    if (bit < 8) at8[byte] ^= 1;
    if (bit < 10) at10[byte] ^= 1;
    at12[byte] ^= 1;
  }
  EXPECT_EQ(MatchDescriptors(queries, std::vector<Descriptor256>{at8, at12}).size(), 1u);
  EXPECT_TRUE(MatchDescriptors(queries, std::vector<Descriptor256>{at8, at10}).empty());
}

TEST(DescriptorMatcher, MaxDistanceIsInclusive) {
  std::mt19937 rng(5);
  const Descriptor256 q = testing::RandomDescriptor(rng);
  const std::vector<Descriptor256> queries = {q};
  EXPECT_EQ(
      MatchDescriptors(queries, std::vector<Descriptor256>{testing::FlipBits(q, 80, rng)}).size(),
      1u);
  EXPECT_TRUE(
      MatchDescriptors(queries, std::vector<Descriptor256>{testing::FlipBits(q, 81, rng)}).empty());
}

TEST(DescriptorMatcher, EmptySetsGiveNoMatches) {
  std::mt19937 rng(6);
  const auto some = RandomDescriptors(10, rng);
  EXPECT_TRUE(MatchDescriptors({}, some).empty());
  EXPECT_TRUE(MatchDescriptors(some, {}).empty());
  EXPECT_TRUE(MatchDescriptors({}, {}).empty());
}

TEST(DescriptorMatcher, RejectsBadOptions) {
  EXPECT_THROW(MatchDescriptors({}, {}, {.ratio = 0.0}), Error);
  EXPECT_THROW(MatchDescriptors({}, {}, {.ratio = 1.5}), Error);
  EXPECT_THROW(MatchDescriptors({}, {}, {.max_distance = 257}), Error);
}

// --- Localiser -------------------------------------------------------------------------------

// About 20 degrees about a tilted axis, about 1 m of translation.
Se3 KnownNodeTFrame() {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.linear() =
      Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d(0.3, 1.0, 0.2).normalized())
          .toRotationMatrix();
  node_T_frame.translation() = Eigen::Vector3d(0.6, -0.3, 0.7);
  return node_T_frame;
}

// Half the frame's matches are wrong correspondences (right descriptor, wrong place); a further
// hundred landmarks have descriptors the node does not know.
SceneSpec HalfOutliers() {
  return {
      .node_landmarks = 500, .true_matches = 200, .wrong_matches = 200, .random_landmarks = 100};
}

TEST(Localiser, RecoversKnownTransformWithHalfOutliers) {
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  const LocalisationResult result = Localiser().Localise(scene.frame, scene.node);
  ASSERT_TRUE(result.success);
  EXPECT_EQ(result.matches, 400);
  EXPECT_GE(result.inliers, 195);
  EXPECT_LE(result.inliers, 205);
  const Se3 error = scene.node_T_frame.inverse() * result.node_T_frame;
  EXPECT_LT(error.translation().norm(), 0.01);
  EXPECT_LT(RotationAngle(error), 0.5 * M_PI / 180.0);
}

// Stereo landmarks are far less certain in depth than across the image (depth error grows as
// z^2 / (f B)), and a small motion leaves many three-point hypotheses within the inlier
// threshold of most matches. With least_squares_result the reported pose is the least-squares
// fit of its inliers, not whichever three-point hypothesis found them: otherwise visual
// odometry of a standing camera drifts by centimetres a frame (seen on the EuRoC pairs).
TEST(Localiser, SmallMotionWithDepthNoiseIsTheLeastSquaresFit) {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.translate(Eigen::Vector3d(0.01, -0.005, 0.02));
  node_T_frame.rotate(Eigen::AngleAxisd(0.005, Eigen::Vector3d(0.3, 1.0, 0.1).normalized()));
  for (std::uint32_t seed = 1; seed <= 20; ++seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> lateral(-1.0, 1.0), depth(1.0, 4.0);
    Landmarks node, frame;
    for (int k = 0; k < 300; ++k) {
      const double z = depth(rng);
      const Eigen::Vector3d p_node(lateral(rng) * z, 0.6 * lateral(rng) * z, z);
      // 2 % of depth along the ray, a millimetre or two across it: stereo's error shape.
      std::normal_distribution<double> along(0.0, 0.02 * z / 2), across(0.0, 0.001 * z);
      const Eigen::Vector3d ray = p_node.normalized();
      const Eigen::Vector3d noisy =
          p_node + ray * along(rng) + Eigen::Vector3d(across(rng), across(rng), 0.0);
      node.points_camera.push_back(noisy.cast<float>());
      const Eigen::Vector3d p_frame = node_T_frame.inverse() * p_node;
      const Eigen::Vector3d ray_frame = p_frame.normalized();
      frame.points_camera.push_back(
          (p_frame + ray_frame * along(rng) + Eigen::Vector3d(across(rng), across(rng), 0.0))
              .cast<float>());
      const Descriptor256 d = testing::RandomDescriptor(rng);
      node.descriptors.push_back(d);
      frame.descriptors.push_back(d);
    }
    const LocalisationResult r =
        Localiser({.inlier_threshold_m = 0.08, .least_squares_result = true}).Localise(frame, node);
    ASSERT_TRUE(r.success) << "seed " << seed;
    const Se3 error = node_T_frame.inverse() * r.node_T_frame;
    EXPECT_LT(error.translation().norm(), 0.01) << "seed " << seed;
    EXPECT_LT(RotationAngle(error), 0.003) << "seed " << seed;
  }
}

TEST(Localiser, SameSeedSameResult) {
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  const LocaliserOptions options{.ransac_iterations = 50, .seed = 1234};
  const LocalisationResult a = Localiser(options).Localise(scene.frame, scene.node);
  const Localiser localiser(options);
  localiser.Localise(scene.frame, scene.node);  // an earlier call must not matter
  const LocalisationResult b = localiser.Localise(scene.frame, scene.node);
  EXPECT_EQ(a.success, b.success);
  EXPECT_EQ(a.inliers, b.inliers);
  EXPECT_EQ(a.matches, b.matches);
  EXPECT_EQ(a.node_T_frame.matrix(), b.node_T_frame.matrix());  // bit for bit
}

TEST(Localiser, AdaptiveStopKeepsTheExhaustiveAnswer) {
  // Stopping once an all-inlier sample is 99.9 % certain must find the same consensus as
  // drawing every one of the 200 samples.
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  const LocalisationResult adaptive = Localiser().Localise(scene.frame, scene.node);
  const LocalisationResult exhaustive =
      Localiser({.ransac_confidence = 0.0}).Localise(scene.frame, scene.node);
  ASSERT_TRUE(adaptive.success);
  ASSERT_TRUE(exhaustive.success);
  EXPECT_EQ(adaptive.inliers, exhaustive.inliers);
  EXPECT_TRUE(Se3ApproxEqual(adaptive.node_T_frame, exhaustive.node_T_frame, 1e-3, 1e-4));
  EXPECT_THROW(Localiser({.ransac_confidence = 1.0}), Error);
}

TEST(Localiser, UnrelatedNodeFails) {
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  std::mt19937 rng(99);
  Landmarks unrelated = scene.node;
  unrelated.descriptors = RandomDescriptors(unrelated.size(), rng);
  const LocalisationResult result = Localiser().Localise(scene.frame, unrelated);
  EXPECT_FALSE(result.success);
  EXPECT_LT(result.inliers, 12);
}

TEST(Localiser, EmptyInputsFailWithoutThrowing) {
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  const Localiser localiser;
  for (const auto& [frame, node] : {std::pair<Landmarks, Landmarks>{{}, scene.node},
                                    std::pair<Landmarks, Landmarks>{scene.frame, {}},
                                    std::pair<Landmarks, Landmarks>{{}, {}}}) {
    LocalisationResult result;
    EXPECT_NO_THROW(result = localiser.Localise(frame, node));
    EXPECT_FALSE(result.success);
    EXPECT_EQ(result.matches, 0);
    EXPECT_EQ(result.inliers, 0);
  }
}

TEST(Localiser, TooFewMatchesFail) {
  const auto scene = MakeLandmarkScene(
      KnownNodeTFrame(),
      {.node_landmarks = 50, .true_matches = 11, .wrong_matches = 0, .random_landmarks = 0});
  const LocalisationResult result = Localiser().Localise(scene.frame, scene.node);
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.matches, 11);
}

TEST(Localiser, CollinearLandmarksFail) {
  auto scene = MakeLandmarkScene(Se3::Identity(), {.node_landmarks = 100,
                                                   .true_matches = 100,
                                                   .wrong_matches = 0,
                                                   .random_landmarks = 0,
                                                   .point_noise_m = 0.0});
  // Every landmark on one line: no sample fixes a rotation about it.
  for (auto* points : {&scene.frame.points_camera, &scene.node.points_camera}) {
    for (auto& p : *points) p = Eigen::Vector3f(0.f, 0.f, p.z());
  }
  const LocalisationResult result = Localiser().Localise(scene.frame, scene.node);
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.matches, 100);
  EXPECT_EQ(result.inliers, 0);
}

TEST(Localiser, PointDescriptorCountMismatchThrows) {
  const auto scene = MakeLandmarkScene(KnownNodeTFrame(), HalfOutliers());
  Landmarks broken = scene.frame;
  broken.descriptors.pop_back();
  const Localiser localiser;
  for (const auto& [frame, node] : {std::pair{broken, scene.node}, std::pair{scene.node, broken}}) {
    try {
      localiser.Localise(frame, node);
      ADD_FAILURE() << "no exception";
    } catch (const Error& e) {
      EXPECT_EQ(e.code(), ErrorCode::kInvalidArgument);
    }
  }
}

TEST(Localiser, RejectsBadOptions) {
  EXPECT_THROW(Localiser({.ratio = 0.0}), Error);
  EXPECT_THROW(Localiser({.ransac_iterations = 0}), Error);
  EXPECT_THROW(Localiser({.inlier_threshold_m = 0.0}), Error);
  EXPECT_THROW(Localiser({.min_inliers = 2}), Error);
  EXPECT_THROW(Localiser({.guided_gate_sigmas = 0.0}), Error);
  EXPECT_THROW(Localiser({.guided_max_distance = 257}), Error);
}

// --- Guided registration ---------------------------------------------------------------------

// A place of repeating texture: 300 landmarks whose descriptors come from a pool of 15, each
// seen again from `node_T_frame` with 1 cm of noise and up to 8 bits flipped. The global
// matcher's ratio test finds nearly nothing distinctive; a pose prior narrows each point's
// search to the one landmark it can be.
struct RepeatingPlace {
  Landmarks node, frame;
};
RepeatingPlace MakeRepeatingPlace(const Se3& node_T_frame, std::uint32_t seed) {
  std::mt19937 rng(seed);
  const std::vector<Descriptor256> pool = RandomDescriptors(15, rng);
  std::uniform_real_distribution<double> lateral(-8.0, 8.0), depth(3.0, 20.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::uniform_int_distribution<int> flips(0, 8);
  RepeatingPlace place;
  for (int k = 0; k < 300; ++k) {
    const Eigen::Vector3d p_node(lateral(rng), 0.3 * lateral(rng), depth(rng));
    const Descriptor256& d = pool[static_cast<std::size_t>(k) % pool.size()];
    place.node.points_camera.push_back(p_node.cast<float>());
    place.node.descriptors.push_back(d);
    const Eigen::Vector3d p_frame = node_T_frame.inverse() * p_node;
    place.frame.points_camera.push_back(
        (p_frame + Eigen::Vector3d(noise(rng), noise(rng), noise(rng))).cast<float>());
    place.frame.descriptors.push_back(testing::FlipBits(d, flips(rng), rng));
  }
  return place;
}

PoseCovariance Isotropic(double rotation_rad, double translation_m) {
  PoseCovariance c = PoseCovariance::Zero();
  c.diagonal() << rotation_rad * rotation_rad, rotation_rad * rotation_rad,
      rotation_rad * rotation_rad, translation_m * translation_m, translation_m * translation_m,
      translation_m * translation_m;
  return c;
}

TEST(LocaliserRegister, APriorFindsWhatTheGlobalMatcherCannot) {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.translation() = Eigen::Vector3d(0.8, 0.0, 1.5);
  node_T_frame.rotate(Eigen::AngleAxisd(0.05, Eigen::Vector3d::UnitY()));
  const RepeatingPlace place = MakeRepeatingPlace(node_T_frame, 11);
  const Localiser localiser;
  EXPECT_FALSE(localiser.Localise(place.frame, place.node).success);
  // A prior 30 cm and 1 degree off, said to be about that uncertain.
  Se3 prior = node_T_frame;
  prior.translation() += Eigen::Vector3d(0.2, 0.0, -0.2);
  prior.rotate(Eigen::AngleAxisd(0.017, Eigen::Vector3d::UnitY()));
  const LocalisationResult result =
      localiser.Register(place.frame, place.node, prior, Isotropic(0.02, 0.3));
  ASSERT_TRUE(result.success);
  EXPECT_GE(result.inliers, 250);
  const Se3 error = node_T_frame.inverse() * result.node_T_frame;
  EXPECT_LT(error.translation().norm(), 0.01);
  EXPECT_LT(RotationAngle(error), 0.001);
  // The same prior claimed certain to a millimetre gates every point too tightly to find its
  // landmark: the gate follows the covariance.
  EXPECT_FALSE(localiser.Register(place.frame, place.node, prior, Isotropic(1e-5, 1e-3)).success);
}

// The covariance a registration reports is honest: over many noisy scenes, the error's
// Mahalanobis distance under it averages the six degrees of freedom of a pose.
TEST(LocaliserRegister, TheReportedCovarianceMatchesTheErrors) {
  Se3 node_T_frame = Se3::Identity();
  node_T_frame.translation() = Eigen::Vector3d(0.3, 0.1, 2.0);
  double sum = 0.0;
  int n = 0;
  for (std::uint32_t seed = 1; seed <= 60; ++seed) {
    const RepeatingPlace place = MakeRepeatingPlace(node_T_frame, seed);
    const LocalisationResult result =
        Localiser({.least_squares_result = true})
            .Register(place.frame, place.node, node_T_frame, Isotropic(0.02, 0.3));
    ASSERT_TRUE(result.success) << "seed " << seed;
    // The error as a left perturbation of the estimate: truth = exp(xi) estimate.
    const Se3 delta = node_T_frame * result.node_T_frame.inverse();
    Eigen::Matrix<double, 6, 1> xi;
    const Eigen::AngleAxisd angle(delta.linear());
    xi.head<3>() = angle.angle() * angle.axis();
    xi.tail<3>() = delta.translation();
    sum += xi.dot(result.covariance.ldlt().solve(xi));
    ++n;
  }
  const double mean = sum / n;
  EXPECT_GT(mean, 6.0 / 2.0);
  EXPECT_LT(mean, 6.0 * 2.0);
}

TEST(LocaliserRegister, RefusesANonFinitePrior) {
  const RepeatingPlace place = MakeRepeatingPlace(Se3::Identity(), 3);
  Se3 bad = Se3::Identity();
  bad.translation().x() = std::nan("");
  EXPECT_THROW(Localiser().Register(place.frame, place.node, bad, Isotropic(0.01, 0.1)), Error);
  EXPECT_THROW(
      Localiser().Register(place.frame, place.node, Se3::Identity(), -Isotropic(0.01, 0.1)), Error);
}

}  // namespace
}  // namespace fleetmap
