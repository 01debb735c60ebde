// The lattice sampler, SceneRamp and the solid-ramp helper shared by the scene generators.
#include <algorithm>
#include <cmath>
#include <utility>

#include <Eigen/Geometry>

#include "scenes_internal.hpp"

namespace strata::internal {

SurfaceSampler::SurfaceSampler(std::uint32_t seed, double spacing_m)
    : rng_(MakeEngine(seed, kJitterStream)),
      spacing_m_(spacing_m),
      jitter_xy_m_(kJitterFraction * spacing_m),
      jitter_z_m_(std::min(kMaxJitterZM, kJitterFraction * spacing_m)) {}

SurfaceSampler SurfaceSampler::Counter(double spacing_m) {
  SurfaceSampler counter(0, spacing_m);
  counter.counting_ = true;
  return counter;
}

void SurfaceSampler::AddRuledPatch(const Vec3& a0, const Vec3& a1, const Vec3& b0, const Vec3& b1,
                                   const KeepFn& keep) {
  const int nu = Intervals(std::max((a1 - a0).norm(), (b1 - b0).norm()), spacing_m_);
  for (int i = 0; i <= nu; ++i) {
    const double u = nu == 0 ? 0.0 : static_cast<double>(i) / nu;
    const Vec3 a = a0 + u * (a1 - a0);
    const Vec3 b = b0 + u * (b1 - b0);
    const int nv = Intervals((b - a).norm(), spacing_m_);
    if (counting_) {  // A column's count without visiting its points.
      counted_ += static_cast<std::size_t>(nv) + 1;
      continue;
    }
    for (int j = 0; j <= nv; ++j) {
      const double v = nv == 0 ? 0.0 : static_cast<double>(j) / nv;
      AddPoint(a + v * (b - a), keep);
    }
  }
}

void SurfaceSampler::AddHorizontalRect(double x0, double x1, double y0, double y1, double z,
                                       const KeepFn& keep) {
  AddRuledPatch({x0, y0, z}, {x1, y0, z}, {x0, y1, z}, {x1, y1, z}, keep);
}

void SurfaceSampler::AddVerticalRect(const Vec2& a, const Vec2& b, double z0, double z1,
                                     const KeepFn& keep) {
  AddRuledPatch({a.x(), a.y(), z0}, {b.x(), b.y(), z0}, {a.x(), a.y(), z1}, {b.x(), b.y(), z1},
                keep);
}

void SurfaceSampler::AddVerticalTrapezoid(const Vec2& a, const Vec2& b, double z_base,
                                          double z_top_a, double z_top_b, const KeepFn& keep) {
  AddRuledPatch({a.x(), a.y(), z_base}, {b.x(), b.y(), z_base}, {a.x(), a.y(), z_top_a},
                {b.x(), b.y(), z_top_b}, keep);
}

void SurfaceSampler::AddInclinedRect(const Vec2& a, const Vec2& b, double z_low,
                                     const Vec2& run_dir, double rise, const KeepFn& keep) {
  const Vec2 a_high = a + run_dir;
  const Vec2 b_high = b + run_dir;
  AddRuledPatch({a.x(), a.y(), z_low}, {b.x(), b.y(), z_low},
                {a_high.x(), a_high.y(), z_low + rise}, {b_high.x(), b_high.y(), z_low + rise},
                keep);
}

void SurfaceSampler::AddBoxSurfaces(const Vec3& lo, const Vec3& hi, bool with_bottom,
                                    const KeepFn& keep) {
  AddHorizontalRect(lo.x(), hi.x(), lo.y(), hi.y(), hi.z(), keep);
  if (with_bottom) AddHorizontalRect(lo.x(), hi.x(), lo.y(), hi.y(), lo.z(), keep);
  const Vec2 c00(lo.x(), lo.y()), c10(hi.x(), lo.y()), c11(hi.x(), hi.y()), c01(lo.x(), hi.y());
  AddVerticalRect(c00, c10, lo.z(), hi.z(), keep);
  AddVerticalRect(c10, c11, lo.z(), hi.z(), keep);
  AddVerticalRect(c11, c01, lo.z(), hi.z(), keep);
  AddVerticalRect(c01, c00, lo.z(), hi.z(), keep);
}

void SurfaceSampler::AddVerticalCylinder(double cx, double cy, double r, double z0, double z1,
                                         const KeepFn& keep) {
  // At least 8 columns, so a thin leg still reads as round rather than as a line.
  const int n_around = std::max(8, Intervals(2.0 * kPi * r, spacing_m_));
  const int n_up = Intervals(z1 - z0, spacing_m_);
  for (int i = 0; i < n_around; ++i) {
    const double phi = 2.0 * kPi * i / n_around;
    const double x = cx + r * std::cos(phi);
    const double y = cy + r * std::sin(phi);
    for (int j = 0; j <= n_up; ++j) {
      AddPoint({x, y, z0 + (z1 - z0) * (n_up == 0 ? 0.0 : static_cast<double>(j) / n_up)}, keep);
    }
  }
}

namespace {

// Two unit vectors across the unit vector w; the first is horizontal unless w is vertical.
std::pair<Vec3, Vec3> CrossBasis(const Vec3& w) {
  Vec3 u = w.cross(Vec3::UnitZ());
  if (u.norm() < 1e-6) u = w.cross(Vec3::UnitX());
  u.normalize();
  return {u, w.cross(u)};
}

}  // namespace

void SurfaceSampler::AddCylinder(const Vec3& a, const Vec3& b, double r, const KeepFn& keep) {
  const Vec3 axis = b - a;
  const double length = axis.norm();
  if (length < kEpsM) return;
  const auto [u, v] = CrossBasis(axis / length);
  const int n_around = std::max(8, Intervals(2.0 * kPi * r, spacing_m_));
  const int n_along = Intervals(length, spacing_m_);
  for (int i = 0; i < n_around; ++i) {
    const double phi = 2.0 * kPi * i / n_around;
    const Vec3 radial = r * (std::cos(phi) * u + std::sin(phi) * v);
    for (int j = 0; j <= n_along; ++j) {
      AddPoint(a + (static_cast<double>(j) / n_along) * axis + radial, keep);
    }
  }
}

void SurfaceSampler::AddDisc(const Vec3& center, const Vec3& normal, double r, const KeepFn& keep) {
  const auto [u, v] = CrossBasis(normal.normalized());
  // Rings inside the rim (the rim itself belongs to the mantle), each at about the spacing.
  const int n_rings = Intervals(r, spacing_m_);
  AddPoint(center, keep);
  for (int k = 1; k < n_rings; ++k) {
    const double ring_r = r * k / n_rings;
    const int n = std::max(1, Intervals(2.0 * kPi * ring_r, spacing_m_));
    for (int i = 0; i < n; ++i) {
      const double phi = 2.0 * kPi * i / n;
      AddPoint(center + ring_r * (std::cos(phi) * u + std::sin(phi) * v), keep);
    }
  }
}

void SurfaceSampler::AddEllipsoid(const Vec3& center, double r_xy, double r_z, const KeepFn& keep) {
  const int n_lat = std::max(2, Intervals(kPi * std::max(r_xy, r_z), spacing_m_));
  for (int i = 0; i <= n_lat; ++i) {
    const double theta = kPi * i / n_lat;  // 0 at the top pole.
    const double ring_r = r_xy * std::sin(theta);
    const double z = center.z() + r_z * std::cos(theta);
    const int n_around = std::max(1, Intervals(2.0 * kPi * ring_r, spacing_m_));
    for (int k = 0; k < n_around; ++k) {
      const double phi = 2.0 * kPi * k / n_around;
      AddPoint({center.x() + ring_r * std::cos(phi), center.y() + ring_r * std::sin(phi), z}, keep);
    }
  }
}

void SurfaceSampler::AddHeightField(double x0, double x1, double y0, double y1,
                                    const std::function<double(double, double)>& height,
                                    const KeepFn& keep) {
  const int nx = Intervals(x1 - x0, spacing_m_);
  const int ny = Intervals(y1 - y0, spacing_m_);
  for (int i = 0; i <= nx; ++i) {
    const double x = x0 + (x1 - x0) * (nx == 0 ? 0.0 : static_cast<double>(i) / nx);
    for (int j = 0; j <= ny; ++j) {
      const double y = y0 + (y1 - y0) * (ny == 0 ? 0.0 : static_cast<double>(j) / ny);
      AddPoint({x, y, height(x, y)}, keep);
    }
  }
}

void AddRoomWalls(SurfaceSampler& sampler, double x_max, double y_max, double z0, double z1,
                  const KeepFn& keep) {
  const Vec2 c00(0.0, 0.0), c10(x_max, 0.0), c11(x_max, y_max), c01(0.0, y_max);
  sampler.AddVerticalRect(c00, c10, z0, z1, keep);
  sampler.AddVerticalRect(c10, c11, z0, z1, keep);
  sampler.AddVerticalRect(c11, c01, z0, z1, keep);
  sampler.AddVerticalRect(c01, c00, z0, z1, keep);
}

void AddSolidRamp(SurfaceSampler& s, const SceneRamp& ramp, bool with_sides, double side_extra_m,
                  double back_bottom_z_m, const KeepFn& keep) {
  // Corners in the ramp's own frame: "low" edge at the toe, run along uphill_dir.
  const Vec2 d = ramp.uphill_dir;
  const bool along_x = std::abs(d.x()) > 0.5;
  const double run = along_x ? ramp.x_max_m - ramp.x_min_m : ramp.y_max_m - ramp.y_min_m;
  Vec2 toe_a, toe_b;  // The low edge, across the ramp.
  if (along_x) {
    const double x = d.x() > 0 ? ramp.x_min_m : ramp.x_max_m;
    toe_a = {x, ramp.y_min_m};
    toe_b = {x, ramp.y_max_m};
  } else {
    const double y = d.y() > 0 ? ramp.y_min_m : ramp.y_max_m;
    toe_a = {ramp.x_min_m, y};
    toe_b = {ramp.x_max_m, y};
  }
  const double rise = ramp.z_high_m - ramp.z_low_m;
  s.AddInclinedRect(toe_a, toe_b, ramp.z_low_m, run * d, rise, keep);
  if (with_sides) {
    for (const Vec2& toe : {toe_a, toe_b}) {
      s.AddVerticalTrapezoid(toe, toe + run * d, ramp.z_low_m, ramp.z_low_m + side_extra_m,
                             ramp.z_high_m + side_extra_m, keep);
    }
  }
  if (back_bottom_z_m < ramp.z_high_m - kEpsM) {
    s.AddVerticalRect(toe_a + run * d, toe_b + run * d, back_bottom_z_m, ramp.z_high_m, keep);
  }
}

}  // namespace strata::internal

namespace strata {

double SceneRamp::Run() const {
  return std::abs(uphill_dir.x()) > 0.5 ? x_max_m - x_min_m : y_max_m - y_min_m;
}

double SceneRamp::Width() const {
  return std::abs(uphill_dir.x()) > 0.5 ? y_max_m - y_min_m : x_max_m - x_min_m;
}

bool SceneRamp::Contains(double x_m, double y_m) const {
  return x_m >= x_min_m && x_m <= x_max_m && y_m >= y_min_m && y_m <= y_max_m;
}

double SceneRamp::TopZAt(double x_m, double y_m) const {
  // Distance from the toe along the run, clamped to the ramp.
  double along = 0;
  if (uphill_dir.x() > 0.5)
    along = x_m - x_min_m;
  else if (uphill_dir.x() < -0.5)
    along = x_max_m - x_m;
  else if (uphill_dir.y() > 0.5)
    along = y_m - y_min_m;
  else
    along = y_max_m - y_m;
  const double run = Run();
  along = std::clamp(along, 0.0, run);
  return z_low_m + (z_high_m - z_low_m) * along / run;
}

}  // namespace strata
