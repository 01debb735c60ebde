#pragma once
/// Hand-made point clouds for tests whose expectations need exact geometry (a ceiling at a
/// known height, a ramp at a known slope), built from lattice-sampled planes. Header-only,
/// test code only.
#include <cmath>
#include <functional>
#include <memory>
#include <numbers>

#include "strata/assessment/terrain_model.hpp"
#include "strata/point_cloud.hpp"

namespace strata::test_util {

/// Appends lattice points (spacing_m apart, both ends included) to a cloud.
class CloudBuilder {
 public:
  explicit CloudBuilder(double spacing_m) : spacing_m_(spacing_m) {}

  /// Points on z = height_m(x, y) over [x0, x1] × [y0, y1], skipping (x, y) where `keep`
  /// returns false.
  CloudBuilder& Surface(double x0, double x1, double y0, double y1,
                        const std::function<double(double, double)>& height_m,
                        const std::function<bool(double, double)>& keep = {}) {
    for (int i = 0; i <= Steps(x0, x1); ++i) {
      for (int j = 0; j <= Steps(y0, y1); ++j) {
        const double x = x0 + i * spacing_m_, y = y0 + j * spacing_m_;
        if (!keep || keep(x, y)) Add(x, y, height_m(x, y));
      }
    }
    return *this;
  }
  /// A horizontal plate at height z_m.
  CloudBuilder& Plate(double x0, double x1, double y0, double y1, double z_m) {
    return Surface(x0, x1, y0, y1, [z_m](double, double) { return z_m; });
  }
  /// Every lattice point of the box [x0, x1] × [y0, y1] × [z0, z1] (a solid, e.g. a wall).
  CloudBuilder& Block(double x0, double x1, double y0, double y1, double z0, double z1) {
    for (int k = 0; k <= Steps(z0, z1); ++k) Plate(x0, x1, y0, y1, z0 + k * spacing_m_);
    return *this;
  }
  void Add(double x, double y, double z) {
    cloud_.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  }
  const PointCloud& cloud() const { return cloud_; }

 private:
  int Steps(double a, double b) const {
    return static_cast<int>(std::floor((b - a) / spacing_m_ + 1e-9));
  }
  double spacing_m_;
  PointCloud cloud_;
};

/// A room 8 × 4 m split at x = 4 by a wall 1.5 m high whose only opening (1.2 < y < 2.8) lies
/// under a table top 0.45 m high (|x − 4| <= 0.6): a wheeled biped (body down to 0.35 m +
/// 0.05 m headroom) crouches through, a robot 0.5 m tall cannot pass. Floor at z = 0, outer
/// walls 1.5 m, points 5 cm apart.
inline PointCloud TableRoom() {
  PointCloud cloud;
  const auto add = [&](double x, double y, double z) {
    cloud.emplace_back(static_cast<float>(x), static_cast<float>(y), static_cast<float>(z));
  };
  const double s = 0.05;
  for (double x = 0; x <= 8.0 + 1e-9; x += s) {
    for (double y = 0; y <= 4.0 + 1e-9; y += s) {
      add(x, y, 0);  // Floor.
      const bool opening = y > 1.2 && y < 2.8;
      if (std::abs(x - 4.0) < 0.1 && !opening) {  // Dividing wall, 1.5 m.
        for (double z = s; z <= 1.5; z += s) add(x, y, z);
      }
      if (std::abs(x - 4.0) <= 0.6 && opening) add(x, y, 0.45);  // Table top over the opening.
    }
  }
  for (double z = s; z <= 1.5; z += s) {  // Outer walls.
    for (double x = 0; x <= 8.0 + 1e-9; x += s) add(x, 0, z), add(x, 4.0, z);
    for (double y = 0; y <= 4.0 + 1e-9; y += s) add(0, y, z), add(8.0, y, z);
  }
  return cloud;
}

/// A floor 12 × 7 m with a block over x 3-9, y 1.2-5.8: a south lane (y 0-1.2) and a north
/// lane (y 5.8-7), too narrow for two robots side by side, join the west and east ends. Points
/// 5 cm apart.
inline PointCloud TwoLanes() {
  CloudBuilder b(0.05);
  b.Plate(0, 12, 0, 7, 0.0);
  b.Block(3, 9, 1.2, 5.8, 0.05, 1.5);
  return b.cloud();
}

/// Slope of the Yard's ramp [rad].
inline const double kYardRampSlopeRad = 10.0 * std::numbers::pi / 180.0;

/// A yard 12 × 6 m, floor at z = 0 with a 1 × 1 m hole (x in (1, 2), y in (4.5, 5.5)); a slab
/// 0.45 m above the floor over [2, 4] × [2, 4] (the deck over a passage too low for a 0.5 m
/// body); a kYardRampSlopeRad ramp rising along +x over [7, 10] × [1, 5] to a plateau at
/// x = 10..12. Points 5 cm apart, no walls.
inline PointCloud Yard() {
  CloudBuilder b(0.05);
  const auto in_hole = [](double x, double y) { return x > 1 && x < 2 && y > 4.5 && y < 5.5; };
  const auto under_ramp = [](double x, double y) { return x > 6.99 && y > 0.99 && y < 5.01; };
  b.Surface(
      0, 12, 0, 6, [](double, double) { return 0.0; },
      [&](double x, double y) { return !in_hole(x, y) && !under_ramp(x, y); });
  b.Plate(2, 4, 2, 4, 0.45);
  b.Surface(7, 10, 1, 5, [](double x, double) { return (x - 7) * std::tan(kYardRampSlopeRad); });
  b.Plate(10.05, 12, 1, 5, 3 * std::tan(kYardRampSlopeRad));
  return b.cloud();
}

/// The Yard assessed on a 0.1 m grid (otherwise default settings), built once.
inline const TerrainModel& YardModel() {
  static const std::shared_ptr<const TerrainModel> model = [] {
    AssessmentConfig config;
    config.grid.resolution_m = 0.1;
    return TerrainModel::Assess(Yard(), config).value();
  }();
  return *model;
}

}  // namespace strata::test_util
