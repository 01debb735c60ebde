#pragma once
/// The optimiser's objective on a MINCO trajectory (paper "Trajectory Generation", eq. for J):
///
///   J = λ_m J_m + λ_t J_t + λ_s J_s + λ_e J_e + λ_g J_g + λ_d J_d + λ_k J_k + λ_h J_h
///
/// - J_m: jerk energy, closed form (Minco3::JerkEnergy).
/// - J_t: total duration Σ T_i.
/// - J_s: safety, C(S'(p) − s_thr) + k_d·C(d_thr − d(p)) with C(x) = max(x, 0)³ (the paper
///   sums the two arguments before cubing; separate penalties keep one from masking the
///   other, and k_d, CostConfig::distance_stiffness, makes the metres' cube count).
/// - J_e: staying on traversable ground, C(e_margin − e(p)) with e the distance to the rim of
///   the traversable region (SampleEdgeDistance, terrain_query.hpp). Not in the paper: S' marks the
///   rim only as rough ground, so a trajectory could cut across a corner of untraversable ground.
/// - J_g: ground following, D(z − h_G(x, y) − h_ref)² with D the dead band of
///   CostConfig::ground_band_m (offsets within it cost nothing). Not in the paper, whose
///   trajectories float above flat ground; the smooth ground height h_G comes from SampleGround
///   (terrain_query.hpp).
/// - J_d: feasibility, C(‖v_xy‖² − v_h²) + C(v_z² − v_v²) and the same for acceleration.
/// - J_k: keep-out zones (keep_out.hpp), C(r + k_margin − sd(x, y)) · g(o) per zone, with r the
///   footprint radius, sd the signed horizontal distance to the zone's polygon (negative
///   inside) and g a C¹ smoothstep of the vertical overlap o of the robot's height range with
///   the zone's (KeepOutVerticalOverlap): 1 where they overlap (o >= 0), 0 where they are
///   more than k_margin apart, so a zone on another storey costs nothing. Not in the paper.
/// - J_h: active-height robots only. (h − h_S)² with h the body height (axis 3) and h_S the
///   most suitable height, min(preferred, ceiling clearance − headroom) clamped to
///   [h_min, h_max]; plus, weighted by λ_d·body_height_stiffness, C(h − h_max) + C(h_min − h)
///   + C(h + headroom − clearance) (each bound moved inwards by a margin).
///
/// All but J_m and J_t are integrals approximated at κ + 1 constraint points per piece,
/// t_j = (j/κ)·T_i, with trapezoid weights (T_i/κ, halved at both ends), and have exact
/// gradients wrt the coefficients c and the durations T (including dt_j/dT_i = j/κ).
#include <span>
#include <string_view>

#include <Eigen/Core>

#include "strata/assessment/terrain_model.hpp"
#include "strata/planning/keep_out.hpp"
#include "strata/planning/minco.hpp"
#include "strata/planning/robot_profile.hpp"
#include "strata/planning/surface_graph.hpp"
#include "strata/planning/terrain_query.hpp"
#include "strata/planning/trajectory.hpp"

namespace strata {

/// Weights λ of the cost terms, each >= 0 and finite. A zero weight skips the term.
struct CostWeights {
  double smoothness = 1.0;     ///< λ_m [s⁵/m²].
  double time = 10.0;          ///< λ_t [1/s].
  double safety = 1.0e3;       ///< λ_s.
  double edge = 1.0e6;         ///< λ_e [1/m³].
  double ground = 1.0e4;       ///< λ_g [1/m²].
  double feasibility = 1.0e5;  ///< λ_d.
  double height = 1.0e3;       ///< λ_h [1/m²].
  /// λ_k [1/m³]. As stiff as λ_e: a centimetre into the zone's margin must cost more than the
  /// time a detour takes.
  double keep_out = 1.0e6;
  /// λ_ω [1/rad]: J_ω, the robot's total turning in x, y (∫|ω| dt, ω its heading rate), so a
  /// radian of turning weighs as much as 2 s of travel (λ_t = 10). Without it the time term
  /// swings trajectories wide before corners, to take them faster, which adds a turn the
  /// other way (docs/benchmarks.md, "Why the planner's defaults").
  double turning = 20.0;
  /// kInvalidConfig blaming the first bad weight by its path, `path`.<field>.
  Status Validate(std::string_view path = "weights") const;
};

/// Thresholds and margins of the cost terms (OptimizerConfig::cost). Validate() blames the
/// first bad field by its path, `path`.<field>.
struct CostConfig {
  /// S' above this is penalised (s_thr) [-], >= 0. S' is the cone-diffused S, normalised to
  /// unit kernel sum, so this is a weighted mean of λ_f φ² + λ_m sqrt(‖∇H‖) nearby. On the
  /// shared maps the median S' over ramps is ~0.5 and the 90th percentile ~2.8 (their
  /// voxelised ramps are staircases), near the rim of valid ground it climbs to ~5.
  double safety_threshold = 1.5;
  /// Within this horizontal distance of the trajectory's start and goal [m], >= 0, the S'
  /// part of J_s fades in (the product of a smoothstep of the distance to each end; 0 turns
  /// the fade off). The ends are fixed, and a robot that starts or stops beside a wall or a
  /// rim, where S' is high, turned away from it on the spot and back: on 150 random pairs the
  /// median curvature fell from 0.315 to 0.277 on stairs_ramp_room and from 0.232 to 0.201 on
  /// indoor_tables (biped). The obstacle-distance part of J_s does not fade.
  double safety_fade_m = 1.5;
  /// ESDF distance below this is penalised (d_thr) [m], > 0. Keep it below the profile's
  /// reference height: the ground itself is an obstacle that far below the reference point.
  double distance_threshold_m = 0.15;
  /// The obstacle-distance part of J_s weighs this many times λ_s [-], >= 0. It is cubic in
  /// metres: without it a reference point 5 cm from a wall cost 10⁻³·λ_s per second, less
  /// than the time it saves by cutting a corner, and the verifier (obstacle distance >= 5 cm)
  /// refused the plan. On the spiral at 0.3 m (200 pairs) 30 removed every such refusal; 1000
  /// also held biped trajectories away from the tables they crouch under.
  double distance_stiffness = 30.0;
  /// Distance to the rim of traversable ground below which J_e penalises (e_margin) [m], in
  /// [0, 1]; at most half a grid cell keeps the centres of rim cells free of penalty.
  double edge_margin_m = 0.1;
  /// J_g penalises the reference point's height offset from ground + reference height only
  /// beyond this band [m], >= 0, below the verifier's ground tolerance. A pull on every
  /// centimetre of offset pulled the trajectory sideways on slopes as well (towards where the
  /// ground lay at its height): gentle weaving that added a fifth to the median curvature on
  /// uneven_terrain.
  double ground_band_m = 0.01;
  /// The speed and acceleration bounds J_d aims for, as a fraction of the profile's, in
  /// (0, 1]: penalties are soft, so aiming a little low lands within them.
  double limit_margin = 0.96;
  /// Active-height robots: how far inside [h_min, h_max] and below the ceiling (less
  /// headroom) the optimiser keeps the body [m], >= 0. Like limit_margin, it lets the
  /// polynomial between constraint points stay within the verified range. Where a passage
  /// leaves less room than twice this, the margin shrinks to half the room.
  double body_height_margin_m = 0.04;
  /// The body-height range and ceiling penalties weigh this many times λ_d [-], >= 0. They
  /// are cubic in metres, so without it a centimetre's overshoot costs 1e-6·λ_d, less than
  /// the time it saves, and the verifier refuses the plan; the speed and acceleration
  /// penalties, cubic in squared speeds, need no such factor.
  double body_height_stiffness = 10.0;
  /// How far beyond the robot's footprint J_k keeps the reference point from a keep-out
  /// zone's polygon, and how far above or below the zone's height range it starts to act
  /// (k_margin) [m], in [0, 1]. Like limit_margin, it lets the polynomial between constraint
  /// points stay out of the zone the verifier checks.
  double keep_out_margin_m = 0.1;
  /// Constraint points per piece κ (trapezoid over κ + 1 samples), >= 2.
  int samples_per_piece = 8;
  Status Validate(std::string_view path = "cost") const;
};

/// Everything the cost needs besides the weights: the robot (reference height h_ref, speed and
/// acceleration bounds, body heights, headroom) and the cost's settings, each held as it is,
/// never copied field by field; what the terms use is derived below.
struct CostParams {
  RobotProfile profile;
  CostConfig config;

  /// Bounds used by J_d: the profile's, times config.limit_margin.
  double max_speed_horizontal_mps() const {
    return config.limit_margin * profile.max_speed_horizontal_mps;
  }
  double max_speed_vertical_mps() const {
    return config.limit_margin * profile.max_speed_vertical_mps;
  }
  double max_accel_horizontal_mps2() const {
    return config.limit_margin * profile.max_accel_horizontal_mps2;
  }
  double max_accel_vertical_mps2() const {
    return config.limit_margin * profile.max_accel_vertical_mps2;
  }
  /// The trajectory's dimension: 4 with active height (axis 3, the body height, and J_h),
  /// else 3.
  int dim() const { return profile.active_height ? 4 : 3; }
};

/// The objective's value split by term, each already multiplied by its weight.
struct CostBreakdown {
  double smoothness = 0, time = 0, safety = 0, edge = 0, ground = 0, feasibility = 0, height = 0,
         keep_out = 0, turning = 0;
  double total() const {
    return smoothness + time + safety + edge + ground + feasibility + height + keep_out + turning;
  }
};

/// Where a trajectory starts and ends in x, y [m]: the S' part of J_s fades in from both
/// (CostConfig::safety_fade_m).
struct TrajectoryEnds {
  Eigen::Vector2d start_xy;
  Eigen::Vector2d goal_xy;
};

/// What each constraint point of one optimisation learnt of the terrain where it was last
/// evaluated: the block of the fields where the S' and d terms are zero at every point, the
/// column where the rim term is, and the corner surfaces its ground stands on. Nearly every
/// point of a plan is far from walls and rims, and between two L-BFGS evaluations most stay
/// in their block and column: those skip the lookups and get the same cost and gradient to
/// the bit. With the body height fixed, a point whose corners show the ground within J_g's
/// band (GroundWithinBand) skips the ground sample too. Every entry is checked against its point
/// before use, so a stale one is never wrong, only useless. Points are numbered by piece and sample
/// (Evaluate resizes the memo to the trajectory's); OptimizerObjective keeps one per optimisation.
struct TerrainMemo {
  struct Point {
    std::int64_t quiet_field_block = -1;  ///< TerrainFields::BlockKey, or -1.
    DeepInside deep_inside;               ///< Where the rim term is zero; empty if unknown.
    GroundChoice ground;                  ///< SampleGround's corner surfaces.
  };
  std::vector<Point> points;
};

/// One state of the trajectory at a constraint point: position (dim: x, y, z[, h]),
/// velocity, acceleration.
struct PointState {
  const StateVector& pos;
  const StateVector& vel;
  const StateVector& acc;
};

/// The gradient of a constraint point's penalty with respect to its state (dim entries each).
struct PointGradient {
  StateVector pos, vel, acc;
  explicit PointGradient(int dim = 3) : pos(dim), vel(dim), acc(dim) {}
};

/// J and its gradient for one planning problem. Immutable; cheap to construct.
class TrajectoryCost {
 public:
  /// `graph` (and its model) and `keep_out` (the zones J_k keeps the robot out of) must
  /// outlive the cost.
  TrajectoryCost(const SurfaceGraph& graph, const CostWeights& weights, const CostParams& params,
                 std::span<const KeepOutZone> keep_out = {})
      : graph_(&graph),
        model_(&graph.model()),
        weights_(weights),
        params_(params),
        keep_out_(keep_out) {}

  const TerrainModel& model() const { return *model_; }
  const SurfaceGraph& graph() const { return *graph_; }
  const CostWeights& weights() const { return weights_; }
  const CostParams& params() const { return params_; }
  std::span<const KeepOutZone> keep_out() const { return keep_out_; }

  /// J of the trajectory held by `minco` (dimension params.dim()). Writes ∂J/∂c (6M×dim) and
  /// the explicit ∂J/∂T (M), overwriting both; `breakdown` (may be null) gets the terms.
  /// `memo` (may be null) is read and updated; the result is the same with or without it.
  double Evaluate(const Minco3& minco, Eigen::MatrixXd* grad_c, Eigen::VectorXd* grad_T,
                  CostBreakdown* breakdown = nullptr, TerrainMemo* memo = nullptr) const;

  /// The integrand of the constraint-point terms (λ_s, λ_e, λ_g, λ_d, λ_k, λ_h parts) at one
  /// state. Writes its gradient (overwritten) and adds the weighted terms into *breakdown (may
  /// be null). With `ends` (Evaluate passes the trajectory's), the S' part fades in from them
  /// over CostConfig::safety_fade_m; without, it applies in full. With `memo`, skips what it
  /// knows to be zero there and updates it. Exposed for tests.
  double PointPenalty(const PointState& state, PointGradient* gradient, CostBreakdown* breakdown,
                      const TrajectoryEnds* ends = nullptr,
                      TerrainMemo::Point* memo = nullptr) const;

  /// The most suitable body height h_S at a ceiling clearance [m] (active-height robots), and
  /// its derivative wrt the clearance.
  double SuitableBodyHeight(double clearance_m, double* derivative) const;

  /// The clearance cap used by SampleGround: comfortably above every body height.
  double ClearanceCap() const;

 private:
  // The terms of PointPenalty, one function each, in the order it adds them: each adds its
  // weighted value into *terms and its gradient into *gradient.
  void AddSafety(const Eigen::Vector3d& p, const TrajectoryEnds* ends, TerrainMemo::Point* memo,
                 PointGradient* gradient, CostBreakdown* terms) const;
  void AddEdge(const Eigen::Vector3d& p, TerrainMemo::Point* memo, PointGradient* gradient,
               CostBreakdown* terms) const;
  void AddKeepOut(const Eigen::Vector3d& p, PointGradient* gradient, CostBreakdown* terms) const;
  void AddGround(const Eigen::Vector3d& p, const GroundSample& ground, PointGradient* gradient,
                 CostBreakdown* terms) const;
  void AddFeasibility(const PointState& state, PointGradient* gradient, CostBreakdown* terms) const;
  void AddTurning(const PointState& state, PointGradient* gradient, CostBreakdown* terms) const;
  void AddBodyHeight(double h, const GroundSample& ground, PointGradient* gradient,
                     CostBreakdown* terms) const;

  const SurfaceGraph* graph_;
  const TerrainModel* model_;
  CostWeights weights_;
  CostParams params_;
  std::span<const KeepOutZone> keep_out_;
};

}  // namespace strata
