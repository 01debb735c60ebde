#pragma once
/// The optimiser's objective on a MINCO trajectory (paper "Trajectory Generation", eq. for J):
///
///   J = λ_m J_m + λ_t J_t + λ_s J_s + λ_g J_g + λ_d J_d + λ_h J_h
///
/// - J_m: jerk energy, closed form (Minco3::JerkEnergy).
/// - J_t: total duration Σ T_i.
/// - J_s: safety, C(S'(p) − s_thr) + C(d_thr − d(p)) with C(x) = max(x, 0)³ (the paper sums
///   the two arguments before cubing; separate penalties keep one from masking the other).
/// - J_g: ground following, (z − h_G(x, y) − h_ref)². Not in the paper, whose trajectories
///   float above flat ground; the smooth ground height h_G comes from SampleGround.
/// - J_d: feasibility, C(‖v_xy‖² − v_h²) + C(v_z² − v_v²) and the same for acceleration.
/// - J_h: active-height robots only. (h − h_S)² with h the body height (axis 3) and h_S the
///   most suitable height, min(preferred, ceiling clearance − headroom) clamped to
///   [h_min, h_max]; plus C(h − h_max) + C(h_min − h) + C(h + headroom − clearance).
///
/// All but J_m and J_t are integrals approximated at κ + 1 constraint points per piece,
/// t_j = (j/κ)·T_i, with trapezoid weights (T_i/κ, halved at both ends), and have exact
/// gradients wrt the coefficients c and the durations T (including dt_j/dT_i = j/κ).
#include <Eigen/Core>

#include "strata/minco.hpp"
#include "strata/robot_profile.hpp"
#include "strata/terrain_model.hpp"

namespace strata {

/// Weights λ of the cost terms, each >= 0 and finite. A zero weight skips the term.
struct CostWeights {
  double smoothness = 1.0;     ///< λ_m [s⁵/m²].
  double time = 10.0;          ///< λ_t [1/s].
  double safety = 1.0e4;       ///< λ_s.
  double ground = 1.0e4;       ///< λ_g [1/m²].
  double feasibility = 1.0e4;  ///< λ_d.
  double height = 1.0e3;       ///< λ_h [1/m²].
  Status Validate() const;
};

/// Everything the cost needs besides the weights, in SI units.
struct CostParams {
  double safety_threshold = 0.5;        ///< s_thr [-].
  double distance_threshold_m = 0.15;   ///< d_thr [m].
  double reference_height_m = 0.3;      ///< h_ref [m].
  double max_speed_horizontal_mps = 1;  ///< Bounds used by J_d (already with any margin).
  double max_speed_vertical_mps = 1;
  double max_accel_horizontal_mps2 = 1;
  double max_accel_vertical_mps2 = 1;
  bool active_height = false;           ///< Adds axis 3 (body height) and J_h.
  double body_height_min_m = 0.5;
  double body_height_max_m = 0.5;
  double body_height_preferred_m = 0.5;
  double headroom_m = 0.05;
  int samples_per_piece = 8;            ///< κ, >= 2.
  /// The trajectory's dimension: 4 with active height, else 3.
  int dim() const { return active_height ? 4 : 3; }
};

/// The objective's value split by term, each already multiplied by its weight.
struct CostBreakdown {
  double smoothness = 0, time = 0, safety = 0, ground = 0, feasibility = 0, height = 0;
  double total() const { return smoothness + time + safety + ground + feasibility + height; }
};

/// The ground under a point, smoothed across columns (see SampleGround).
struct GroundSample {
  double height_m = 0;                                  ///< h_G [m].
  Eigen::Vector2d height_gradient = Eigen::Vector2d::Zero();     ///< ∂h_G/∂(x, y) [-].
  double clearance_m = 0;                               ///< Ceiling clearance [m], capped.
  Eigen::Vector2d clearance_gradient = Eigen::Vector2d::Zero();  ///< ∂clearance/∂(x, y).
};

/// The ground a reference point p stands on, as a smooth function of (x, y): bilinear
/// interpolation between the four nearest column centres of each column's plane-fit centre
/// height (and ceiling clearance, capped at `clearance_cap_m`), taking in every column the
/// highest surface at or below the point p.z − reference_height_m + half a cell. A neighbour
/// column whose surface is more than a cell away in height from the one under p (a ledge, a
/// deck's edge, a void) contributes the value under p instead, so the ground does not slope
/// into a drop. Returns false when nothing is below p in its own column.
bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample);

/// J and its gradient for one planning problem. Immutable; cheap to construct.
class TrajectoryCost {
 public:
  TrajectoryCost(const TerrainModel& model, const CostWeights& weights, const CostParams& params)
      : model_(&model), weights_(weights), params_(params) {}

  const TerrainModel& model() const { return *model_; }
  const CostWeights& weights() const { return weights_; }
  const CostParams& params() const { return params_; }

  /// J of the trajectory held by `minco` (dimension params.dim()). Writes ∂J/∂c (6M×dim) and
  /// the explicit ∂J/∂T (M), overwriting both; `breakdown` (may be null) gets the terms.
  double Evaluate(const Minco3& minco, Eigen::MatrixXd* grad_c, Eigen::VectorXd* grad_T,
                  CostBreakdown* breakdown = nullptr) const;

  /// The integrand of the constraint-point terms (λ_s, λ_g, λ_d, λ_h parts) at one state:
  /// position (dim: x, y, z[, h]), velocity, acceleration. Adds ∂P/∂pos, ∂P/∂vel, ∂P/∂acc
  /// into the given vectors (each dim entries) and the terms into *breakdown. Exposed for
  /// tests.
  double PointPenalty(const Eigen::VectorXd& pos, const Eigen::VectorXd& vel,
                      const Eigen::VectorXd& acc, Eigen::VectorXd* grad_pos,
                      Eigen::VectorXd* grad_vel, Eigen::VectorXd* grad_acc,
                      CostBreakdown* breakdown) const;

  /// The most suitable body height h_S at a ceiling clearance [m] (active-height robots), and
  /// its derivative wrt the clearance.
  double SuitableBodyHeight(double clearance_m, double* derivative) const;

  /// The clearance cap used by SampleGround: comfortably above every body height.
  double ClearanceCap() const;

 private:
  const TerrainModel* model_;
  CostWeights weights_;
  CostParams params_;
};

}  // namespace strata
