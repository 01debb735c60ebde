#pragma once
/// The optimiser's objective on a MINCO trajectory (paper "Trajectory Generation", eq. for J):
///
///   J = λ_m J_m + λ_t J_t + λ_s J_s + λ_g J_g + λ_d J_d + λ_h J_h
///
/// - J_m: jerk energy, closed form (Minco3::JerkEnergy).
/// - J_t: total duration Σ T_i.
/// - J_s: safety, C(S'(p) − s_thr) + C(d_thr − d(p)) with C(x) = max(x, 0)³ (the paper sums
///   the two arguments before cubing; separate penalties keep one from masking the other).
/// - J_e: staying on traversable ground, C(e_margin − e(p)) with e the distance to the rim of
///   the traversable region (SampleEdgeDistance). Not in the paper: S' marks the rim only as
///   rough ground, so a trajectory could cut across a corner of untraversable ground.
/// - J_g: ground following, (z − h_G(x, y) − h_ref)². Not in the paper, whose trajectories
///   float above flat ground; the smooth ground height h_G comes from SampleGround.
/// - J_d: feasibility, C(‖v_xy‖² − v_h²) + C(v_z² − v_v²) and the same for acceleration.
/// - J_h: active-height robots only. (h − h_S)² with h the body height (axis 3) and h_S the
///   most suitable height, min(preferred, ceiling clearance − headroom) clamped to
///   [h_min, h_max]; plus, weighted by λ_d·body_height_stiffness, C(h − h_max) + C(h_min − h)
///   + C(h + headroom − clearance) (each bound moved inwards by a margin).
///
/// All but J_m and J_t are integrals approximated at κ + 1 constraint points per piece,
/// t_j = (j/κ)·T_i, with trapezoid weights (T_i/κ, halved at both ends), and have exact
/// gradients wrt the coefficients c and the durations T (including dt_j/dT_i = j/κ).
#include <Eigen/Core>

#include "strata/minco.hpp"
#include "strata/robot_profile.hpp"
#include "strata/surface_graph.hpp"
#include "strata/terrain_model.hpp"

namespace strata {

/// A state vector of the trajectory (x, y, z[, body height]): fixed storage of 4, so the
/// optimiser's inner loop never allocates.
using StateVector = Eigen::Matrix<double, Eigen::Dynamic, 1, 0, 4, 1>;

/// Weights λ of the cost terms, each >= 0 and finite. A zero weight skips the term.
struct CostWeights {
  double smoothness = 1.0;     ///< λ_m [s⁵/m²].
  double time = 10.0;          ///< λ_t [1/s].
  double safety = 1.0e3;       ///< λ_s.
  double edge = 1.0e6;         ///< λ_e [1/m³].
  double ground = 1.0e4;       ///< λ_g [1/m²].
  double feasibility = 1.0e5;  ///< λ_d.
  double height = 1.0e3;       ///< λ_h [1/m²].
  Status Validate() const;
};

/// Everything the cost needs besides the weights, in SI units.
struct CostParams {
  double safety_threshold = 1.5;        ///< s_thr [-].
  double distance_threshold_m = 0.15;   ///< d_thr [m].
  double edge_margin_m = 0.1;           ///< e_margin [m].
  double reference_height_m = 0.3;      ///< h_ref [m].
  double max_speed_horizontal_mps = 1;  ///< Bounds used by J_d (already with any margin).
  double max_speed_vertical_mps = 1;
  double max_accel_horizontal_mps2 = 1;
  double max_accel_vertical_mps2 = 1;
  bool active_height = false;  ///< Adds axis 3 (body height) and J_h.
  double body_height_min_m = 0.5;
  double body_height_max_m = 0.5;
  double body_height_preferred_m = 0.5;
  double headroom_m = 0.05;
  double body_height_margin_m = 0.04;  ///< Kept inside the range and under the ceiling [m].
  /// The body-height range and ceiling penalties weigh this many times λ_d [-], >= 0. They
  /// are cubic in metres, so without it a centimetre's overshoot costs 1e-6·λ_d, less than
  /// the time it saves, and the verifier refuses the plan; the speed and acceleration
  /// penalties, cubic in squared speeds, need no such factor. On the indoor_tables benchmark
  /// (2000 biped pairs) 10 took the plans that pass verification from 96.8% to 99.5%.
  double body_height_stiffness = 10.0;
  int samples_per_piece = 8;  ///< κ, >= 2.
  /// The trajectory's dimension: 4 with active height, else 3.
  int dim() const { return active_height ? 4 : 3; }
};

/// The objective's value split by term, each already multiplied by its weight.
struct CostBreakdown {
  double smoothness = 0, time = 0, safety = 0, edge = 0, ground = 0, feasibility = 0, height = 0;
  double total() const { return smoothness + time + safety + edge + ground + feasibility + height; }
};

/// The ground under a point, smoothed across columns (see SampleGround).
struct GroundSample {
  double height_m = 0;                                           ///< h_G [m].
  Eigen::Vector2d height_gradient = Eigen::Vector2d::Zero();     ///< ∂h_G/∂(x, y) [-].
  double clearance_m = 0;                                        ///< Ceiling clearance [m], capped.
  Eigen::Vector2d clearance_gradient = Eigen::Vector2d::Zero();  ///< ∂clearance/∂(x, y).
  /// The surface of p's own column whose ground is nearest to p.z − reference height (the one
  /// p stands on); when the column has none (a hole in the map), the surface of the corner
  /// with the largest interpolation weight.
  const ColumnSurface* surface = nullptr;
};

/// The ground a reference point p stands on, as a continuous function of p: bilinear
/// interpolation between the four nearest column centres of each column's plane-fit centre
/// height (and, when clearance_cap_m > 0, of the lowest ceiling clearance of the column and
/// its 8 neighbours, capped at clearance_cap_m: a ceiling is felt half a cell before the body
/// is under it; 0 skips the clearance), taking in every column the
/// surface whose ground is nearest to p.z − reference_height_m. Corners whose ground is more
/// than 0.5 m from that height (another level: a ledge, a drop) or that have no surface get no
/// weight and the rest are renormalised, so the ground does not slope into a drop; if every
/// corner is that far, all are used. Returns false when none of the four columns has a surface
/// or p lies outside the grid.
bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample);

/// Distance from p to the rim of the traversable region [m], a continuous function of p:
/// bilinear interpolation between the four nearest column centres of each column's
/// SurfaceGraph::edge_distance at p's level (the node within 0.5 m of p.z −
/// reference_height_m), a column without such a node counting −0.5·r (its centre lies half a
/// cell outside the rim). The rim itself is at 0. Writes the gradient wrt (x, y).
double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p,
                          Eigen::Vector2d* gradient);

/// J and its gradient for one planning problem. Immutable; cheap to construct.
class TrajectoryCost {
 public:
  /// `graph` (and its model) must outlive the cost.
  TrajectoryCost(const SurfaceGraph& graph, const CostWeights& weights, const CostParams& params)
      : graph_(&graph), model_(&graph.model()), weights_(weights), params_(params) {}

  const TerrainModel& model() const { return *model_; }
  const SurfaceGraph& graph() const { return *graph_; }
  const CostWeights& weights() const { return weights_; }
  const CostParams& params() const { return params_; }

  /// J of the trajectory held by `minco` (dimension params.dim()). Writes ∂J/∂c (6M×dim) and
  /// the explicit ∂J/∂T (M), overwriting both; `breakdown` (may be null) gets the terms.
  double Evaluate(const Minco3& minco, Eigen::MatrixXd* grad_c, Eigen::VectorXd* grad_T,
                  CostBreakdown* breakdown = nullptr) const;

  /// The integrand of the constraint-point terms (λ_s, λ_e, λ_g, λ_d, λ_h parts) at one state:
  /// position (dim: x, y, z[, h]), velocity, acceleration. Writes ∂P/∂pos, ∂P/∂vel, ∂P/∂acc
  /// (each dim entries, overwritten) and adds the weighted terms into *breakdown (may be
  /// null). Exposed for tests.
  double PointPenalty(const StateVector& pos, const StateVector& vel, const StateVector& acc,
                      StateVector* grad_pos, StateVector* grad_vel, StateVector* grad_acc,
                      CostBreakdown* breakdown) const;

  /// The most suitable body height h_S at a ceiling clearance [m] (active-height robots), and
  /// its derivative wrt the clearance.
  double SuitableBodyHeight(double clearance_m, double* derivative) const;

  /// The clearance cap used by SampleGround: comfortably above every body height.
  double ClearanceCap() const;

 private:
  const SurfaceGraph* graph_;
  const TerrainModel* model_;
  CostWeights weights_;
  CostParams params_;
};

}  // namespace strata
