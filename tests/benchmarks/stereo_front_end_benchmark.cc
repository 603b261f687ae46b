// The real-image front end per stereo pair on the EuRoC sequence (stereo_front_end.h), beside
// the raw OpenCV work it is built on, in one run so the ratios hold on a noisy machine:
// - BM_OpenCvOrbBothImages: cv::ORB on the left then the right image, nothing else (the
//   baseline: what the front end cannot do without);
// - BM_StereoFrontEnd: ORB on both images (two threads), row matching with the left-right check
//   and sub-pixel refinement, triangulation: the figure the issue asks for, ms per pair;
// - BM_StereoRowMatching: the matching step alone, on keypoints found beforehand;
// - BM_Rectify: undistortion and rectification of both images (before the front end);
// - BM_VisualOdometry: one frame tracked from the previous (the localiser's match + RANSAC).
// All on the machine's cores (OpenCV's own threads too); run with --benchmark_min_time=2 for the
// closing figures.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <vector>

#include "fleetmap/experiments/euroc_sequence.h"
#include "fleetmap/experiments/stereo_front_end.h"
#include "fleetmap/experiments/visual_odometry.h"

namespace fleetmap {
namespace {

constexpr int kPairs = 20;  // a second of flight: enough variety, little loading

struct RealPairs {
  std::unique_ptr<StereoRectifier> rectifier;
  std::vector<cv::Mat> left_raw, right_raw, left, right;
};

const RealPairs& Pairs() {
  static const RealPairs pairs = [] {
    RealPairs p;
    const EurocSequence sequence = LoadEurocSequence(FLEETMAP_EUROC_DIR);
    p.rectifier = std::make_unique<StereoRectifier>(sequence.left, sequence.right);
    for (int i = 0; i < kPairs && i < static_cast<int>(sequence.pairs.size()); ++i) {
      const StereoPairFiles& files = sequence.pairs[static_cast<std::size_t>(i)];
      p.left_raw.push_back(ReadMonoImage(files.left_image, 752, 480));
      p.right_raw.push_back(ReadMonoImage(files.right_image, 752, 480));
      cv::Mat l, r;
      p.rectifier->Rectify(p.left_raw.back(), p.right_raw.back(), l, r);
      p.left.push_back(l);
      p.right.push_back(r);
    }
    return p;
  }();
  return pairs;
}

bool HaveData(benchmark::State& state) {
  if (std::string(FLEETMAP_EUROC_DIR).empty()) {
    state.SkipWithError(
        "the EuRoC sequence was not found at configure time; configure with "
        "-DFLEETMAP_EUROC_DIR=/path/to/euroc-v1_01-micro");
    return false;
  }
  return true;
}

void BM_OpenCvOrbBothImages(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  const StereoFrontEndOptions o;
  const cv::Ptr<cv::ORB> orb = CreateOrbDetector(o);
  std::size_t i = 0;
  for (auto _ : state) {
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    orb->detectAndCompute(p.left[i % p.left.size()], cv::noArray(), kl, dl);
    orb->detectAndCompute(p.right[i % p.right.size()], cv::noArray(), kr, dr);
    benchmark::DoNotOptimize(dr.data);
    ++i;
  }
}
BENCHMARK(BM_OpenCvOrbBothImages)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_StereoFrontEnd(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  const StereoFrontEnd front_end(p.rectifier->geometry(), StereoFrontEndOptions{});
  std::size_t i = 0;
  double landmarks = 0;
  for (auto _ : state) {
    const StereoFrontEndResult r =
        front_end.Process(0, p.left[i % p.left.size()], p.right[i % p.right.size()]);
    landmarks += static_cast<double>(r.frame.landmarks.size());
    ++i;
  }
  state.counters["landmarks"] = landmarks / static_cast<double>(i);
}
BENCHMARK(BM_StereoFrontEnd)->Unit(benchmark::kMillisecond)->UseRealTime();

// The matching step alone (row search, left-right check, sub-pixel refinement) on keypoints
// found beforehand.
void BM_StereoRowMatching(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  const StereoFrontEndOptions o;
  const cv::Ptr<cv::ORB> orb = CreateOrbDetector(o);
  std::vector<std::vector<cv::KeyPoint>> kl(p.left.size()), kr(p.left.size());
  std::vector<cv::Mat> dl(p.left.size()), dr(p.left.size());
  for (std::size_t i = 0; i < p.left.size(); ++i) {
    orb->detectAndCompute(p.left[i], cv::noArray(), kl[i], dl[i]);
    orb->detectAndCompute(p.right[i], cv::noArray(), kr[i], dr[i]);
  }
  std::size_t i = 0;
  for (auto _ : state) {
    const std::size_t k = i % p.left.size();
    benchmark::DoNotOptimize(
        MatchStereoRows(kl[k], dl[k], kr[k], dr[k], p.left[k], p.right[k], o.matching));
    ++i;
  }
}
BENCHMARK(BM_StereoRowMatching)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_Rectify(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  std::size_t i = 0;
  cv::Mat l, r;
  for (auto _ : state) {
    p.rectifier->Rectify(p.left_raw[i % p.left_raw.size()], p.right_raw[i % p.right_raw.size()], l,
                         r);
    benchmark::DoNotOptimize(r.data);
    ++i;
  }
}
BENCHMARK(BM_Rectify)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_VisualOdometry(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  const StereoFrontEnd front_end(p.rectifier->geometry(), StereoFrontEndOptions{});
  std::vector<Frame> frames;
  for (std::size_t i = 0; i < p.left.size(); ++i) {
    frames.push_back(front_end.Process(0, p.left[i], p.right[i]).frame);
  }
  const Localiser localiser(VisualOdometryOptions{}.localiser);
  std::size_t i = 1;
  for (auto _ : state) {
    const std::size_t k = i % (frames.size() - 1);
    benchmark::DoNotOptimize(localiser.Localise(frames[k + 1].landmarks, frames[k].landmarks));
    ++i;
  }
}
BENCHMARK(BM_VisualOdometry)->Unit(benchmark::kMillisecond)->UseRealTime();

}  // namespace
}  // namespace fleetmap

BENCHMARK_MAIN();
