#include "compare/bench_metrics.hpp"

#include <algorithm>
#include <cmath>

namespace strata::bench {
namespace {

struct Derivatives {
  Eigen::Vector3d position, first, second;
};

// One centripetal Catmull-Rom segment p1 → p2 (neighbours p0, p3) as a cubic Hermite curve in
// u ∈ [0, 1].
class CatmullRomSegment {
 public:
  CatmullRomSegment(const Eigen::Vector3d& p0, const Eigen::Vector3d& p1, const Eigen::Vector3d& p2,
                    const Eigen::Vector3d& p3)
      : p1_(p1), p2_(p2) {
    const double d01 = std::sqrt((p1 - p0).norm());
    const double d12 = std::sqrt((p2 - p1).norm());
    const double d23 = std::sqrt((p3 - p2).norm());
    m1_ = d12 * ((p1 - p0) / d01 - (p2 - p0) / (d01 + d12) + (p2 - p1) / d12);
    m2_ = d12 * ((p2 - p1) / d12 - (p3 - p1) / (d12 + d23) + (p3 - p2) / d23);
  }
  Derivatives Evaluate(double u) const {
    const double u2 = u * u, u3 = u2 * u;
    Derivatives d;
    d.position = (2 * u3 - 3 * u2 + 1) * p1_ + (u3 - 2 * u2 + u) * m1_ + (-2 * u3 + 3 * u2) * p2_ +
                 (u3 - u2) * m2_;
    d.first = (6 * u2 - 6 * u) * p1_ + (3 * u2 - 4 * u + 1) * m1_ + (-6 * u2 + 6 * u) * p2_ +
              (3 * u2 - 2 * u) * m2_;
    d.second = (12 * u - 6) * p1_ + (6 * u - 4) * m1_ + (-12 * u + 6) * p2_ + (6 * u - 2) * m2_;
    return d;
  }

 private:
  Eigen::Vector3d p1_, p2_, m1_, m2_;
};

// Below this speed along the curve's parameter a sample is stationary and κ undefined.
constexpr double kStationary = 1e-9;

Eigen::Vector3d InSpace(Eigen::Vector3d v, CurvatureSpace space) {
  if (space == CurvatureSpace::kPlanar) v.z() = 0;
  return v;
}

double Curvature(const Eigen::Vector3d& first, const Eigen::Vector3d& second) {
  const double speed = first.norm();
  return first.cross(second).norm() / (speed * speed * speed);
}

// Parameter values where a curve's cumulative arc length reaches (k + 0.5)·L/n, k < n, with
// n = max(1, round(L / spacing)); `table` holds (parameter, arc length) pairs, ascending.
std::vector<double> UniformArcParameters(const std::vector<std::pair<double, double>>& table,
                                         double spacing_m) {
  std::vector<double> params;
  if (table.size() < 2) return params;
  const double total = table.back().second;
  const int n = std::max(1, static_cast<int>(std::lround(total / spacing_m)));
  std::size_t j = 1;
  for (int k = 0; k < n; ++k) {
    const double s = (k + 0.5) * total / n;
    while (j + 1 < table.size() && table[j].second < s) ++j;
    const auto& [u0, s0] = table[j - 1];
    const auto& [u1, s1] = table[j];
    params.push_back(s1 > s0 ? u0 + (u1 - u0) * (s - s0) / (s1 - s0) : u0);
  }
  return params;
}

// (time, arc length) pairs of a trajectory's x, y, z (in `space`) every ~2 ms.
std::vector<std::pair<double, double>> TrajectoryArcTable(const Trajectory& trajectory,
                                                          CurvatureSpace space) {
  std::vector<std::pair<double, double>> table;
  if (trajectory.pieces.empty()) return table;
  const double duration = trajectory.TotalDuration();
  const int n = std::max(1000, static_cast<int>(std::ceil(duration / 0.002)));
  TrajectoryCursor cursor(trajectory);
  Eigen::Vector3d previous = InSpace(cursor.Position(0).head<3>(), space);
  double length = 0;
  table.emplace_back(0.0, 0.0);
  for (int i = 1; i <= n; ++i) {
    const double t = duration * i / n;
    const Eigen::Vector3d p = InSpace(cursor.Position(t).head<3>(), space);
    length += (p - previous).norm();
    previous = p;
    table.emplace_back(t, length);
  }
  return table;
}

}  // namespace

double PolylineLength(std::span<const Eigen::Vector3d> points) {
  double length = 0;
  for (std::size_t i = 1; i < points.size(); ++i) length += (points[i] - points[i - 1]).norm();
  return length;
}

double PathMeanCurvature(std::span<const Eigen::Vector3d> points, CurvatureSpace space,
                         double spacing_m) {
  std::vector<Eigen::Vector3d> p;
  for (const Eigen::Vector3d& point : points) {
    const Eigen::Vector3d q = InSpace(point, space);
    if (p.empty() || (q - p.back()).norm() >= 1e-3) p.push_back(q);
  }
  if (p.size() < 3) return 0;
  const std::size_t n = p.size();
  std::vector<CatmullRomSegment> segments;
  for (std::size_t i = 0; i + 1 < n; ++i) {
    const Eigen::Vector3d before = i > 0 ? p[i - 1] : Eigen::Vector3d(2 * p[0] - p[1]);
    const Eigen::Vector3d after = i + 2 < n ? p[i + 2] : Eigen::Vector3d(2 * p[n - 1] - p[n - 2]);
    segments.emplace_back(before, p[i], p[i + 1], after);
  }
  // Arc length table over the global parameter i + u (segment i, u in [0, 1]).
  constexpr int kSubsteps = 32;
  std::vector<std::pair<double, double>> table{{0.0, 0.0}};
  double length = 0;
  for (std::size_t i = 0; i < segments.size(); ++i) {
    Eigen::Vector3d previous = segments[i].Evaluate(0).position;
    for (int k = 1; k <= kSubsteps; ++k) {
      const double u = double(k) / kSubsteps;
      const Eigen::Vector3d q = segments[i].Evaluate(u).position;
      length += (q - previous).norm();
      previous = q;
      table.emplace_back(double(i) + u, length);
    }
  }
  double sum = 0;
  int count = 0;
  for (const double s : UniformArcParameters(table, spacing_m)) {
    const std::size_t i = std::min(segments.size() - 1, static_cast<std::size_t>(s));
    const Derivatives d = segments[i].Evaluate(s - double(i));
    if (d.first.norm() < kStationary) continue;
    sum += Curvature(d.first, d.second);
    ++count;
  }
  return count > 0 ? sum / count : 0;
}

double TrajectoryMeanCurvature(const Trajectory& trajectory, CurvatureSpace space,
                               double spacing_m) {
  double sum = 0;
  int count = 0;
  TrajectoryCursor cursor(trajectory);
  for (const double t : UniformArcParameters(TrajectoryArcTable(trajectory, space), spacing_m)) {
    const Eigen::Vector3d v = InSpace(cursor.Velocity(t).head<3>(), space);
    if (v.norm() < kStationary) continue;
    sum += Curvature(v, InSpace(cursor.Acceleration(t).head<3>(), space));
    ++count;
  }
  return count > 0 ? sum / count : 0;
}

std::vector<Eigen::Vector3d> SampleTrajectory(const Trajectory& trajectory, double spacing_m) {
  std::vector<Eigen::Vector3d> points;
  if (trajectory.pieces.empty()) return points;
  TrajectoryCursor cursor(trajectory);
  points.push_back(cursor.Position(0).head<3>());
  for (const double t :
       UniformArcParameters(TrajectoryArcTable(trajectory, CurvatureSpace::k3d), spacing_m)) {
    points.push_back(cursor.Position(t).head<3>());
  }
  points.push_back(trajectory.Position(trajectory.TotalDuration()).head<3>());
  return points;
}

}  // namespace strata::bench
