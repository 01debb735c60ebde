#include "strata/planning/time_scaling.hpp"

#include <algorithm>
#include <cmath>

#include "strata/planning/minco.hpp"

namespace strata {

DynamicPeaks SampleDynamicPeaks(const Trajectory& trajectory, double max_step_s) {
  DynamicPeaks peaks;
  for (std::size_t i = 0; i < trajectory.pieces.size(); ++i) {
    const double duration = trajectory.pieces[i].duration_s;
    const int steps = std::max(1, static_cast<int>(std::ceil(duration / max_step_s)));
    for (int k = 0; k <= steps; ++k) {
      const double t = duration * k / steps;
      const StateVector v = trajectory.EvaluatePiece(i, t, 1);
      const StateVector a = trajectory.EvaluatePiece(i, t, 2);
      peaks.speed_horizontal_mps = std::max(peaks.speed_horizontal_mps, v.head<2>().norm());
      peaks.speed_vertical_mps = std::max(peaks.speed_vertical_mps, std::abs(v(2)));
      peaks.accel_horizontal_mps2 = std::max(peaks.accel_horizontal_mps2, a.head<2>().norm());
      peaks.accel_vertical_mps2 = std::max(peaks.accel_vertical_mps2, std::abs(a(2)));
    }
  }
  return peaks;
}

double RequiredTimeScale(const DynamicPeaks& peaks, const RobotProfile& profile, double fraction) {
  const double speed =
      std::max(peaks.speed_horizontal_mps / (fraction * profile.max_speed_horizontal_mps),
               peaks.speed_vertical_mps / (fraction * profile.max_speed_vertical_mps));
  const double accel =
      std::max(peaks.accel_horizontal_mps2 / (fraction * profile.max_accel_horizontal_mps2),
               peaks.accel_vertical_mps2 / (fraction * profile.max_accel_vertical_mps2));
  return std::max({1.0, speed, std::sqrt(accel)});
}

Trajectory StretchTime(const Trajectory& trajectory, double k, const Eigen::MatrixXd& head_pva,
                       const Eigen::MatrixXd& tail_pva) {
  const int pieces = static_cast<int>(trajectory.pieces.size());
  Eigen::MatrixXd joints(trajectory.dimension, pieces - 1);
  Eigen::VectorXd durations(pieces);
  for (int i = 0; i < pieces; ++i) {
    const TrajectoryPiece& piece = trajectory.pieces[static_cast<std::size_t>(i)];
    durations(i) = k * piece.duration_s;
    if (i > 0) joints.col(i - 1) = piece.coefficients.row(0).transpose();
  }
  Minco3 minco;
  minco.SetConditions(head_pva, tail_pva, pieces);
  minco.SetParameters(joints, durations);
  return Trajectory::FromMinco(minco);
}

}  // namespace strata
