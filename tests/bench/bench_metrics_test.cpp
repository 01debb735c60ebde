// The comparison's curve figures (bench/compare/bench_metrics.hpp) against curves whose
// curvature is known in closed form.
#include "compare/bench_metrics.hpp"

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace strata::bench {
namespace {

// Points on a circle of radius r in the plane z = z0, every `step` rad.
std::vector<Eigen::Vector3d> Arc(double r, double z0, double step, double turn) {
  std::vector<Eigen::Vector3d> points;
  for (double a = 0; a <= turn + 1e-12; a += step) {
    points.emplace_back(r * std::cos(a), r * std::sin(a), z0);
  }
  return points;
}

TEST(PathMeanCurvature, ACircleHasTheInverseOfItsRadiusInBothSpaces) {
  const std::vector<Eigen::Vector3d> arc = Arc(4.0, 1.0, 0.05, std::numbers::pi);
  EXPECT_NEAR(PathMeanCurvature(arc, CurvatureSpace::k3d), 0.25, 0.005);
  EXPECT_NEAR(PathMeanCurvature(arc, CurvatureSpace::kPlanar), 0.25, 0.005);
}

// A straight line whose points carry ±5 mm of height noise, as the baselines' paths over raw
// cloud points do: the 3D figure reads the noise as curvature, the projection does not.
TEST(PathMeanCurvature, HeightNoiseOnAStraightLineCountsOnlyIn3d) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> noise(-0.005, 0.005);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 100; ++i) points.emplace_back(0.1 * i, 0.05 * i, 0.3 + noise(rng));
  EXPECT_GT(PathMeanCurvature(points, CurvatureSpace::k3d), 0.5);
  EXPECT_LT(PathMeanCurvature(points, CurvatureSpace::kPlanar), 1e-6);
}

// One quintic piece x = t, y = t², z = t (a parabola climbing a ramp) for t in [0, 1].
Trajectory ClimbingParabola() {
  Trajectory t;
  t.dimension = 3;
  TrajectoryPiece piece;
  piece.duration_s = 1.0;
  piece.coefficients = Eigen::MatrixXd::Zero(6, 3);
  piece.coefficients(1, 0) = 1;  // x = t
  piece.coefficients(2, 1) = 1;  // y = t²
  piece.coefficients(1, 2) = 1;  // z = t
  t.pieces.push_back(piece);
  return t;
}

// Mean over arc length of the curvature of y = x² (planar) and of (s, s², s) (3D), s in [0, 1],
// by fine quadrature.
double ReferenceMean(bool planar) {
  double sum = 0, length = 0;
  constexpr int kSteps = 200000;
  for (int i = 0; i < kSteps; ++i) {
    const double s = (i + 0.5) / kSteps;
    const Eigen::Vector3d d1(1, 2 * s, planar ? 0 : 1), d2(0, 2, 0);
    const double speed = d1.norm();
    sum += d1.cross(d2).norm() / (speed * speed);  // κ · ds/dt
    length += speed;
  }
  return sum / length;
}

TEST(TrajectoryMeanCurvature, MatchesTheClosedFormOnAClimbingParabola) {
  const Trajectory t = ClimbingParabola();
  EXPECT_NEAR(TrajectoryMeanCurvature(t, CurvatureSpace::kPlanar), ReferenceMean(true), 1e-3);
  EXPECT_NEAR(TrajectoryMeanCurvature(t, CurvatureSpace::k3d), ReferenceMean(false), 1e-3);
  // The same curve as points, through the path formula: the same figure.
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i <= 200; ++i) points.push_back(t.Position(i / 200.0).head<3>());
  EXPECT_NEAR(PathMeanCurvature(points, CurvatureSpace::kPlanar), ReferenceMean(true), 2e-3);
}

}  // namespace
}  // namespace strata::bench
