#pragma once
/// The safety penalty field S and its diffusion S' (paper Sec. IV, docs/design.md §6).

#include <vector>

#include <Eigen/Core>

#include "strata/assessment/grid.hpp"
#include "strata/assessment/surface_map.hpp"
#include "strata/assessment/terrain_config.hpp"

namespace strata {

/// The paper's cone kernel: m = 2⌈t/r_g⌉ + 1 and
/// A_ij = max(0, 1 − r_g·sqrt((i − (m−1)/2)² + (j − (m−1)/2)²) / t), unnormalised.
/// t = 0 gives the 1×1 identity kernel.
Eigen::MatrixXd ConeKernel(double diffusion_distance_m, double resolution_m);

/// ‖∇H‖ at cell (ix, iy, iz) [1/m]: central differences (one-sided at the grid's edge) of the
/// projected plane's centre height z_c and tilt φ between the neighbouring columns of the same
/// layer, capped at field.max_pose_gradient_per_m. A neighbour with nothing below it (a drop
/// into a void) counts as the cap: stepping there is a fall. A neighbour inside an obstacle (a
/// wall's body at this layer) is left out like one beyond the grid's edge: no pose change
/// happens there, the robot cannot go there, and walls are kept at bay by the ground filter's
/// radius, the distance term and the rim terms, not by S. The x_c, y_c components of H are
/// left out: on any surface they just follow the sampling position (∂x_c/∂x ≈ 1 everywhere)
/// and carry no information about the terrain.
/// Precondition: the cell itself projects onto a surface.
double PoseGradientNorm(const SurfaceMap& surfaces, const FieldConfig& field, int ix, int iy,
                        int iz);

/// S at a cell inside an obstacle: no place for a robot, and no part of S' (SafetyDiffusion).
inline constexpr float kInsideObstacle = -1.0F;

/// S at the cells of `box` (inside the grid): λ_f φ² + λ_m sqrt(‖∇H‖) of the surface each
/// cell projects down onto, field.VoidPenalty() where nothing is below it, kInsideObstacle
/// where it lies inside an obstacle. The result covers the box's cells (CellBox::Geometry).
/// CellBox::Whole gives the dense field.
ScalarGrid ComputeSafetyPenalty(const SurfaceMap& surfaces, const FieldConfig& field,
                                const CellBox& box);

/// S': each horizontal layer of S convolved with the cone kernel scaled to unit sum, one cell
/// at a time. The paper's A sums to about π t²/(3 r_g²); dividing by that sum keeps S' on the
/// scale of S, so the optimiser's threshold s_thr means the same at every resolution. The
/// kernel is renormalised over the cells that count: inside the grid and not inside an
/// obstacle (kInsideObstacle), so a wall's body adds nothing to S' beside it while a drop
/// still does; a cell whose whole kernel is inside obstacles reads field.VoidPenalty().
class SafetyDiffusion {
 public:
  SafetyDiffusion(const FieldConfig& field, double resolution_m);
  /// Half-width of the kernel [cells]: S' at a cell reads S up to this many columns away.
  int reach() const { return reach_; }
  /// S' at `cell` of a grid of `grid_size` cells, from `penalty`, S over `box`, which must
  /// hold every cell of the cell's layer within reach() columns that lies inside the grid.
  float At(const ScalarGrid& penalty, const CellBox& box, const Eigen::Vector3i& grid_size,
           const Eigen::Vector3i& cell) const;

 private:
  struct Tap {
    int dx, dy;
    float weight;
  };
  int reach_ = 0;
  std::vector<Tap> taps_;
  float void_penalty_ = 0;
};

/// S' at every cell of the dense `penalty` (a whole grid): the reference the band is checked
/// against, and what the tests look at.
ScalarGrid DiffuseSafetyPenalty(const ScalarGrid& penalty, const FieldConfig& field);

}  // namespace strata
