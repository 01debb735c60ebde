#pragma once
/// The safety penalty field S and its diffusion S' (paper Sec. IV, docs/design.md §6).

#include <vector>

#include <Eigen/Core>

#include "strata/grid.hpp"
#include "strata/surface_map.hpp"
#include "strata/terrain_config.hpp"

namespace strata {

/// The paper's cone kernel: m = 2⌈t/r_g⌉ + 1 and
/// A_ij = max(0, 1 − r_g·sqrt((i − (m−1)/2)² + (j − (m−1)/2)²) / t), unnormalised.
/// t = 0 gives the 1×1 identity kernel.
Eigen::MatrixXd ConeKernel(double diffusion_distance_m, double resolution_m);

/// ‖∇H‖ at cell (ix, iy, iz) [1/m]: central differences (one-sided at the grid's edge) of the
/// projected plane's centre height z_c and tilt φ between the neighbouring columns of the same
/// layer, capped at field.max_pose_gradient_per_m. A neighbour that projects onto nothing
/// (inside an obstacle, or a void below) counts as the cap: stepping there is a fall or a
/// collision. The x_c, y_c components of H are left out: on any surface they just follow the
/// sampling position (∂x_c/∂x ≈ 1 everywhere) and carry no information about the terrain.
/// Precondition: the cell itself projects onto a surface.
double PoseGradientNorm(const SurfaceMap& surfaces, const FieldConfig& field, int ix, int iy,
                        int iz);

/// S at every cell centre: λ_f φ² + λ_m sqrt(‖∇H‖) of the surface the cell projects down onto,
/// or field.VoidPenalty() where it projects onto nothing.
ScalarGrid ComputeSafetyPenalty(const SurfaceMap& surfaces, const FieldConfig& field,
                                int num_threads);

/// S': each horizontal layer of S convolved with the cone kernel scaled to unit sum. The
/// paper's A sums to about π t²/(3 r_g²); dividing by that sum keeps S' on the scale of S, so
/// the optimiser's threshold s_thr means the same at every resolution. Near the grid's edge
/// the kernel is renormalised over the cells that exist.
ScalarGrid DiffuseSafetyPenalty(const ScalarGrid& penalty, const FieldConfig& field,
                                int num_threads);

}  // namespace strata
