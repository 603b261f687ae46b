// The acceptance lines on a real drive (JudgeRealExperiment, real_experiment.h),
// judged on hand-made results: each line passes at its exact threshold and fails just past it,
// and lines whose measure needs ground truth are not judged without it.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "fleetmap/runners/real_experiment.h"

namespace fleetmap {
namespace {

// Every measure exactly at its threshold: 49 of 50 pairs tracked (98 %), drift 3 % and
// 0.03 deg/m, 19 of 20 localised (95 %), a median position error of 0.3 m.
RealExperimentResult AtTheThresholds() {
  RealExperimentResult r;
  r.vo_pairs = 50;
  r.vo_pairs_with_30_inliers = 49;
  r.has_ground_truth = true;
  r.accuracy.sub_paths = 120;
  r.accuracy.translational_drift_percent = 3.0;
  r.accuracy.rotational_drift_deg_per_m = 0.03;
  r.localised_frames = 20;
  r.localised_ok = 19;
  r.localised_with_truth = 19;
  r.position_error_median_m = 0.3;
  return r;
}

// The lines in the order JudgeRealExperiment gives them with ground truth.
enum JudgedLine { kTracked, kTranslationalDrift, kRotationalDrift, kLocalised, kPositionError };

std::vector<bool> Passes(const std::vector<RealAcceptanceLine>& lines) {
  std::vector<bool> pass;
  for (const RealAcceptanceLine& line : lines) pass.push_back(line.pass);
  return pass;
}

// All lines pass but `failing`.
std::vector<bool> AllBut(JudgedLine failing) {
  std::vector<bool> pass(5, true);
  pass[failing] = false;
  return pass;
}

TEST(RealExperimentJudgeTest, EveryLinePassesAtItsExactThreshold) {
  const std::vector<RealAcceptanceLine> lines = JudgeRealExperiment(AtTheThresholds());
  ASSERT_EQ(lines.size(), 5u);
  EXPECT_EQ(Passes(lines), std::vector<bool>(5, true));
  // Each line says what it asks and what was measured.
  EXPECT_NE(lines[kTracked].what.find("98 %"), std::string::npos) << lines[kTracked].what;
  EXPECT_EQ(lines[kTracked].measured, "98.0 %");
  EXPECT_NE(lines[kTranslationalDrift].what.find("3 %"), std::string::npos);
  EXPECT_EQ(lines[kTranslationalDrift].measured, "3.00 %");
  EXPECT_NE(lines[kRotationalDrift].what.find("0.03 deg/m"), std::string::npos);
  EXPECT_EQ(lines[kRotationalDrift].measured, "0.0300 deg/m");
  EXPECT_NE(lines[kLocalised].what.find("95 %"), std::string::npos);
  EXPECT_EQ(lines[kLocalised].measured, "95.0 %");
  EXPECT_NE(lines[kPositionError].what.find("0.3 m"), std::string::npos);
  EXPECT_EQ(lines[kPositionError].measured, "0.300 m");
}

TEST(RealExperimentJudgeTest, EachLineFailsJustPastItsThreshold) {
  RealExperimentResult r = AtTheThresholds();
  r.vo_pairs_with_30_inliers = 489;  // of 500: 97.8 %
  r.vo_pairs = 500;
  EXPECT_EQ(Passes(JudgeRealExperiment(r)), AllBut(kTracked));

  r = AtTheThresholds();
  r.accuracy.translational_drift_percent = 3.001;
  EXPECT_EQ(Passes(JudgeRealExperiment(r)), AllBut(kTranslationalDrift));

  r = AtTheThresholds();
  r.accuracy.rotational_drift_deg_per_m = 0.0301;
  EXPECT_EQ(Passes(JudgeRealExperiment(r)), AllBut(kRotationalDrift));

  r = AtTheThresholds();
  r.localised_ok = 189;  // of 199: 94.97 %
  r.localised_frames = 199;
  EXPECT_EQ(Passes(JudgeRealExperiment(r)), AllBut(kLocalised));

  r = AtTheThresholds();
  r.position_error_median_m = 0.301;
  EXPECT_EQ(Passes(JudgeRealExperiment(r)), AllBut(kPositionError));
}

TEST(RealExperimentJudgeTest, NothingMeasuredIsNoPass) {
  // No consecutive pairs, no localised frames: the rates are 0 of 0, which is not 98 %.
  RealExperimentResult r = AtTheThresholds();
  r.vo_pairs = 0;
  r.vo_pairs_with_30_inliers = 0;
  r.localised_frames = 0;
  r.localised_ok = 0;
  const std::vector<RealAcceptanceLine> lines = JudgeRealExperiment(r);
  ASSERT_GE(lines.size(), 4u);
  EXPECT_FALSE(lines[kTracked].pass);
  EXPECT_FALSE(lines[kLocalised].pass);
}

TEST(RealExperimentJudgeTest, GroundTruthButNothingLocalisedAgainstItFailsTheErrorLine) {
  RealExperimentResult r = AtTheThresholds();
  r.localised_with_truth = 0;
  r.position_error_median_m = 0;
  const std::vector<RealAcceptanceLine> lines = JudgeRealExperiment(r);
  ASSERT_GT(lines.size(), static_cast<std::size_t>(kPositionError));
  EXPECT_FALSE(lines[kPositionError].pass);
}

TEST(RealExperimentJudgeTest, WithoutGroundTruthOnlyTheTwoRatesAreJudged) {
  RealExperimentResult r = AtTheThresholds();
  r.has_ground_truth = false;
  std::vector<RealAcceptanceLine> lines = JudgeRealExperiment(r);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_NE(lines[0].what.find("tracked"), std::string::npos) << lines[0].what;
  EXPECT_NE(lines[1].what.find("localised"), std::string::npos) << lines[1].what;
  EXPECT_TRUE(lines[0].pass);
  EXPECT_TRUE(lines[1].pass);
  // And they still fail on their own.
  r.vo_pairs_with_30_inliers = 48;
  r.localised_ok = 18;
  lines = JudgeRealExperiment(r);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_FALSE(lines[0].pass);
  EXPECT_FALSE(lines[1].pass);
}

}  // namespace
}  // namespace fleetmap
