// Γ(distance) and Γ(path) (seed 002 §III-C, §V), checked against the worked example of seed
// 002 Fig. 5 by hand.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "fleetmap/core/error.h"
#include "fleetmap/ranking/distance_ranking.h"
#include "fleetmap/ranking/path_memory.h"
#include "fleetmap/ranking/path_ranking.h"
#include "numbered_uuid.h"

namespace fleetmap {
namespace {

// Seed 002 Fig. 5: P1 = n1 n2 n3 n4 n9 and P2 = n6 n7 n8 n4 n5; the robot is at n_k = n4 with
// candidates Y = {n5, n9} and has just tried W = {n1, n2, n3, n4, n8}, Z = [1, 1, 1, 1, 0].
PathMemory Figure5Memory() {
  PathMemory memory;
  const Uuid p1 = NumberedUuid(101), p2 = NumberedUuid(102);
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{1, 2}, {2, 3}, {3, 4}, {4, 9}}) {
    memory.AddPathEdge(p1, NumberedUuid(a), NumberedUuid(b));
  }
  for (const auto& [a, b] : std::vector<std::pair<int, int>>{{6, 7}, {7, 8}, {8, 4}, {4, 5}}) {
    memory.AddPathEdge(p2, NumberedUuid(a), NumberedUuid(b));
  }
  return memory;
}

void ObserveFigure5(PathRanking& ranking) {
  for (const auto& [node, success] :
       std::vector<std::pair<int, bool>>{{1, true}, {2, true}, {3, true}, {8, false}, {4, true}}) {
    const LocalisationAttempt attempt{NumberedUuid(node), success};
    ranking.ObserveIteration({&attempt, 1});
  }
}

TEST(PathMemory, CountsPathsSharedByTwoNodes) {
  const PathMemory memory = Figure5Memory();
  EXPECT_EQ(memory.path_count(), 2u);
  EXPECT_EQ(memory.SharedPaths(NumberedUuid(4), NumberedUuid(9)), 1);  // P1
  EXPECT_EQ(memory.SharedPaths(NumberedUuid(4), NumberedUuid(5)), 1);  // P2
  EXPECT_EQ(memory.SharedPaths(NumberedUuid(3), NumberedUuid(9)),
            1);  // linked by P1 though not adjacent
  EXPECT_EQ(memory.SharedPaths(NumberedUuid(1), NumberedUuid(5)), 0);
  EXPECT_EQ(memory.SharedPaths(NumberedUuid(4), NumberedUuid(4)), 2);
  EXPECT_TRUE(memory.PathsThrough(NumberedUuid(77)).empty());
}

TEST(PathRanking, Figure5PosteriorsMatchHandComputation) {
  PathRanking ranking(Figure5Memory(), {.window_iterations = 10});
  ObserveFigure5(ranking);
  ASSERT_EQ(ranking.observation_count(), 5u);

  // n9: Z_9 = [1, 1, 1, 1, 0] (P1 through n1..n4), D = 4 + 5 = 9, so θ = 2/9 on the four
  // successes and 1/9 on n8's failure: p(Z | n9) = (2/9)^4 (8/9). Prior N_9k = 1 (P1).
  // n5: Z_5 = [0, 0, 0, 1, 1] (P2 through n8 and n4), D = 2 + 5 = 7:
  // p(Z | n5) = (1/7)^3 (2/7) (5/7). Prior N_5k = 1 (P2).
  const double expected_n9 = std::log(2.0) + std::log(std::pow(2.0 / 9, 4) * (8.0 / 9));
  const double expected_n5 = std::log(2.0) + std::log(std::pow(1.0 / 7, 3) * (2.0 / 7) * (5.0 / 7));
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)), expected_n9, 1e-12);
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(5)), expected_n5, 1e-12);

  // The figure's conclusion: n9 is the better bet, although n5 is nearer.
  std::vector<Candidate> candidates{{NumberedUuid(5), 1.0}, {NumberedUuid(9), 2.0}};
  ranking.Rank(NumberedUuid(4), candidates);
  EXPECT_EQ(candidates[0].node, NumberedUuid(9));
  EXPECT_EQ(candidates[1].node, NumberedUuid(5));
}

TEST(PathRanking, PriorAloneFavoursNodesWithMorePathsFromReference) {
  PathMemory memory = Figure5Memory();
  memory.AddPathEdge(NumberedUuid(103), NumberedUuid(4),
                     NumberedUuid(5));                               // a second path from n4 to n5
  PathRanking ranking(std::move(memory), {.window_iterations = 0});  // T = 0: prior only
  ObserveFigure5(ranking);
  EXPECT_EQ(ranking.observation_count(), 0u);
  // π ∝ N_ik + 1: n5 has 2 + 1, n9 has 1 + 1.
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(5)) -
                  ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)),
              std::log(3.0 / 2.0), 1e-12);
  std::vector<Candidate> candidates{{NumberedUuid(9), 1.0}, {NumberedUuid(5), 2.0}};
  ranking.Rank(NumberedUuid(4), candidates);
  EXPECT_EQ(candidates[0].node, NumberedUuid(5));
}

TEST(PathRanking, WindowForgetsIterationsOlderThanT) {
  PathRanking ranking(Figure5Memory(), {.window_iterations = 2});
  ObserveFigure5(ranking);  // only n8 (failed) and n4 (succeeded) stay
  EXPECT_EQ(ranking.observation_count(), 2u);
  // n9: Z_9 = [0 for n8, 1 for n4], D = 1 + 2 = 3: θ(n8) = 1/3 failed, θ(n4) = 2/3 succeeded.
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)),
              std::log(2.0) + std::log((2.0 / 3) * (2.0 / 3)), 1e-12);
  // n5: Z_5 = [1, 1], D = 2 + 2 = 4: θ = 2/4 for both.
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(5)),
              std::log(2.0) + std::log((1 - 2.0 / 4) * (2.0 / 4)), 1e-12);
}

TEST(PathRanking, LatestOutcomeOfARepeatedNodeCounts) {
  PathRanking ranking(Figure5Memory(), {.window_iterations = 10});
  const LocalisationAttempt failed{NumberedUuid(1), false}, succeeded{NumberedUuid(1), true};
  ranking.ObserveIteration({&failed, 1});
  ranking.ObserveIteration({&succeeded, 1});
  EXPECT_EQ(ranking.observation_count(), 1u);
  // W = {n1}, z = 1; n9 shares P1 with it: D = 1 + 1, θ = 2/2.
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)), std::log(2.0) + std::log(1.0),
              1e-12);
}

TEST(PathRanking, PathEdgesAddedDuringTheOutingCountAtOnce) {
  PathRanking ranking(PathMemory{}, {.window_iterations = 10});
  const LocalisationAttempt attempts[] = {{NumberedUuid(1), true}, {NumberedUuid(3), false}};
  ranking.ObserveIteration(attempts);
  // No paths yet: D = 2, θ = 1/2 for both observations.
  EXPECT_NEAR(ranking.LogPosterior(Uuid(), NumberedUuid(2)), 2 * std::log(0.5), 1e-12);
  ranking.ObservePathEdge(NumberedUuid(200), NumberedUuid(1),
                          NumberedUuid(2));  // n1, already in W, joins a path with n2
  // Z = [1, 0], D = 3: θ(n1) = 2/3 succeeded, θ(n3) = 1/3 failed.
  EXPECT_NEAR(ranking.LogPosterior(Uuid(), NumberedUuid(2)), 2 * std::log(2.0 / 3), 1e-12);
  EXPECT_EQ(ranking.memory().SharedPaths(NumberedUuid(1), NumberedUuid(2)), 1);
}

TEST(PathRanking, StartOutingClearsObservationsButKeepsMemory) {
  PathRanking ranking(Figure5Memory(), {.window_iterations = 10});
  ObserveFigure5(ranking);
  ranking.StartOuting();
  EXPECT_EQ(ranking.observation_count(), 0u);
  EXPECT_EQ(ranking.memory().path_count(), 2u);
  EXPECT_NEAR(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)), std::log(2.0), 1e-12);
}

// Eqs. 5–9 evaluated term by term from their definitions, for checking the fast path.
double DirectLogPosterior(const PathMemory& memory, const Uuid& reference, const Uuid& candidate,
                          const std::vector<std::pair<Uuid, bool>>& observed) {
  double score = std::log(memory.SharedPaths(candidate, reference) + 1.0);
  double denominator = 0.0;
  for (const auto& [node, success] : observed)
    denominator += memory.SharedPaths(candidate, node) + 1.0;
  for (const auto& [node, success] : observed) {
    const double theta = (memory.SharedPaths(candidate, node) + 1.0) / denominator;
    score += std::log(success ? theta : 1.0 - theta);
  }
  return score;
}

// Few paths (bitsets over every path, one word and several) and many (bitsets over the paths
// touching W only) must all give the definition's numbers.
class PathRankingMatchesDefinition : public ::testing::TestWithParam<int> {};

TEST_P(PathRankingMatchesDefinition, OnARandomMap) {
  const int paths = GetParam();
  constexpr int kNodes = 600;
  std::mt19937 rng(static_cast<unsigned>(paths));
  std::uniform_int_distribution<int> pick_node(0, kNodes - 1), pick_path(0, paths - 1),
      per_node(0, 6);
  PathMemory memory;
  for (int i = 0; i < kNodes; ++i) {
    for (int k = per_node(rng); k > 0; --k) {
      memory.AddPathEdge(NumberedUuid(10'000 + pick_path(rng)), NumberedUuid(i),
                         NumberedUuid(pick_node(rng)));
    }
  }
  PathRanking ranking(memory, {.window_iterations = 30});
  std::vector<std::pair<Uuid, bool>> window;  // W with each member's latest outcome
  std::bernoulli_distribution success(0.4);
  for (int t = 0; t < 30; ++t) {
    std::vector<LocalisationAttempt> attempts;
    for (int a = 0; a < 4; ++a) {
      // Some attempts on nodes on no path, which count in |W| but link to nothing.
      const Uuid node =
          t % 7 == 0 && a == 0 ? NumberedUuid(5000 + t) : NumberedUuid(pick_node(rng));
      attempts.push_back({node, success(rng)});
    }
    ranking.ObserveIteration(attempts);
    for (const LocalisationAttempt& attempt : attempts) {
      const auto it = std::find_if(window.begin(), window.end(),
                                   [&](const auto& entry) { return entry.first == attempt.node; });
      if (it == window.end()) {
        window.emplace_back(attempt.node, attempt.success);
      } else {
        it->second = attempt.success;
      }
    }
  }
  ASSERT_EQ(ranking.observation_count(), window.size());
  const Uuid reference = NumberedUuid(pick_node(rng));
  for (int c = 0; c < 40; ++c) {
    const Uuid candidate =
        NumberedUuid(c == 0 ? 5000 : pick_node(rng));  // one candidate on no path
    const double expected = DirectLogPosterior(memory, reference, candidate, window);
    const double actual = ranking.LogPosterior(reference, candidate);
    if (std::isinf(expected)) {
      EXPECT_EQ(actual, expected) << "candidate " << c;
    } else {
      EXPECT_NEAR(actual, expected, 1e-9 * std::abs(expected)) << "candidate " << c;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(PathCounts, PathRankingMatchesDefinition, ::testing::Values(40, 200, 400));

TEST(PathRanking, WhileEveryAttemptInTheWindowFailedCandidatesRankByDistance) {
  PathRanking ranking(Figure5Memory(), {.window_iterations = 10});
  const LocalisationAttempt failures[] = {{NumberedUuid(8), false}, {NumberedUuid(1), false}};
  ranking.ObserveIteration(failures);
  // Eq. 8 alone would put n9 (P1, 2 x 2/9) before n77 on no path (1/4); with nothing in W that
  // succeeded the posterior only says which candidates the failures rule out, so the nearer
  // comes first.
  EXPECT_GT(ranking.LogPosterior(NumberedUuid(4), NumberedUuid(9)),
            ranking.LogPosterior(NumberedUuid(4), NumberedUuid(77)));
  std::vector<Candidate> candidates{{NumberedUuid(9), 3.0}, {NumberedUuid(77), 1.0}};
  ranking.Rank(NumberedUuid(4), candidates);
  EXPECT_EQ(candidates[0].node, NumberedUuid(77));
  // One success in the window and the posterior ranks again.
  const LocalisationAttempt success{NumberedUuid(4), true};
  ranking.ObserveIteration({&success, 1});
  ranking.Rank(NumberedUuid(4), candidates);
  EXPECT_EQ(candidates[0].node, NumberedUuid(9));
}

TEST(PathRanking, RejectsNegativeWindow) {
  EXPECT_THROW(PathRanking(PathMemory{}, {.window_iterations = -1}), Error);
}

TEST(DistanceRanking, NearestFirstTiesByUuid) {
  DistanceRanking ranking;
  std::vector<Candidate> candidates{
      {NumberedUuid(3), 2.0}, {NumberedUuid(2), 1.0}, {NumberedUuid(1), 2.0}};
  ranking.Rank(Uuid(), candidates);
  EXPECT_EQ(candidates[0].node, NumberedUuid(2));
  EXPECT_EQ(candidates[1].node, NumberedUuid(1));
  EXPECT_EQ(candidates[2].node, NumberedUuid(3));
}

}  // namespace
}  // namespace fleetmap
