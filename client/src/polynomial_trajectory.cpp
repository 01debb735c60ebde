#include "strata/client/polynomial_trajectory.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

#include "strata/v1/planner_service.pb.h"
#include "strata/v1/trajectory.pb.h"

namespace strata::client {
namespace {

std::string Number(double value) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", value);
  return buffer;
}

ClientError Invalid(const std::string& what) { return ClientError{"invalid trajectory: " + what}; }

// k! / (k - order)!, the factor d^order/dt^order brings to c_k t^k.
double FallingFactorial(int k, int order) {
  double product = 1;
  for (int j = 0; j < order; ++j) product *= k - j;
  return product;
}

}  // namespace

Expected<PolynomialTrajectory> PolynomialTrajectory::FromProto(const v1::Trajectory& trajectory) {
  const int dimension = trajectory.dimension();
  if (dimension != 3 && dimension != 4) {
    return Invalid("dimension is " + std::to_string(dimension) +
                   "; it must be 3 (x, y, z) or 4 (x, y, z, body height)");
  }
  if (trajectory.pieces_size() == 0) return Invalid("it has no pieces; at least one is needed");

  PolynomialTrajectory result;
  result.dimension_ = dimension;
  result.pieces_.reserve(static_cast<std::size_t>(trajectory.pieces_size()));
  double start_s = 0;
  for (int i = 0; i < trajectory.pieces_size(); ++i) {
    const v1::TrajectoryPiece& source = trajectory.pieces(i);
    const std::string name = "pieces[" + std::to_string(i) + "]";
    if (!std::isfinite(source.duration_s()) || source.duration_s() <= 0) {
      return Invalid(name + ".duration_s is " + Number(source.duration_s()) +
                     " s; it must be > 0 and finite");
    }
    if (source.axes_size() != dimension) {
      return Invalid(name + " has " + std::to_string(source.axes_size()) +
                     " axes; the trajectory's dimension is " + std::to_string(dimension));
    }
    Piece piece;
    piece.start_s = start_s;
    piece.duration_s = source.duration_s();
    piece.coefficients.resize(dimension, kCoefficientsPerAxis);
    for (int a = 0; a < dimension; ++a) {
      const v1::Polynomial& axis = source.axes(a);
      const std::string axis_name = name + ".axes[" + std::to_string(a) + "]";
      if (axis.coefficients_size() != kCoefficientsPerAxis) {
        return Invalid(axis_name + " has " + std::to_string(axis.coefficients_size()) +
                       " coefficients; a quintic needs exactly 6 (c_0 … c_5)");
      }
      for (int k = 0; k < kCoefficientsPerAxis; ++k) {
        if (!std::isfinite(axis.coefficients(k))) {
          return Invalid(axis_name + ".coefficients[" + std::to_string(k) + "] is " +
                         Number(axis.coefficients(k)) + "; coefficients must be finite");
        }
        piece.coefficients(a, k) = axis.coefficients(k);
      }
    }
    start_s += piece.duration_s;
    result.pieces_.push_back(std::move(piece));
  }
  if (!std::isfinite(start_s)) return Invalid("the total duration overflows");
  const double declared = trajectory.duration_s();
  if (declared != 0 && !(std::abs(declared - start_s) <= 1e-9 * std::max(1.0, start_s))) {
    return Invalid("duration_s is " + Number(declared) + " s but the pieces last " +
                   Number(start_s) + " s in total");
  }
  result.duration_s_ = start_s;
  return result;
}

Expected<PolynomialTrajectory> PolynomialTrajectory::FromPlanResponse(
    const v1::PlanResponse& response) {
  if (!response.has_trajectory()) {
    return ClientError{"invalid plan response: it has no trajectory"};
  }
  return FromProto(response.trajectory());
}

std::size_t PolynomialTrajectory::PieceAt(double t_s) const {
  // The last piece whose start is <= t; a time on a joint belongs to the later piece.
  const auto after = std::upper_bound(pieces_.begin(), pieces_.end(), t_s,
                                      [](double t, const Piece& p) { return t < p.start_s; });
  if (after == pieces_.begin()) return 0;
  return static_cast<std::size_t>(after - pieces_.begin()) - 1;
}

Eigen::VectorXd PolynomialTrajectory::EvaluatePiece(std::size_t piece, double t_s,
                                                    int order) const {
  const auto& c = pieces_[piece].coefficients;
  Eigen::VectorXd value = Eigen::VectorXd::Zero(dimension_);
  if (order < 0 || order > kMaxOrder) return value;
  for (int a = 0; a < dimension_; ++a) {
    // Horner on the derivative's coefficients c_k k!/(k-order)!, k = order … 5.
    double sum = 0;
    for (int k = kCoefficientsPerAxis - 1; k >= order; --k) {
      sum = sum * t_s + FallingFactorial(k, order) * c(a, k);
    }
    value[a] = sum;
  }
  return value;
}

Eigen::VectorXd PolynomialTrajectory::Evaluate(double t_s, int order) const {
  if (std::isnan(t_s)) {
    return Eigen::VectorXd::Constant(dimension_, std::numeric_limits<double>::quiet_NaN());
  }
  if (t_s > duration_s_) {
    if (order > 0) return Eigen::VectorXd::Zero(dimension_);
    return EvaluatePiece(pieces_.size() - 1, pieces_.back().duration_s, 0);
  }
  if (t_s <= 0) return EvaluatePiece(0, 0.0, order);
  const std::size_t i = PieceAt(t_s);
  const double local_s = std::min(t_s - pieces_[i].start_s, pieces_[i].duration_s);
  return EvaluatePiece(i, local_s, order);
}

TrajectoryState PolynomialTrajectory::StateAt(double t_s) const {
  TrajectoryState state;
  state.time_s = t_s;
  const Eigen::VectorXd position = Evaluate(t_s, 0);
  const Eigen::VectorXd velocity = Evaluate(t_s, 1);
  state.position_m = position.head<3>();
  state.velocity_mps = velocity.head<3>();
  state.acceleration_mps2 = Evaluate(t_s, 2).head<3>();
  state.jerk_mps3 = Evaluate(t_s, 3).head<3>();
  if (dimension_ == 4) {
    state.body_height_m = position[3];
    state.body_height_rate_mps = velocity[3];
  }
  return state;
}

}  // namespace strata::client
