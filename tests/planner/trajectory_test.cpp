// TrajectoryCursor against a lookup written out here: the piece from the running sum of the
// durations, the time local to it.
#include "strata/planning/trajectory.hpp"

#include <algorithm>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace strata {
namespace {

// 40 pieces of random durations and coefficients in 3 dimensions.
Trajectory RandomTrajectory(std::mt19937& rng) {
  std::uniform_real_distribution<double> duration(0.05, 2.0), coefficient(-1.0, 1.0);
  Trajectory trajectory;
  trajectory.dimension = 3;
  for (int i = 0; i < 40; ++i) {
    TrajectoryPiece piece;
    piece.duration_s = duration(rng);
    piece.coefficients.resize(6, 3);
    for (int k = 0; k < 6 * 3; ++k) piece.coefficients.data()[k] = coefficient(rng);
    trajectory.pieces.push_back(piece);
  }
  return trajectory;
}

Eigen::VectorXd Expected(const Trajectory& trajectory, double t, int order) {
  t = std::clamp(t, 0.0, trajectory.TotalDuration());
  double start = 0;
  std::size_t i = 0;
  while (i + 1 < trajectory.pieces.size() && t > start + trajectory.pieces[i].duration_s) {
    start += trajectory.pieces[i++].duration_s;
  }
  return trajectory.EvaluatePiece(i, std::min(t - start, trajectory.pieces[i].duration_s), order);
}

TEST(TrajectoryCursor, MatchesTheLookupForwardBackwardAndOutsideTheTrajectory) {
  std::mt19937 rng(3);
  const Trajectory trajectory = RandomTrajectory(rng);
  const double total = trajectory.TotalDuration();
  std::vector<double> times;
  for (int k = 0; k <= 400; ++k) times.push_back(total * k / 400);  // Forward, as sampling.
  std::uniform_real_distribution<double> anywhere(-0.5, total + 0.5);
  for (int k = 0; k < 400; ++k) times.push_back(anywhere(rng));  // Back and forth, and out.
  TrajectoryCursor cursor(trajectory);
  for (const double t : times) {
    for (int order = 0; order <= 3; ++order) {
      const Eigen::VectorXd expected = Expected(trajectory, t, order);
      EXPECT_LT((cursor.Evaluate(t, order) - expected).norm(), 1e-9 * (1 + expected.norm()))
          << "t " << t << " order " << order;
      EXPECT_LT((trajectory.Evaluate(t, order) - expected).norm(), 1e-9 * (1 + expected.norm()))
          << "t " << t << " order " << order;
    }
  }
}

}  // namespace
}  // namespace strata
