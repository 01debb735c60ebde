#include "strata/trajectory_costs.hpp"

#include <algorithm>
#include <cmath>
#include <string>

#include "format_internal.hpp"

namespace strata {
namespace {

constexpr double kLevelGapM = SurfaceGraph::kLevelGapM;

// Cubic penalty C(x) = max(x, 0)³ and its derivative 3·max(x, 0)².
struct Cubic {
  double value = 0;
  double slope = 0;
};
Cubic CubicPenalty(double x) {
  if (x <= 0) return {};
  return {x * x * x, 3 * x * x};
}

// The surface of column (ix, iy) whose ground is nearest to height z, or nullptr if the
// column has none.
const ColumnSurface* NearestSurface(const SurfaceMap& surfaces, int ix, int iy, double z) {
  const ColumnSurface* nearest = nullptr;
  for (const ColumnSurface& s : surfaces.Column(ix, iy)) {
    if (nearest == nullptr || std::abs(s.ground_z_m - z) < std::abs(nearest->ground_z_m - z)) {
      nearest = &s;
    }
  }
  return nearest;
}

// β(t) and its first three derivatives: row k holds d^k/dt^k [1, t, …, t⁵].
Eigen::Matrix<double, 4, 6> Basis(double t) {
  const double t2 = t * t, t3 = t2 * t, t4 = t3 * t, t5 = t4 * t;
  Eigen::Matrix<double, 4, 6> b;
  b << 1, t, t2, t3, t4, t5, 0, 1, 2 * t, 3 * t2, 4 * t3, 5 * t4, 0, 0, 2, 6 * t, 12 * t2, 20 * t3,
      0, 0, 0, 6, 24 * t, 60 * t2;
  return b;
}

}  // namespace

Status CostWeights::Validate() const {
  const std::pair<const char*, double> fields[] = {
      {"smoothness", smoothness}, {"time", time},
      {"safety", safety},         {"edge", edge},
      {"ground", ground},         {"feasibility", feasibility},
      {"height", height}};
  for (const auto& [name, value] : fields) {
    if (!(std::isfinite(value) && value >= 0)) {
      return internal::OutOfRange(std::string("weights.") + name, value, ">= 0 and finite");
    }
  }
  return Status::Ok();
}

bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample) {
  const GridGeometry& g = model.grid();
  const SurfaceMap& surfaces = model.surfaces();
  const double r = g.resolution_m;
  const double z_ground = p.z() - reference_height_m;
  const int own_ix = static_cast<int>(std::floor((p.x() - g.origin_m.x()) / r));
  const int own_iy = static_cast<int>(std::floor((p.y() - g.origin_m.y()) / r));
  if (own_ix < 0 || own_iy < 0 || own_ix >= g.size.x() || own_iy >= g.size.y()) return false;
  sample->surface = NearestSurface(surfaces, own_ix, own_iy, z_ground);

  // Bilinear weights between the four column centres around p ("centre coordinates": the
  // centre of column i sits at u = i).
  const double u = (p.x() - g.origin_m.x()) / r - 0.5;
  const double v = (p.y() - g.origin_m.y()) / r - 0.5;
  const int i0 = static_cast<int>(std::floor(u));
  const int j0 = static_cast<int>(std::floor(v));
  const double fu = u - i0, fv = v - j0;
  const ColumnSurface* corner[2][2];
  bool any_near = false;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const int ix = std::clamp(i0 + di, 0, g.size.x() - 1);
      const int iy = std::clamp(j0 + dj, 0, g.size.y() - 1);
      corner[dj][di] = NearestSurface(surfaces, ix, iy, z_ground);
      any_near = any_near || (corner[dj][di] != nullptr &&
                              std::abs(corner[dj][di]->ground_z_m - z_ground) <= kLevelGapM);
    }
  }
  // A corner on another level (a ledge, a drop) or without ground must not tilt the ground:
  // it gets no weight, and the others are renormalised. The choice only flips where the point
  // is kLevelGapM from that corner's ground, far from where a trajectory runs, so the field is
  // continuous wherever it matters.
  bool used[2][2];
  bool any_used = false;
  double total = 0;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const ColumnSurface* s = corner[dj][di];
      used[dj][di] =
          s != nullptr && (!any_near || std::abs(s->ground_z_m - z_ground) <= kLevelGapM);
      any_used = any_used || used[dj][di];
      if (used[dj][di]) total += (di ? fu : 1 - fu) * (dj ? fv : 1 - fv);
    }
  }
  if (!any_used || total <= 0) return false;
  if (sample->surface == nullptr) {  // A hole in p's column: report the heaviest corner's.
    double heaviest = -1;
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        const double w = (di ? fu : 1 - fu) * (dj ? fv : 1 - fv);
        if (used[dj][di] && w > heaviest) {
          heaviest = w;
          sample->surface = corner[dj][di];
        }
      }
    }
  }
  // f = Σ w_k f_k / Σ w_k with bilinear w_k; the gradient by the quotient rule.
  const auto interpolate = [&](auto value_of, double* value, Eigen::Vector2d* grad) {
    double num = 0;
    Eigen::Vector2d d_num = Eigen::Vector2d::Zero(), d_total = Eigen::Vector2d::Zero();
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        if (!used[dj][di]) continue;
        const double w = (di ? fu : 1 - fu) * (dj ? fv : 1 - fv);
        const Eigen::Vector2d dw((di ? 1.0 : -1.0) * (dj ? fv : 1 - fv) / r,
                                 (dj ? 1.0 : -1.0) * (di ? fu : 1 - fu) / r);
        const double f = value_of(dj, di);
        num += w * f;
        d_num += dw * f;
        d_total += dw;
      }
    }
    *value = num / total;
    *grad = (d_num - *value * d_total) / total;
  };
  interpolate([&](int dj, int di) { return static_cast<double>(corner[dj][di]->plane_center_z_m); },
              &sample->height_m, &sample->height_gradient);
  if (clearance_cap_m > 0) {
    // A ceiling must be seen before the body is under it: each corner takes the lowest
    // clearance of its column and the 8 around it (same level), so the interpolated ceiling
    // is never above any column within half a cell.
    const auto lowest_around = [&](int ix, int iy, const ColumnSurface& s) {
      double lowest = clearance_cap_m;
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          const int jx = std::clamp(ix + dx, 0, g.size.x() - 1);
          const int jy = std::clamp(iy + dy, 0, g.size.y() - 1);
          const ColumnSurface* n = NearestSurface(surfaces, jx, jy, s.ground_z_m);
          if (n != nullptr && std::abs(n->ground_z_m - s.ground_z_m) <= kLevelGapM) {
            lowest = std::min(lowest, static_cast<double>(n->clearance_m));
          }
        }
      }
      return lowest;
    };
    double lowest[2][2];
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        if (used[dj][di]) lowest[dj][di] = lowest_around(i0 + di, j0 + dj, *corner[dj][di]);
      }
    }
    interpolate([&](int dj, int di) { return lowest[dj][di]; }, &sample->clearance_m,
                &sample->clearance_gradient);
  }
  return true;
}

double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p,
                          Eigen::Vector2d* gradient) {
  const GridGeometry& g = graph.grid();
  const double r = g.resolution_m;
  const double z_ground = p.z() - graph.params().reference_height_m;
  const double u = (p.x() - g.origin_m.x()) / r - 0.5;
  const double v = (p.y() - g.origin_m.y()) / r - 0.5;
  const int i0 = static_cast<int>(std::floor(u));
  const int j0 = static_cast<int>(std::floor(v));
  const double fu = u - i0, fv = v - j0;
  double f[2][2];
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const int node = graph.NodeNear(i0 + di, j0 + dj, z_ground);
      f[dj][di] = node >= 0 ? graph.edge_distance(node) : -0.5 * r;
    }
  }
  const double f0 = f[0][0] + fu * (f[0][1] - f[0][0]);
  const double f1 = f[1][0] + fu * (f[1][1] - f[1][0]);
  (*gradient) << ((1 - fv) * (f[0][1] - f[0][0]) + fv * (f[1][1] - f[1][0])) / r, (f1 - f0) / r;
  return f0 + fv * (f1 - f0);
}

double TrajectoryCost::SuitableBodyHeight(double clearance_m, double* derivative) const {
  const CostParams& c = params_;
  double h = c.body_height_preferred_m;
  double slope = 0;
  if (clearance_m - c.headroom_m < h) {
    h = clearance_m - c.headroom_m;
    slope = 1;
  }
  if (h < c.body_height_min_m || h > c.body_height_max_m) {
    h = std::clamp(h, c.body_height_min_m, c.body_height_max_m);
    slope = 0;
  }
  if (derivative != nullptr) *derivative = slope;
  return h;
}

double TrajectoryCost::ClearanceCap() const {
  return std::max(params_.body_height_max_m, params_.body_height_preferred_m) + params_.headroom_m +
         1.0;
}

double TrajectoryCost::PointPenalty(const StateVector& pos, const StateVector& vel,
                                    const StateVector& acc, StateVector* grad_pos,
                                    StateVector* grad_vel, StateVector* grad_acc,
                                    CostBreakdown* breakdown) const {
  const CostWeights& w = weights_;
  const CostParams& c = params_;
  const int dim = static_cast<int>(pos.size());
  grad_pos->setZero(dim);
  grad_vel->setZero(dim);
  grad_acc->setZero(dim);
  const Eigen::Vector3d p = pos.head<3>();
  CostBreakdown terms;

  if (w.safety > 0) {
    Eigen::Vector3d gradient;
    const Cubic unsafe = CubicPenalty(model_->SafetyPenalty(p, &gradient) - c.safety_threshold);
    terms.safety += w.safety * unsafe.value;
    grad_pos->head<3>() += w.safety * unsafe.slope * gradient;
    const Cubic close = CubicPenalty(c.distance_threshold_m - model_->Distance(p, &gradient));
    terms.safety += w.safety * close.value;
    grad_pos->head<3>() -= w.safety * close.slope * gradient;
  }

  if (w.edge > 0) {
    Eigen::Vector2d gradient;
    const Cubic outside = CubicPenalty(c.edge_margin_m - SampleEdgeDistance(*graph_, p, &gradient));
    terms.edge += w.edge * outside.value;
    grad_pos->head<2>() -= w.edge * outside.slope * gradient;
  }

  GroundSample ground;
  const bool has_ground =
      (w.ground > 0 || (c.active_height && (w.height > 0 || w.feasibility > 0))) &&
      SampleGround(*model_, p, c.reference_height_m, c.active_height ? ClearanceCap() : 0, &ground);
  if (has_ground && w.ground > 0) {
    const double offset = p.z() - ground.height_m - c.reference_height_m;
    terms.ground += w.ground * offset * offset;
    (*grad_pos)(0) -= w.ground * 2 * offset * ground.height_gradient.x();
    (*grad_pos)(1) -= w.ground * 2 * offset * ground.height_gradient.y();
    (*grad_pos)(2) += w.ground * 2 * offset;
  }

  if (w.feasibility > 0) {
    // Cubic penalties on squared norms (as in Fast-Planner), horizontal and vertical apart.
    const auto bound = [&](const StateVector& x, double max_h, double max_v, StateVector* g) {
      const Cubic h = CubicPenalty(x(0) * x(0) + x(1) * x(1) - max_h * max_h);
      const Cubic v = CubicPenalty(x(2) * x(2) - max_v * max_v);
      (*g)(0) += w.feasibility * h.slope * 2 * x(0);
      (*g)(1) += w.feasibility * h.slope * 2 * x(1);
      (*g)(2) += w.feasibility * v.slope * 2 * x(2);
      return w.feasibility * (h.value + v.value);
    };
    terms.feasibility += bound(vel, c.max_speed_horizontal_mps, c.max_speed_vertical_mps, grad_vel);
    terms.feasibility +=
        bound(acc, c.max_accel_horizontal_mps2, c.max_accel_vertical_mps2, grad_acc);
  }

  if (c.active_height && dim == 4 && has_ground) {
    const double h = pos(3);
    if (w.height > 0) {
      double slope = 0;
      const double error = h - SuitableBodyHeight(ground.clearance_m, &slope);
      terms.height += w.height * error * error;
      (*grad_pos)(3) += w.height * 2 * error;
      grad_pos->head<2>() -= w.height * 2 * error * slope * ground.clearance_gradient;
    }
    if (w.feasibility > 0) {
      // The body stays within its range and under the ceiling, a margin inside each. The
      // margin is at most half the range, and half the room between the lowest body and the
      // ceiling, so that no two bounds cross where the graph let the robot in.
      const double range_margin =
          std::min(c.body_height_margin_m, (c.body_height_max_m - c.body_height_min_m) / 2);
      const double room = ground.clearance_m - c.headroom_m - c.body_height_min_m;
      const bool room_limited = 0 < room && room < 2 * range_margin;
      const double margin = room_limited ? room / 2 : (room <= 0 ? 0 : range_margin);
      const double margin_slope = room_limited ? 0.5 : 0;  // ∂margin/∂clearance.
      const Cubic high = CubicPenalty(h - (c.body_height_max_m - range_margin));
      const Cubic low = CubicPenalty(c.body_height_min_m + margin - h);
      const Cubic ceiling = CubicPenalty(h + c.headroom_m + margin - ground.clearance_m);
      const double weight = c.body_height_stiffness * w.feasibility;
      terms.height += weight * (high.value + low.value + ceiling.value);
      (*grad_pos)(3) += weight * (high.slope - low.slope + ceiling.slope);
      grad_pos->head<2>() += weight *
                             (low.slope * margin_slope + ceiling.slope * (margin_slope - 1)) *
                             ground.clearance_gradient;
    }
  }

  if (breakdown != nullptr) {
    breakdown->safety += terms.safety;
    breakdown->edge += terms.edge;
    breakdown->ground += terms.ground;
    breakdown->feasibility += terms.feasibility;
    breakdown->height += terms.height;
  }
  return terms.safety + terms.edge + terms.ground + terms.feasibility + terms.height;
}

double TrajectoryCost::Evaluate(const Minco3& minco, Eigen::MatrixXd* grad_c,
                                Eigen::VectorXd* grad_T, CostBreakdown* breakdown) const {
  const int pieces = minco.piece_count();
  const int dim = minco.dim();
  const int kappa = params_.samples_per_piece;
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

  StateVector pos(dim), vel(dim), acc(dim), jerk(dim), g_pos(dim), g_vel(dim), g_acc(dim);
  for (int i = 0; i < pieces; ++i) {
    const double duration = minco.durations()(i);
    const auto c =
        minco.coefficients().middleRows<Minco3::kPieceCoefficients>(Minco3::kPieceCoefficients * i);
    auto g_c = grad_c->middleRows<Minco3::kPieceCoefficients>(Minco3::kPieceCoefficients * i);
    for (int j = 0; j <= kappa; ++j) {
      const double alpha = static_cast<double>(j) / kappa;
      const Eigen::Matrix<double, 4, 6> beta = Basis(alpha * duration);
      pos.noalias() = (beta.row(0) * c).transpose();
      vel.noalias() = (beta.row(1) * c).transpose();
      acc.noalias() = (beta.row(2) * c).transpose();
      jerk.noalias() = (beta.row(3) * c).transpose();
      CostBreakdown point_terms;
      const double penalty = PointPenalty(pos, vel, acc, &g_pos, &g_vel, &g_acc, &point_terms);
      if (penalty == 0) continue;  // Gradients are zero too: every term is >= 0 and C¹.
      // Trapezoid weight T/κ (halved at the ends); it scales with T, hence penalty·w/T below.
      const double weight = (j == 0 || j == kappa ? 0.5 : 1.0) * duration / kappa;
      g_c.noalias() += weight * (beta.row(0).transpose() * g_pos.transpose() +
                                 beta.row(1).transpose() * g_vel.transpose() +
                                 beta.row(2).transpose() * g_acc.transpose());
      // t_j = α·T moves with T: d(state)/dT = α·(next derivative).
      (*grad_T)(i) += penalty * weight / duration +
                      weight * alpha * (g_pos.dot(vel) + g_vel.dot(acc) + g_acc.dot(jerk));
      terms.safety += weight * point_terms.safety;
      terms.edge += weight * point_terms.edge;
      terms.ground += weight * point_terms.ground;
      terms.feasibility += weight * point_terms.feasibility;
      terms.height += weight * point_terms.height;
    }
  }
  if (breakdown != nullptr) *breakdown = terms;
  return terms.total();
}

}  // namespace strata
