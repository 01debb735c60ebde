#include "strata/planning/trajectory_costs.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <string>

#include "format_internal.hpp"

namespace strata {
namespace {

// Cubic penalty C(x) = max(x, 0)³ and its derivative 3·max(x, 0)².
struct Cubic {
  double value = 0;
  double slope = 0;
};
Cubic CubicPenalty(double x) {
  if (x <= 0) return {};
  return {x * x * x, 3 * x * x};
}

// J_ω's heading rate is ω = (v × a)_z / (‖v‖² + v_f²) with this v_f [m/s]: near rest the
// heading is the direction the robot sets off in, not a turn.
constexpr double kTurnSpeedFloorMps = 0.1;
// J_ω's |ω| is smoothed to sqrt(ω² + ε²) − ε with this ε [rad/s].
constexpr double kTurnRateSmoothing = 0.05;

// How far inside its threshold a field block's corners must be for TerrainMemo to call its
// terms zero: far above the rounding of a trilinear interpolation of values of order 1–100.
constexpr double kInterpolationRounding = 1e-9;

// The smoothstep 3u² − 2u³ of u clamped to [0, 1], and its derivative (C¹: 0 at both ends).
Cubic Smoothstep(double u) {
  if (u <= 0) return {};
  if (u >= 1) return {1, 0};
  return {u * u * (3 - 2 * u), 6 * u * (1 - u)};
}

// β(t) and its first three derivatives: row k holds d^k/dt^k [1, t, …, t⁵].
Eigen::Matrix<double, 4, 6> Basis(double t) {
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t, t5 = t4 * t;
  Eigen::Matrix<double, 4, 6> b;
  b << 1, t, t2, t3, t4, t5, 0, 1, 2 * t, 3 * t2, 4 * t3, 5 * t4, 0, 0, 2, 6 * t, 12 * t2, 20 * t3,
      0, 0, 0, 6, 24 * t, 60 * t2;
  return b;
}

// How much of the S' part of J_s applies at p (CostConfig::safety_fade_m): the product of a
// smoothstep of the distance to each end over fade_m, and its gradient in x, y [1/m].
struct SafetyFade {
  double scale = 1;
  Eigen::Vector2d gradient = Eigen::Vector2d::Zero();
};
SafetyFade SafetyFadeAt(const Eigen::Vector2d& p, const TrajectoryEnds& ends, double fade_m) {
  SafetyFade fade;
  if (fade_m <= 0) return fade;
  const Eigen::Vector2d end_xy[2] = {ends.start_xy, ends.goal_xy};
  Cubic step[2];
  Eigen::Vector2d away[2];
  for (int k = 0; k < 2; ++k) {
    const Eigen::Vector2d offset = p - end_xy[k];
    const double distance = offset.norm();
    step[k] = Smoothstep(distance / fade_m);
    away[k] = distance > 1e-12 ? Eigen::Vector2d(offset / distance) : Eigen::Vector2d::Zero();
  }
  fade.scale = step[0].value * step[1].value;
  fade.gradient =
      (step[0].slope * step[1].value * away[0] + step[0].value * step[1].slope * away[1]) / fade_m;
  return fade;
}

}  // namespace

Status CostWeights::Validate(std::string_view path) const {
  const std::pair<const char*, double> fields[] = {
      {"smoothness", smoothness}, {"time", time},
      {"safety", safety},         {"edge", edge},
      {"ground", ground},         {"feasibility", feasibility},
      {"height", height},         {"keep_out", keep_out},
      {"turning", turning}};
  for (const auto& [name, value] : fields) {
    if (!(std::isfinite(value) && value >= 0)) {
      return internal::OutOfRange(internal::FieldPath(path, name), value, ">= 0 and finite");
    }
  }
  return Status::Ok();
}

Status CostConfig::Validate(std::string_view path) const {
  const auto bad_field = [path](const char* field, double value, const char* range) {
    return internal::OutOfRange(internal::FieldPath(path, field), value, range);
  };
  if (!(std::isfinite(safety_threshold) && safety_threshold >= 0)) {
    return bad_field("safety_threshold", safety_threshold, ">= 0 and finite");
  }
  if (!(std::isfinite(ground_band_m) && ground_band_m >= 0 && ground_band_m <= 0.5)) {
    return bad_field("ground_band_m", ground_band_m, "in [0, 0.5] m");
  }
  if (!(std::isfinite(edge_margin_m) && edge_margin_m >= 0 && edge_margin_m <= 1)) {
    return bad_field("edge_margin_m", edge_margin_m, "in [0, 1] m");
  }
  if (!(std::isfinite(safety_fade_m) && safety_fade_m >= 0)) {
    return bad_field("safety_fade_m", safety_fade_m, ">= 0 and finite");
  }
  if (!(std::isfinite(distance_threshold_m) && distance_threshold_m > 0)) {
    return bad_field("distance_threshold_m", distance_threshold_m, "> 0 and finite");
  }
  if (!(limit_margin > 0 && limit_margin <= 1)) {
    return bad_field("limit_margin", limit_margin, "in (0, 1]");
  }
  if (!(std::isfinite(body_height_margin_m) && body_height_margin_m >= 0)) {
    return bad_field("body_height_margin_m", body_height_margin_m, ">= 0 and finite");
  }
  if (!(std::isfinite(distance_stiffness) && distance_stiffness >= 0)) {
    return bad_field("distance_stiffness", distance_stiffness, ">= 0 and finite");
  }
  if (!(std::isfinite(body_height_stiffness) && body_height_stiffness >= 0)) {
    return bad_field("body_height_stiffness", body_height_stiffness, ">= 0 and finite");
  }
  if (!(std::isfinite(keep_out_margin_m) && keep_out_margin_m >= 0 && keep_out_margin_m <= 1)) {
    return bad_field("keep_out_margin_m", keep_out_margin_m, "in [0, 1] m");
  }
  if (samples_per_piece < 2) return bad_field("samples_per_piece", samples_per_piece, ">= 2");
  return Status::Ok();
}

double TrajectoryCost::SuitableBodyHeight(double clearance_m, double* derivative) const {
  const RobotProfile& robot = params_.profile;
  const double h_min = robot.MinBodyHeight(), h_max = robot.MaxBodyHeight();
  double h = robot.body_height_m;  // The preferred height.
  double slope = 0;
  if (clearance_m - robot.headroom_m < h) {
    h = clearance_m - robot.headroom_m;
    slope = 1;
  }
  if (h < h_min || h > h_max) {
    h = std::clamp(h, h_min, h_max);
    slope = 0;
  }
  if (derivative != nullptr) *derivative = slope;
  return h;
}

double TrajectoryCost::ClearanceCap() const {
  const RobotProfile& robot = params_.profile;
  return std::max(robot.MaxBodyHeight(), robot.body_height_m) + robot.headroom_m + 1.0;
}

double TrajectoryCost::PointPenalty(const PointState& state, PointGradient* gradient,
                                    CostBreakdown* breakdown, const TrajectoryEnds* ends,
                                    TerrainMemo::Point* memo) const {
  const CostWeights& w = weights_;
  const CostConfig& c = params_.config;
  const RobotProfile& robot = params_.profile;
  const bool active_height = robot.active_height;
  const int dim = static_cast<int>(state.pos.size());
  gradient->pos.setZero(dim);
  gradient->vel.setZero(dim);
  gradient->acc.setZero(dim);
  const Eigen::Vector3d p = state.pos.head<3>();
  CostBreakdown terms;

  AddSafety(p, ends, memo, gradient, &terms);
  AddEdge(p, memo, gradient, &terms);
  AddKeepOut(p, gradient, &terms);
  // Only J_g needs the ground when the body's height is fixed, and J_g is zero within the
  // band: where the memo's choice shows the ground there, the sample is skipped.
  const bool height_terms = active_height && (w.height > 0 || w.feasibility > 0);
  const bool ground_in_band =
      memo != nullptr && !height_terms &&
      GroundWithinBand(memo->ground, p, robot.reference_height_m, c.ground_band_m);
  GroundSample ground;
  const bool has_ground =
      !ground_in_band && (w.ground > 0 || height_terms) &&
      SampleGround(*model_, p, robot.reference_height_m, active_height ? ClearanceCap() : 0,
                   &ground, memo != nullptr ? &memo->ground : nullptr);
  if (has_ground && w.ground > 0) AddGround(p, ground, gradient, &terms);
  AddFeasibility(state, gradient, &terms);
  AddTurning(state, gradient, &terms);
  if (active_height && dim == 4 && has_ground)
    AddBodyHeight(state.pos(3), ground, gradient, &terms);

  if (breakdown != nullptr) {
    breakdown->safety += terms.safety;
    breakdown->edge += terms.edge;
    breakdown->ground += terms.ground;
    breakdown->feasibility += terms.feasibility;
    breakdown->height += terms.height;
    breakdown->keep_out += terms.keep_out;
    breakdown->turning += terms.turning;
  }
  return terms.safety + terms.edge + terms.ground + terms.feasibility + terms.height +
         terms.keep_out + terms.turning;
}

// J_s (paper eq. (8)-(12)): S' over its threshold, faded in from the trajectory's ends, and
// the stiff distance term below the distance threshold.
void TrajectoryCost::AddSafety(const Eigen::Vector3d& p, const TrajectoryEnds* ends,
                               TerrainMemo::Point* memo, PointGradient* gradient,
                               CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  const CostConfig& c = params_.config;
  const bool quiet_fields = memo != nullptr && memo->quiet_field_block >= 0 &&
                            model_->fields().BlockKey(p) == memo->quiet_field_block;
  if (!(w.safety > 0 && !quiet_fields)) return;
  FieldSample fields;  // S' and d from one lookup of the eight corners they share.
  FieldBlock block;
  model_->fields().Sample(p, &fields, memo != nullptr ? &block : nullptr);
  const Cubic unsafe = CubicPenalty(fields.safety - c.safety_threshold);
  if (unsafe.value > 0) {  // Most samples: S' under the threshold, nothing to fade.
    const SafetyFade fade =
        ends != nullptr ? SafetyFadeAt(p.head<2>(), *ends, c.safety_fade_m) : SafetyFade{};
    terms->safety += fade.scale * w.safety * unsafe.value;
    gradient->pos.head<3>() += fade.scale * w.safety * unsafe.slope * fields.safety_gradient;
    gradient->pos.head<2>() += w.safety * unsafe.value * fade.gradient;
  }
  const double stiff = w.safety * c.distance_stiffness;
  const Cubic close = CubicPenalty(c.distance_threshold_m - fields.distance_m);
  terms->safety += stiff * close.value;
  gradient->pos.head<3>() -= stiff * close.slope * fields.distance_gradient;
  if (memo != nullptr) {
    // Both fields are convex combinations of the block's corners anywhere in it; the margin
    // covers the rounding of the interpolation.
    const bool quiet = block.max_safety < c.safety_threshold - kInterpolationRounding &&
                       block.min_distance > c.distance_threshold_m + kInterpolationRounding;
    memo->quiet_field_block = quiet ? block.key : -1;
  }
}

// J_e: the footprint kept off the rim of the valid ground.
void TrajectoryCost::AddEdge(const Eigen::Vector3d& p, TerrainMemo::Point* memo,
                             PointGradient* gradient, CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  const bool deep_inside =
      memo != nullptr && memo->deep_inside.ix >= 0 && IsDeepInside(*graph_, p, memo->deep_inside);
  if (!(w.edge > 0 && !deep_inside)) return;
  const CostConfig& c = params_.config;
  Eigen::Vector2d edge_gradient;
  DeepInside deep;
  const Cubic outside =
      CubicPenalty(c.edge_margin_m - SampleEdgeDistance(*graph_, p, c.edge_margin_m, &edge_gradient,
                                                        memo != nullptr ? &deep : nullptr));
  terms->edge += w.edge * outside.value;
  gradient->pos.head<2>() -= w.edge * outside.slope * edge_gradient;
  if (memo != nullptr) memo->deep_inside = outside.value == 0 ? deep : DeepInside{};
}

// J_k: the footprint kept out of every keep-out zone whose height range it shares.
void TrajectoryCost::AddKeepOut(const Eigen::Vector3d& p, PointGradient* gradient,
                                CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  if (!(w.keep_out > 0 && !keep_out_.empty())) return;
  const RobotProfile& robot = params_.profile;
  const double margin = params_.config.keep_out_margin_m;
  const double reach = robot.footprint_radius_m + margin;
  for (const KeepOutZone& zone : keep_out_) {
    // Vertical gate: 1 where the robot's height range overlaps the zone's, fading to 0 at
    // k_margin apart (a step when k_margin is 0).
    double overlap_slope = 0;
    const double overlap = KeepOutVerticalOverlap(zone.prism, robot, p.z(), &overlap_slope);
    if (overlap <= -margin || (margin == 0 && overlap <= 0)) continue;
    const Cubic gate = margin > 0 ? Smoothstep(overlap / margin + 1) : Cubic{1, 0};
    const Eigen::Vector2d lo = zone.bounds_m.min().head<2>().array() - reach;
    const Eigen::Vector2d hi = zone.bounds_m.max().head<2>().array() + reach;
    if ((p.head<2>().array() <= lo.array()).any() || (p.head<2>().array() >= hi.array()).any()) {
      continue;
    }
    Eigen::Vector2d zone_gradient;
    const Cubic inside =
        CubicPenalty(reach - zone.prism.SignedDistanceXY(p.head<2>(), &zone_gradient));
    if (inside.value == 0) continue;
    terms->keep_out += w.keep_out * gate.value * inside.value;
    gradient->pos.head<2>() -= w.keep_out * gate.value * inside.slope * zone_gradient;
    if (gate.slope != 0) {  // Only inside the fade, so margin > 0.
      gradient->pos(2) += w.keep_out * inside.value * gate.slope / margin * overlap_slope;
    }
  }
}

// J_g: the reference point at its height above the smoothed ground. Quadratic beyond the
// band, zero within: C¹ at its edges.
void TrajectoryCost::AddGround(const Eigen::Vector3d& p, const GroundSample& ground,
                               PointGradient* gradient, CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  const double raw = p.z() - ground.height_m - params_.profile.reference_height_m;
  const double band = params_.config.ground_band_m;
  const double offset = raw > band ? raw - band : (raw < -band ? raw + band : 0.0);
  terms->ground += w.ground * offset * offset;
  gradient->pos(0) -= w.ground * 2 * offset * ground.height_gradient.x();
  gradient->pos(1) -= w.ground * 2 * offset * ground.height_gradient.y();
  gradient->pos(2) += w.ground * 2 * offset;
}

// J_d: speed and acceleration within their bounds. Cubic penalties on squared norms (as in
// Fast-Planner), horizontal and vertical apart.
void TrajectoryCost::AddFeasibility(const PointState& state, PointGradient* gradient,
                                    CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  if (!(w.feasibility > 0)) return;
  const auto bound = [&](const StateVector& x, double max_h, double max_v, StateVector* g) {
    const Cubic h = CubicPenalty(x(0) * x(0) + x(1) * x(1) - max_h * max_h);
    const Cubic v = CubicPenalty(x(2) * x(2) - max_v * max_v);
    (*g)(0) += w.feasibility * h.slope * 2 * x(0);
    (*g)(1) += w.feasibility * h.slope * 2 * x(1);
    (*g)(2) += w.feasibility * v.slope * 2 * x(2);
    return w.feasibility * (h.value + v.value);
  };
  terms->feasibility += bound(state.vel, params_.max_speed_horizontal_mps(),
                              params_.max_speed_vertical_mps(), &gradient->vel);
  terms->feasibility += bound(state.acc, params_.max_accel_horizontal_mps2(),
                              params_.max_accel_vertical_mps2(), &gradient->acc);
}

// J_t: the turn rate. ω = (v × a)_z / (‖v‖² + v_f²), finite at rest (kTurnSpeedFloorMps);
// |ω| smoothed to sqrt(ω² + ε²) − ε, C¹ where the heading holds still.
void TrajectoryCost::AddTurning(const PointState& state, PointGradient* gradient,
                                CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  if (!(w.turning > 0)) return;
  const Eigen::Vector2d v = state.vel.head<2>(), a = state.acc.head<2>();
  const double speed2 = v.squaredNorm() + kTurnSpeedFloorMps * kTurnSpeedFloorMps;
  const double omega = (v.x() * a.y() - v.y() * a.x()) / speed2;
  const double root = std::sqrt(omega * omega + kTurnRateSmoothing * kTurnRateSmoothing);
  terms->turning += w.turning * (root - kTurnRateSmoothing);
  const double slope = w.turning * omega / root / speed2;  // ∂P/∂ω over ‖v‖² + v_f².
  gradient->vel(0) += slope * (a.y() - 2 * omega * v.x());
  gradient->vel(1) += slope * (-a.x() - 2 * omega * v.y());
  gradient->acc(0) += slope * -v.y();
  gradient->acc(1) += slope * v.x();
}

// J_h (paper eq. (13)) and the body height's bounds (active-height robots): the body at the
// height that suits the ceiling, within its range and under the ceiling, a margin inside each.
void TrajectoryCost::AddBodyHeight(double h, const GroundSample& ground, PointGradient* gradient,
                                   CostBreakdown* terms) const {
  const CostWeights& w = weights_;
  const CostConfig& c = params_.config;
  const RobotProfile& robot = params_.profile;
  if (w.height > 0) {
    double slope = 0;
    const double error = h - SuitableBodyHeight(ground.clearance_m, &slope);
    terms->height += w.height * error * error;
    gradient->pos(3) += w.height * 2 * error;
    gradient->pos.head<2>() -= w.height * 2 * error * slope * ground.clearance_gradient;
  }
  if (w.feasibility > 0) {
    // The margin is at most half the range, and half the room between the lowest body and the
    // ceiling, so that no two bounds cross where the graph let the robot in.
    const double h_min = robot.MinBodyHeight(), h_max = robot.MaxBodyHeight();
    const double range_margin = std::min(c.body_height_margin_m, (h_max - h_min) / 2);
    const double room = ground.clearance_m - robot.headroom_m - h_min;
    const bool room_limited = 0 < room && room < 2 * range_margin;
    const double margin = room_limited ? room / 2 : (room <= 0 ? 0 : range_margin);
    const double margin_slope = room_limited ? 0.5 : 0;  // ∂margin/∂clearance.
    const Cubic high = CubicPenalty(h - (h_max - range_margin));
    const Cubic low = CubicPenalty(h_min + margin - h);
    const Cubic ceiling = CubicPenalty(h + robot.headroom_m + margin - ground.clearance_m);
    const double weight = c.body_height_stiffness * w.feasibility;
    terms->height += weight * (high.value + low.value + ceiling.value);
    gradient->pos(3) += weight * (high.slope - low.slope + ceiling.slope);
    gradient->pos.head<2>() += weight *
                               (low.slope * margin_slope + ceiling.slope * (margin_slope - 1)) *
                               ground.clearance_gradient;
  }
}

double TrajectoryCost::Evaluate(const Minco3& minco, Eigen::MatrixXd* grad_c,
                                Eigen::VectorXd* grad_T, CostBreakdown* breakdown,
                                TerrainMemo* memo) const {
  const int pieces = minco.piece_count();
  const int dim = minco.dim();
  const int kappa = params_.config.samples_per_piece;
  if (memo != nullptr && memo->points.size() != std::size_t(pieces) * (kappa + 1)) {
    memo->points.assign(std::size_t(pieces) * (kappa + 1), TerrainMemo::Point{});
  }
  grad_c->setZero(Minco3::kPieceCoefficients * pieces, dim);
  grad_T->setZero(pieces);
  CostBreakdown terms;

  if (weights_.smoothness > 0) {
    terms.smoothness = weights_.smoothness * minco.JerkEnergy(grad_c, grad_T);
    *grad_c *= weights_.smoothness;
    *grad_T *= weights_.smoothness;
  }
  terms.time = weights_.time * minco.TotalDuration();
  grad_T->array() += weights_.time;

  StateVector pos(dim), vel(dim), acc(dim), jerk(dim);
  PointGradient point_gradient(dim);
  StateVector& g_pos = point_gradient.pos;
  StateVector& g_vel = point_gradient.vel;
  StateVector& g_acc = point_gradient.acc;
  const TrajectoryEnds ends{minco.head_pva().col(0).head<2>(), minco.tail_pva().col(0).head<2>()};
  // A piece's last sample and the next piece's first are the same state (MINCO is C⁴ at its
  // waypoints): its penalty is evaluated once, and g_pos, g_vel, g_acc still hold its
  // gradients when the next piece starts.
  double junction_penalty = 0;
  CostBreakdown junction_terms;
  // Piece i's coefficients of axis a are the 6 consecutive doubles at column a, row 6i of
  // the column-major coefficient matrix (and of grad_c, shaped alike): the loops below
  // index them directly, which profiles showed cheaper than products of dynamic blocks.
  const Eigen::Index stride = minco.coefficients().outerStride();
  assert(grad_c->outerStride() == stride);
  for (int i = 0; i < pieces; ++i) {
    const double duration = minco.durations()(i);
    const double* c = minco.coefficients().data() + Minco3::kPieceCoefficients * i;
    double* g_c = grad_c->data() + Minco3::kPieceCoefficients * i;
    for (int j = 0; j <= kappa; ++j) {
      const double alpha = static_cast<double>(j) / kappa;
      const Eigen::Matrix<double, 4, 6> beta = Basis(alpha * duration);
      for (int a = 0; a < dim; ++a) {
        const double* column = c + a * stride;
        double state[4] = {0, 0, 0, 0};  // Position, velocity, acceleration, jerk.
        for (int k = 0; k < Minco3::kPieceCoefficients; ++k) {
          for (int order = 0; order < 4; ++order) state[order] += beta(order, k) * column[k];
        }
        pos(a) = state[0];
        vel(a) = state[1];
        acc(a) = state[2];
        jerk(a) = state[3];
      }
      CostBreakdown point_terms;
      double penalty = 0;
      if (j == 0 && i > 0) {
        penalty = junction_penalty;
        point_terms = junction_terms;
      } else {
        TerrainMemo::Point* point_memo =
            memo != nullptr ? &memo->points[std::size_t(i) * (kappa + 1) + j] : nullptr;
        penalty = PointPenalty({pos, vel, acc}, &point_gradient, &point_terms, &ends, point_memo);
        if (j == kappa) {
          junction_penalty = penalty;
          junction_terms = point_terms;
        }
      }
      if (penalty == 0) continue;  // Gradients are zero too: every term is >= 0 and C¹.
      // Trapezoid weight T/κ (halved at the ends); it scales with T, hence penalty·w/T below.
      const double weight = (j == 0 || j == kappa ? 0.5 : 1.0) * duration / kappa;
      // t_j = α·T moves with T: d(state)/dT = α·(next derivative), summed into state_rate.
      double state_rate = 0;
      for (int a = 0; a < dim; ++a) {
        double* column = g_c + a * stride;
        for (int k = 0; k < Minco3::kPieceCoefficients; ++k) {
          column[k] +=
              weight * (beta(0, k) * g_pos(a) + beta(1, k) * g_vel(a) + beta(2, k) * g_acc(a));
        }
        state_rate += g_pos(a) * vel(a) + g_vel(a) * acc(a) + g_acc(a) * jerk(a);
      }
      (*grad_T)(i) += penalty * weight / duration + weight * alpha * state_rate;
      terms.safety += weight * point_terms.safety;
      terms.edge += weight * point_terms.edge;
      terms.ground += weight * point_terms.ground;
      terms.feasibility += weight * point_terms.feasibility;
      terms.height += weight * point_terms.height;
      terms.keep_out += weight * point_terms.keep_out;
      terms.turning += weight * point_terms.turning;
    }
  }
  if (breakdown != nullptr) *breakdown = terms;
  return terms.total();
}

}  // namespace strata
