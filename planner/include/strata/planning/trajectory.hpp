#pragma once
/// The planner's output: a piecewise-quintic trajectory a robot can follow without the map.
///
/// Frame: the map's frame (the point cloud's coordinates), metres and seconds. Piece i covers
/// global time [Σ_{k<i} T_k, Σ_{k<=i} T_k]; with local time t ∈ [0, T_i] its value on axis a is
///   p_{i,a}(t) = Σ_{k=0..5} coefficients(k, a) · t^k     (lowest order first).
/// Axes 0, 1, 2 are x, y, z of the reference point (ground height + the profile's
/// reference_height_m). For active-height robots axis 3 is the commanded body height above
/// the ground [m]. Position, velocity and acceleration are continuous across pieces (C⁴).
#include <cstddef>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "strata/status.hpp"

namespace strata {

class Minco3;

/// A state vector of the trajectory (x, y, z[, body height]) or one of its derivatives:
/// fixed storage of 4, so that evaluating a trajectory (the optimiser's and the verifier's
/// inner loops) never allocates.
using StateVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 4, 1>;

struct TrajectoryPiece {
  double duration_s = 0;                                  ///< T_i [s], > 0.
  Eigen::Matrix<double, 6, Eigen::Dynamic> coefficients;  ///< 6 × dimension, see above.
};

/// Most pieces a trajectory from outside may have (a warm start, a reservation): a kilometre in
/// pieces of 1.5 m is ~700.
inline constexpr std::size_t kMaxTrajectoryPieces = 20000;

struct Trajectory {
  int dimension = 3;  ///< 3 (x, y, z) or 4 (x, y, z, body height).
  std::vector<TrajectoryPiece> pieces;

  /// kInvalidInput blaming `path`.<field> for no pieces or more than `max_pieces`
  /// ("pieces"), a duration that is not finite and > 0 ("pieces[i].duration_s"), or
  /// coefficients that are not 6 finite values per axis of `dimension`
  /// ("pieces[i].coefficients"). The dimension itself is the caller's to check.
  Status ValidatePieces(std::string_view path, std::size_t max_pieces) const;

  /// Copies the pieces of an optimised MINCO trajectory.
  static Trajectory FromMinco(const Minco3& minco);

  double TotalDuration() const;
  /// The `order`-th time derivative (0..5) at global time t [s], clamped to
  /// [0, TotalDuration()]. Precondition: at least one piece. Finds the piece by walking from
  /// the first, O(pieces): code that samples a whole trajectory uses a TrajectoryCursor.
  StateVector Evaluate(double t, int order) const;
  /// The `order`-th derivative of piece `piece` at local time t ∈ [0, T_piece] (not clamped).
  StateVector EvaluatePiece(std::size_t piece, double t, int order) const;
  StateVector Position(double t) const { return Evaluate(t, 0); }
  StateVector Velocity(double t) const { return Evaluate(t, 1); }
  StateVector Acceleration(double t) const { return Evaluate(t, 2); }
};

/// Evaluates a trajectory at global times that mostly move forward, as dense sampling does:
/// it keeps the piece of the last time asked and steps from there, so a pass over a whole
/// trajectory costs O(samples + pieces), where Trajectory::Evaluate walks from the first piece
/// each time (quadratic over a kilometre's trajectory of hundreds of pieces).
class TrajectoryCursor {
 public:
  /// `trajectory` (at least one piece) must outlive the cursor.
  explicit TrajectoryCursor(const Trajectory& trajectory) : trajectory_(trajectory) {}
  /// As Trajectory::Evaluate.
  StateVector Evaluate(double t, int order);
  StateVector Position(double t) { return Evaluate(t, 0); }
  StateVector Velocity(double t) { return Evaluate(t, 1); }
  StateVector Acceleration(double t) { return Evaluate(t, 2); }

 private:
  const Trajectory& trajectory_;
  std::size_t piece_ = 0;
  double piece_start_s_ = 0;  // Global time at which piece_ starts.
};

}  // namespace strata
