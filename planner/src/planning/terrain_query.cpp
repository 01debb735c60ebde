#include "strata/planning/terrain_query.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <span>

namespace strata {
namespace {

constexpr double kLevelGapM = SurfaceGraph::kLevelGapM;

// The surface of column (ix, iy) whose ground is nearest to height z, or nullptr if the
// column has none. A column's grounds ascend (SurfaceMap), so past the first at or above z
// every other is farther.
const ColumnSurface* NearestSurface(const SurfaceMap& surfaces, int ix, int iy, double z) {
  const ColumnSurface* nearest = nullptr;
  for (const ColumnSurface& s : surfaces.Column(ix, iy)) {
    if (nearest == nullptr || std::abs(s.ground_z_m - z) < std::abs(nearest->ground_z_m - z)) {
      nearest = &s;
    }
    if (s.ground_z_m >= z) break;
  }
  return nearest;
}

// How far inside the range where a column's nearest surface stands a ground height must lie
// for GroundChoice to reuse the choice [m]: far above the rounding of |ground − z|.
constexpr double kChoiceMarginM = 1e-6;

// How far inside its bounds GroundWithinBand wants a point [m]: far above the rounding of
// the coordinates and heights it compares (metres to hundreds of metres).
constexpr double kInsideM = 1e-9;

// NearestSurface, narrowing the open range (*low, *high) of heights z to those for which it
// stays the choice: halfway to the grounds below and above it (a column's grounds ascend).
const ColumnSurface* NearestSurfaceInRange(const SurfaceMap& surfaces, int ix, int iy, double z,
                                           double* low, double* high) {
  const ColumnSurface* nearest = NearestSurface(surfaces, ix, iy, z);
  if (nearest == nullptr) return nullptr;  // No surface at any height.
  const std::span<const ColumnSurface> column = surfaces.Column(ix, iy);
  const std::size_t k = static_cast<std::size_t>(nearest - column.data());
  const double ground = nearest->ground_z_m;
  if (k > 0) *low = std::max(*low, 0.5 * (column[k - 1].ground_z_m + ground) + kChoiceMarginM);
  if (k + 1 < column.size()) {
    *high = std::min(*high, 0.5 * (ground + column[k + 1].ground_z_m) - kChoiceMarginM);
  }
  return nearest;
}

// p's coordinates in units of cells, with the centre of column i at i ("centre coordinates"):
// the four column centres SampleGround blends at p are those of their floor and the next.
Eigen::Vector2d CentreCoordinates(const GridGeometry& g, const Eigen::Vector2d& p) {
  return {(p.x() - g.origin_m.x()) / g.resolution_m - 0.5,
          (p.y() - g.origin_m.y()) / g.resolution_m - 0.5};
}

}  // namespace

bool SampleGround(const TerrainModel& model, const Eigen::Vector3d& p, double reference_height_m,
                  double clearance_cap_m, GroundSample* sample, GroundChoice* choice) {
  const GridGeometry& g = model.grid();
  const SurfaceMap& surfaces = model.surfaces();
  const double r = g.resolution_m;
  const double z_ground = p.z() - reference_height_m;
  const int own_ix = static_cast<int>(std::floor((p.x() - g.origin_m.x()) / r));
  const int own_iy = static_cast<int>(std::floor((p.y() - g.origin_m.y()) / r));
  if (own_ix < 0 || own_iy < 0 || own_ix >= g.size.x() || own_iy >= g.size.y()) return false;

  // Bilinear weights between the four column centres around p. p's own column is one of the
  // four: i0 or i0 + 1.
  const Eigen::Vector2d centre = CentreCoordinates(g, p.head<2>());
  const double u = centre.x();
  const double v = centre.y();
  const int i0 = static_cast<int>(std::floor(u));
  const int j0 = static_cast<int>(std::floor(v));
  const double fu = u - i0, fv = v - j0;
  const ColumnSurface* corner[2][2] = {};
  const Eigen::Vector2i cell(i0, j0);
  const bool chosen = choice != nullptr && choice->cell == cell && z_ground > choice->low_m &&
                      z_ground < choice->high_m;
  if (chosen) {
    std::copy(&choice->corner[0][0], &choice->corner[0][0] + 4, &corner[0][0]);
  } else {
    double low = -std::numeric_limits<double>::infinity();
    double high = std::numeric_limits<double>::infinity();
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        const int ix = std::clamp(i0 + di, 0, g.size.x() - 1);
        const int iy = std::clamp(j0 + dj, 0, g.size.y() - 1);
        corner[dj][di] = choice != nullptr
                             ? NearestSurfaceInRange(surfaces, ix, iy, z_ground, &low, &high)
                             : NearestSurface(surfaces, ix, iy, z_ground);
      }
    }
    if (choice != nullptr) {
      choice->cell = cell;
      // u = i0 at x = origin + (i0 + 0.5)·r.
      const Eigen::Array2d low_corner =
          g.origin_m.head<2>().array() + (cell.cast<double>().array() + 0.5) * r;
      choice->area = Eigen::AlignedBox2d(low_corner + kInsideM, low_corner + r - kInsideM);
      choice->low_m = low;
      choice->high_m = high;
      std::copy(&corner[0][0], &corner[0][0] + 4, &choice->corner[0][0]);
      choice->center_low_m = std::numeric_limits<double>::infinity();
      choice->center_high_m = -std::numeric_limits<double>::infinity();
      for (const ColumnSurface* s : {corner[0][0], corner[0][1], corner[1][0], corner[1][1]}) {
        if (s == nullptr) continue;
        choice->center_low_m = std::min(choice->center_low_m, double{s->plane_center_z_m});
        choice->center_high_m = std::max(choice->center_high_m, double{s->plane_center_z_m});
      }
      choice->clearance_cap_m = -1;
    }
  }
  bool any_near = false;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      any_near = any_near || (corner[dj][di] != nullptr &&
                              std::abs(corner[dj][di]->ground_z_m - z_ground) <= kLevelGapM);
    }
  }
  assert(own_ix - i0 >= 0 && own_ix - i0 <= 1 && own_iy - j0 >= 0 && own_iy - j0 <= 1);
  sample->surface = corner[own_iy - j0][own_ix - i0];
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
    double lowest[2][2] = {};
    if (choice != nullptr && choice->clearance_cap_m == clearance_cap_m) {
      std::copy(&choice->lowest_clearance_m[0][0], &choice->lowest_clearance_m[0][0] + 4,
                &lowest[0][0]);
    } else {
      // With a choice, every corner's: which are used depends on the height, the choice not.
      for (int dj = 0; dj < 2; ++dj) {
        for (int di = 0; di < 2; ++di) {
          if (used[dj][di] || (choice != nullptr && corner[dj][di] != nullptr)) {
            lowest[dj][di] = lowest_around(i0 + di, j0 + dj, *corner[dj][di]);
          }
        }
      }
      if (choice != nullptr) {
        std::copy(&lowest[0][0], &lowest[0][0] + 4, &choice->lowest_clearance_m[0][0]);
        choice->clearance_cap_m = clearance_cap_m;
      }
    }
    interpolate([&](int dj, int di) { return lowest[dj][di]; }, &sample->clearance_m,
                &sample->clearance_gradient);
  }
  return true;
}

bool GroundWithinBand(const GroundChoice& choice, const Eigen::Vector3d& p,
                      double reference_height_m, double band_m) {
  const double z_ground = p.z() - reference_height_m;
  // Without corners, center_low_m is +∞ and the band test passes: SampleGround finds no
  // ground there.
  return choice.area.contains(p.head<2>()) && z_ground > choice.low_m + kInsideM &&
         z_ground < choice.high_m - kInsideM &&
         z_ground - band_m + kInsideM < choice.center_low_m &&
         choice.center_high_m < z_ground + band_m - kInsideM;
}

Eigen::Vector2i BlendCell(const GridGeometry& grid, const Eigen::Vector2d& p) {
  const Eigen::Vector2d centre = CentreCoordinates(grid, p);
  return {static_cast<int>(std::floor(centre.x())), static_cast<int>(std::floor(centre.y()))};
}

// The range of the blend of `corner`'s plane heights (SampleGround's, from the square whose
// lower-left column is `cell`) over `area` and the band of feet heights [low, high], with
// these corners throughout: each must be near the band throughout or far throughout, so that
// the same ones are weighted; then the blend is monotone along x and y, and its extremes are
// at the area's corners. False where that does not hold or the weights can vanish.
bool BlendRange(const GridGeometry& g, const Eigen::Vector2i& cell,
                const ColumnSurface* const (&corner)[2][2], const Eigen::AlignedBox2d& area,
                double ground_low_m, double ground_high_m, double* low_m, double* high_m) {
  bool near[2][2] = {};
  bool any_near = false;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const ColumnSurface* s = corner[dj][di];
      if (s == nullptr) continue;
      near[dj][di] =
          s->ground_z_m - kLevelGapM <= ground_low_m && ground_high_m <= s->ground_z_m + kLevelGapM;
      const bool far =
          ground_high_m < s->ground_z_m - kLevelGapM || ground_low_m > s->ground_z_m + kLevelGapM;
      if (near[dj][di] == far) return false;
      any_near = any_near || near[dj][di];
    }
  }
  for (const Eigen::Vector2d& p :
       {area.corner(Eigen::AlignedBox2d::BottomLeft), area.corner(Eigen::AlignedBox2d::BottomRight),
        area.corner(Eigen::AlignedBox2d::TopLeft), area.corner(Eigen::AlignedBox2d::TopRight)}) {
    // SampleGround's weights at p.
    const Eigen::Vector2d f = CentreCoordinates(g, p) - cell.cast<double>();
    const double fu = f.x(), fv = f.y();
    double total = 0, sum = 0;
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        const ColumnSurface* s = corner[dj][di];
        if (s == nullptr || (any_near && !near[dj][di])) continue;
        const double w = (di ? fu : 1 - fu) * (dj ? fv : 1 - fv);
        total += w;
        sum += w * s->plane_center_z_m;
      }
    }
    // The total weight is bilinear too: positive at the corners, positive throughout.
    if (!(total > kInsideM)) return false;
    *low_m = std::min(*low_m, sum / total);
    *high_m = std::max(*high_m, sum / total);
  }
  return true;
}

// Most combinations of the corners' surfaces GroundHeightRange takes the union over.
constexpr int kMaxSurfaceCombinations = 16;

bool GroundHeightRange(const TerrainModel& model, const GroundChoice& choice,
                       const Eigen::AlignedBox2d& area, double reach_m, double ground_low_m,
                       double ground_high_m, double* low_m, double* high_m) {
  const Eigen::Vector2d reach = Eigen::Vector2d::Constant(reach_m);
  if (!Eigen::AlignedBox2d(choice.area.min() - reach, choice.area.max() + reach).contains(area)) {
    return false;
  }
  // The surfaces each corner may take over the band: the choice's where it stands for the
  // whole band; elsewhere those between its nearest at the band's ends (a column's grounds
  // ascend, and so does its nearest one with the height), as where the feet sit halfway
  // between two grounds of a corner. h_G at a point is then the blend of one combination of
  // them, so the union of every combination's range bounds it, across the jump too.
  const bool choice_stands = ground_low_m > choice.low_m && ground_high_m < choice.high_m;
  const GridGeometry& g = model.grid();
  const ColumnSurface* first[2][2] = {};
  int count[2][2] = {};
  int combinations = 1;
  for (int dj = 0; dj < 2; ++dj) {
    for (int di = 0; di < 2; ++di) {
      const ColumnSurface* last = nullptr;
      if (choice_stands) {
        first[dj][di] = last = choice.corner[dj][di];
      } else {
        const int ix = std::clamp(choice.cell.x() + di, 0, g.size.x() - 1);
        const int iy = std::clamp(choice.cell.y() + dj, 0, g.size.y() - 1);
        first[dj][di] = NearestSurface(model.surfaces(), ix, iy, ground_low_m);
        last = NearestSurface(model.surfaces(), ix, iy, ground_high_m);
      }
      count[dj][di] = first[dj][di] == nullptr ? 1 : static_cast<int>(last - first[dj][di]) + 1;
      combinations *= count[dj][di];
      if (combinations > kMaxSurfaceCombinations) return false;
    }
  }
  *low_m = std::numeric_limits<double>::infinity();
  *high_m = -std::numeric_limits<double>::infinity();
  for (int combination = 0; combination < combinations; ++combination) {
    const ColumnSurface* corner[2][2] = {};
    int rest = combination;
    for (int dj = 0; dj < 2; ++dj) {
      for (int di = 0; di < 2; ++di) {
        if (first[dj][di] != nullptr) corner[dj][di] = first[dj][di] + rest % count[dj][di];
        rest /= count[dj][di];
      }
    }
    if (!BlendRange(g, choice.cell, corner, area, ground_low_m, ground_high_m, low_m, high_m)) {
      return false;
    }
  }
  return true;
}

double SampleEdgeDistance(const SurfaceGraph& graph, const Eigen::Vector3d& p, double reach_m,
                          Eigen::Vector2d* gradient, DeepInside* deep) {
  if (deep != nullptr) *deep = DeepInside{};
  const GridGeometry& g = graph.grid();
  const double r = g.resolution_m;
  const double z_ground = p.z() - graph.params().reference_height_m;
  const Eigen::Vector2d q = (p.head<2>() - g.origin_m.head<2>()) / r;  // In cells.
  const int ci = static_cast<int>(std::floor(q.x()));
  const int cj = static_cast<int>(std::floor(q.y()));
  const auto traversable = [&](int ix, int iy) {
    return ix >= 0 && iy >= 0 && ix < g.size.x() && iy < g.size.y() &&
           graph.NodeNear(ix, iy, z_ground) >= 0;
  };
  // Columns `window` away or more lie at least that many cells from p (p is inside its own
  // column), so the nearest square of the other kind within the window is the nearest at all
  // while it is closer than `window` cells.
  const int window = std::max(1, static_cast<int>(std::ceil(reach_m / r)));
  // Deep inside (the usual case): the column's own node is farther from the rim than the
  // window reaches, so every column in it is traversable. Edge distances are chamfer
  // distances, within 8.3% above Euclidean, from the node's centre, at most r/√2 from p.
  bool inside = false;  // traversable(ci, cj), from the node the fast path looks up anyway.
  if (ci >= 0 && cj >= 0 && ci < g.size.x() && cj < g.size.y()) {
    double low = 0, high = 0;
    const int own = deep != nullptr ? graph.NodeNear(ci, cj, z_ground, &low, &high)
                                    : graph.NodeNear(ci, cj, z_ground);
    if (own >= 0 && graph.edge_distance(own) / 1.083 - 0.5 * r >= (window + 1) * r) {
      if (deep != nullptr) *deep = DeepInside{ci, cj, low, high};
      gradient->setZero();
      return window * r;
    }
    inside = own >= 0;
  }
  double nearest = window;  // In cells.
  Eigen::Vector2d away = Eigen::Vector2d::Zero();
  for (int dj = -window; dj <= window; ++dj) {
    for (int di = -window; di <= window; ++di) {
      if ((di == 0 && dj == 0) || traversable(ci + di, cj + dj) == inside) continue;
      // The square's nearest point to q.
      const Eigen::Vector2d low(ci + di, cj + dj);
      const Eigen::Vector2d high = low + Eigen::Vector2d::Ones();
      const Eigen::Vector2d closest = q.cwiseMax(low).cwiseMin(high);
      const Eigen::Vector2d delta = q - closest;
      const double d = delta.norm();
      if (d >= nearest) continue;
      nearest = d;
      // On the square's edge (d = 0) the direction is the edge's normal.
      away = d > 1e-12 ? Eigen::Vector2d(delta / d)
                       : Eigen::Vector2d(q - (low.array() + 0.5).matrix()).normalized();
    }
  }
  const double sign = inside ? 1.0 : -1.0;
  *gradient = nearest < window ? Eigen::Vector2d(sign * away) : Eigen::Vector2d::Zero();
  return sign * nearest * r;
}

bool IsDeepInside(const SurfaceGraph& graph, const Eigen::Vector3d& p, const DeepInside& deep) {
  const GridGeometry& g = graph.grid();
  const double z_ground = p.z() - graph.params().reference_height_m;
  if (!(z_ground > deep.ground_low && z_ground < deep.ground_high)) return false;
  // SampleEdgeDistance's column, from the same expression; within the grid a truncation is
  // its floor, and cheaper.
  const Eigen::Vector2d q = (p.head<2>() - g.origin_m.head<2>()) / g.resolution_m;
  return q.x() >= 0 && q.y() >= 0 && q.x() < g.size.x() && q.y() < g.size.y() &&
         static_cast<int>(q.x()) == deep.ix && static_cast<int>(q.y()) == deep.iy;
}

}  // namespace strata
