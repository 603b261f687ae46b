// The real-image front end per stereo pair on the EuRoC sequence (stereo_front_end.h), beside
// the raw OpenCV work it is built on, in one run so the ratios hold on a noisy machine:
// - BM_OpenCvOrbBothImages: cv::ORB on the left then the right image, nothing else, one thread;
// - BM_OpenCvOrbTwoThreads: cv::ORB's detectAndCompute on both images with the front end's
//   detector (CreateOrbDetector: detect_oversampling x orb_features keypoints per image), one
//   image on a std::async thread, nothing else: ORB alone, the baseline of the front end's
//   acceptance lines (`fleetmap bench limits`). The front end does less ORB work than this on the
//   left image (it describes only the keypoints bucketing keeps) and the same on the right;
// - BM_OpenCvOrbKeptTwoThreads: the same with orb_features keypoints per image (no
//   oversampling): plain ORB giving as many keypoints as the front end keeps, for reference;
// - BM_StereoFrontEnd: ORB on both images (two threads), row matching with the left-right check
//   and sub-pixel refinement, triangulation: the headline figure, ms per pair;
// - BM_StereoRowMatching: the matching step alone, on keypoints found (and bucketed) beforehand;
// - BM_Rectify: undistortion and rectification of both images (before the front end);
// - BM_VisualOdometry: one frame tracked from the previous (the localiser's match + RANSAC).
// And the same baselines and the front end on the first pair of the KITTI odometry excerpt
// seq2 (1241 x 376, the acceptance line "front end <= 25 ms per 1241 x 376 pair on 2 cores,
// beside OpenCV's ORB alone on both images (same threads)"): BM_Kitti*.
// All on the machine's cores (OpenCV's own threads too); run with --benchmark_min_time=2 for the
// closing figures. On a loaded machine compare within one run with
// --benchmark_repetitions=5 --benchmark_enable_random_interleaving=true (medians), and read the
// cpu_ms counters (CPU time of every thread per pair) beside the wall times.
#include <benchmark/benchmark.h>

#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <future>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <utility>
#include <vector>

#include "fleetmap/stereo/euroc_sequence.h"
#include "fleetmap/stereo/stereo_front_end.h"
#include "fleetmap/stereo/stereo_sequence.h"
#include "fleetmap/stereo/visual_odometry.h"

namespace fleetmap {
namespace {

constexpr int kPairs = 20;  // a second of flight: enough variety, little loading

// CPU time of the whole process (every thread), so the work a step does can be compared when
// the machine is too loaded for wall times to mean much.
double ProcessCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}

// Reports, as counter cpu_ms, the CPU time of every thread per iteration since `start_ms`.
void ReportCpu(benchmark::State& state, double start_ms) {
  state.counters["cpu_ms"] =
      benchmark::Counter(ProcessCpuMs() - start_ms, benchmark::Counter::kAvgIterations);
}

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

// ORB alone on both images with the front end's detector settings: a detector per image, the
// right image's on a std::async thread while this one does the left, each detectAndCompute.
void OrbBothImagesTwoThreads(const StereoFrontEndOptions& o, const cv::Mat& left,
                             const cv::Mat& right) {
  std::future<cv::Mat> right_future = std::async(std::launch::async, [&] {
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
    CreateOrbDetector(o)->detectAndCompute(right, cv::noArray(), keypoints, descriptors);
    return descriptors;
  });
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  CreateOrbDetector(o)->detectAndCompute(left, cv::noArray(), keypoints, descriptors);
  benchmark::DoNotOptimize(descriptors.data);
  benchmark::DoNotOptimize(right_future.get().data);
}

// ORB on both images of the EuRoC pairs in turn, two threads, as `o` sets it.
void RunOrbTwoThreads(benchmark::State& state, const StereoFrontEndOptions& o) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  std::size_t i = 0;
  const double cpu_start_ms = ProcessCpuMs();
  for (auto _ : state) {
    OrbBothImagesTwoThreads(o, p.left[i % p.left.size()], p.right[i % p.right.size()]);
    ++i;
  }
  ReportCpu(state, cpu_start_ms);
}

void BM_OpenCvOrbTwoThreads(benchmark::State& state) {
  RunOrbTwoThreads(state, StereoFrontEndOptions{});
}
BENCHMARK(BM_OpenCvOrbTwoThreads)->Unit(benchmark::kMillisecond)->UseRealTime();

// ORB detecting only as many keypoints per image as the front end keeps on the left.
StereoFrontEndOptions KeptCountOnly(StereoFrontEndOptions o) {
  o.detect_oversampling = 1.0;
  return o;
}

void BM_OpenCvOrbKeptTwoThreads(benchmark::State& state) {
  RunOrbTwoThreads(state, KeptCountOnly(StereoFrontEndOptions{}));
}
BENCHMARK(BM_OpenCvOrbKeptTwoThreads)->Unit(benchmark::kMillisecond)->UseRealTime();

// Landmarks per pair and where the front end's own clock says the time went (its ORB stage
// includes the left image's bucketing), averaged over the iterations, as counters.
struct StageTimes {
  double landmarks = 0, orb_ms = 0, matching_ms = 0;
  int runs = 0;
  void Add(const StereoFrontEndResult& r) {
    landmarks += static_cast<double>(r.frame.landmarks.size());
    orb_ms += r.timings.orb_ms;
    matching_ms += r.timings.matching_ms;
    ++runs;
  }
  void Report(benchmark::State& state) const {
    if (runs == 0) return;
    state.counters["landmarks"] = landmarks / runs;
    state.counters["orb_ms"] = orb_ms / runs;
    state.counters["matching_ms"] = matching_ms / runs;
  }
};

void BM_StereoFrontEnd(benchmark::State& state) {
  if (!HaveData(state)) return;
  const RealPairs& p = Pairs();
  const StereoFrontEnd front_end(p.rectifier->geometry(), StereoFrontEndOptions{});
  std::size_t i = 0;
  StageTimes times;
  const double cpu_start_ms = ProcessCpuMs();
  for (auto _ : state) {
    times.Add(front_end.Process(0, p.left[i % p.left.size()], p.right[i % p.right.size()]));
    ++i;
  }
  ReportCpu(state, cpu_start_ms);
  times.Report(state);
}
BENCHMARK(BM_StereoFrontEnd)->Unit(benchmark::kMillisecond)->UseRealTime();

// The left image's keypoints cut down to orb_features by grid bucketing, as the front end
// does before matching, with their descriptor rows.
void BucketLeft(const StereoFrontEndOptions& o, const cv::Size& size,
                std::vector<cv::KeyPoint>& keypoints, cv::Mat& descriptors) {
  const std::vector<int> kept = BucketKeypoints(keypoints, size.width, size.height, o.grid_columns,
                                                o.grid_rows, o.orb_features);
  std::vector<cv::KeyPoint> kept_keypoints;
  cv::Mat kept_descriptors(static_cast<int>(kept.size()), descriptors.cols, descriptors.type());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    kept_keypoints.push_back(keypoints[static_cast<std::size_t>(kept[i])]);
    descriptors.row(kept[i]).copyTo(kept_descriptors.row(static_cast<int>(i)));
  }
  keypoints = std::move(kept_keypoints);
  descriptors = kept_descriptors;
}

// The matching step alone (row search, left-right check, sub-pixel refinement) on keypoints
// found beforehand: the right image's all, the left's after bucketing, as the front end has them.
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
    BucketLeft(o, p.left[i].size(), kl[i], dl[i]);
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

// ---- KITTI: the first pair of the odometry excerpt seq2 ----

constexpr int kKittiWidthPx = 1241;
constexpr int kKittiHeightPx = 376;

struct KittiPair {
  RectifiedStereoGeometry geometry;
  cv::Mat left, right;  // rectified (the excerpt's images are; rectifying them is a no-op)
};

// Rectified as the pipeline does it (stereo_pipeline.cc), so the front end sees what
// `fleetmap experiment real` gives it.
const KittiPair& Kitti() {
  static const KittiPair pair = [] {
    const StereoSequence sequence =
        LoadStereoSequence(std::filesystem::path(FLEETMAP_KITTI_DIR) / "seq2");
    const StereoRectifier rectifier(sequence.left, sequence.right);
    KittiPair k;
    k.geometry = rectifier.geometry();
    const StereoPairFiles& files = sequence.pairs.front();
    rectifier.Rectify(ReadMonoImage(files.left_image, kKittiWidthPx, kKittiHeightPx),
                      ReadMonoImage(files.right_image, kKittiWidthPx, kKittiHeightPx), k.left,
                      k.right);
    return k;
  }();
  return pair;
}

bool HaveKitti(benchmark::State& state) {
  const std::filesystem::path dir(FLEETMAP_KITTI_DIR);
  if (dir.empty() || !std::filesystem::is_regular_file(dir / "seq2" / "calib.txt")) {
    state.SkipWithError(
        "the KITTI odometry excerpts were not found at configure time; configure with "
        "-DFLEETMAP_KITTI_DIR=/path/to/kitti-odometry-excerpts");
    return false;
  }
  return true;
}

void BM_KittiOpenCvOrbBothImages(benchmark::State& state) {
  if (!HaveKitti(state)) return;
  const KittiPair& k = Kitti();
  const cv::Ptr<cv::ORB> orb = CreateOrbDetector(StereoFrontEndOptions{});
  for (auto _ : state) {
    std::vector<cv::KeyPoint> kl, kr;
    cv::Mat dl, dr;
    orb->detectAndCompute(k.left, cv::noArray(), kl, dl);
    orb->detectAndCompute(k.right, cv::noArray(), kr, dr);
    benchmark::DoNotOptimize(dr.data);
  }
}
BENCHMARK(BM_KittiOpenCvOrbBothImages)->Unit(benchmark::kMillisecond)->UseRealTime();

// The argument is the keypoints kept (StereoFrontEndOptions::orb_features): the default and the
// earlier 1500, side by side in one run.
StereoFrontEndOptions WithFeatures(const benchmark::State& state) {
  StereoFrontEndOptions o;
  o.orb_features = static_cast<int>(state.range(0));
  return o;
}

void BM_KittiOpenCvOrbTwoThreads(benchmark::State& state) {
  if (!HaveKitti(state)) return;
  const KittiPair& k = Kitti();
  const StereoFrontEndOptions o = WithFeatures(state);
  const double cpu_start_ms = ProcessCpuMs();
  for (auto _ : state) OrbBothImagesTwoThreads(o, k.left, k.right);
  ReportCpu(state, cpu_start_ms);
}
BENCHMARK(BM_KittiOpenCvOrbTwoThreads)
    ->Arg(StereoFrontEndOptions{}.orb_features)
    ->Arg(1500)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_KittiOpenCvOrbKeptTwoThreads(benchmark::State& state) {
  if (!HaveKitti(state)) return;
  const KittiPair& k = Kitti();
  const StereoFrontEndOptions o = KeptCountOnly(WithFeatures(state));
  const double cpu_start_ms = ProcessCpuMs();
  for (auto _ : state) OrbBothImagesTwoThreads(o, k.left, k.right);
  ReportCpu(state, cpu_start_ms);
}
BENCHMARK(BM_KittiOpenCvOrbKeptTwoThreads)
    ->Arg(StereoFrontEndOptions{}.orb_features)
    ->Arg(1500)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

void BM_KittiStereoFrontEnd(benchmark::State& state) {
  if (!HaveKitti(state)) return;
  const KittiPair& k = Kitti();
  const StereoFrontEnd front_end(k.geometry, WithFeatures(state));
  StageTimes times;
  const double cpu_start_ms = ProcessCpuMs();
  for (auto _ : state) times.Add(front_end.Process(0, k.left, k.right));
  ReportCpu(state, cpu_start_ms);
  times.Report(state);
}
BENCHMARK(BM_KittiStereoFrontEnd)
    ->Arg(StereoFrontEndOptions{}.orb_features)
    ->Arg(1500)
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace fleetmap

BENCHMARK_MAIN();
