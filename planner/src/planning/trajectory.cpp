#include "strata/planning/trajectory.hpp"

#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <string>

#include <fmt/format.h>

#include "format_internal.hpp"
#include "strata/planning/minco.hpp"

namespace strata {

Status Trajectory::ValidatePieces(std::string_view path, std::size_t max_pieces) const {
  const auto bad = [&](const std::string& field, const std::string& what) {
    std::string name = internal::FieldPath(path, field);
    return Error{ErrorCode::kInvalidInput, name + " " + what, name};
  };
  if (pieces.empty() || pieces.size() > max_pieces) {
    return bad("pieces", fmt::format("has {} pieces; give 1 to {}", pieces.size(), max_pieces));
  }
  for (std::size_t i = 0; i < pieces.size(); ++i) {
    const TrajectoryPiece& piece = pieces[i];
    const std::string at = fmt::format("pieces[{}]", i);
    if (!(std::isfinite(piece.duration_s) && piece.duration_s > 0)) {
      return bad(at + ".duration_s", "must be > 0 and finite");
    }
    if (piece.coefficients.rows() != 6 || piece.coefficients.cols() != dimension ||
        !piece.coefficients.allFinite()) {
      return bad(at + ".coefficients", "must hold 6 finite coefficients per axis");
    }
  }
  return Status::Ok();
}

Trajectory Trajectory::FromMinco(const Minco3& minco) {
  Trajectory trajectory;
  trajectory.dimension = minco.dim();
  trajectory.pieces.resize(static_cast<std::size_t>(minco.piece_count()));
  for (int i = 0; i < minco.piece_count(); ++i) {
    TrajectoryPiece& piece = trajectory.pieces[static_cast<std::size_t>(i)];
    piece.duration_s = minco.durations()(i);
    piece.coefficients =
        minco.coefficients().middleRows(Minco3::kPieceCoefficients * i, Minco3::kPieceCoefficients);
  }
  return trajectory;
}

double Trajectory::TotalDuration() const {
  double total = 0;
  for (const TrajectoryPiece& piece : pieces) total += piece.duration_s;
  return total;
}

StateVector Trajectory::Evaluate(double t, int order) const {
  return TrajectoryCursor(*this).Evaluate(t, order);
}

StateVector Trajectory::EvaluatePiece(std::size_t i, double t, int order) const {
  assert(i < pieces.size() && order >= 0 && order <= 5 &&
         pieces[i].coefficients.cols() == dimension);
  // Horner on the order-th derivative: Σ_{k>=order} k!/(k-order)! c_k t^(k-order), axis by
  // axis over the column-major coefficients (a hot loop of verification and statistics).
  const std::array<double, 6>& factor = kQuinticDerivativeFactor[order];
  const double* column = pieces[i].coefficients.data();
  StateVector value(dimension);
  for (int axis = 0; axis < dimension; ++axis, column += 6) {
    double v = 0;
    for (int k = 5; k >= order; --k) v = v * t + factor[k] * column[k];
    value(axis) = v;
  }
  return value;
}

StateVector TrajectoryCursor::Evaluate(double t, int order) {
  const std::vector<TrajectoryPiece>& pieces = trajectory_.pieces;
  assert(!pieces.empty() && order >= 0 && order <= 5);
  t = std::max(t, 0.0);
  while (piece_ > 0 && t < piece_start_s_) piece_start_s_ -= pieces[--piece_].duration_s;
  while (piece_ + 1 < pieces.size() && t > piece_start_s_ + pieces[piece_].duration_s) {
    piece_start_s_ += pieces[piece_++].duration_s;
  }
  return trajectory_.EvaluatePiece(
      piece_, std::clamp(t - piece_start_s_, 0.0, pieces[piece_].duration_s), order);
}

}  // namespace strata
