#pragma once
/// Euclidean signed distance field from an occupancy grid, by the exact separable distance
/// transform of Felzenszwalb & Huttenlocher (linear time per axis).

#include <cstdint>
#include <limits>
#include <vector>

#include "strata/assessment/grid.hpp"

namespace strata {

/// Exact 1D squared distance transform of a sampled function (Felzenszwalb & Huttenlocher
/// 2012, "Distance Transforms of Sampled Functions"): out[q] = min_p (q − p)² + f[p].
/// `f` holds +infinity where there is no site; a line without sites stays +infinity. `n`
/// samples are read from f with stride `stride`, written to out with the same stride (entries
/// between them are untouched); f and out must not overlap. `scratch_v` and `scratch_z` must
/// hold n and n + 1 entries. Computed in float: exact for integer-valued f (squared distances
/// in cells) while f + n² < 2^24. Exposed for tests.
void SquaredDistanceTransform1D(const float* f, float* out, int n, std::int64_t stride,
                                int* scratch_v, float* scratch_z);

/// Signed distance [m] at every cell centre: for a free cell, the distance to the nearest
/// occupied cell centre; for an occupied cell, resolution − (distance to the nearest free cell
/// centre), i.e. 0 on the obstacle's boundary layer and negative deeper inside. Distances are
/// capped at `distance_cap_m`, or without a cap (infinity) at the grid's diagonal length: with
/// no occupied cell at all every value is the cap, with no free cell every value is
/// resolution − cap.
/// `occupied` has geometry.CellCount() entries (non-zero = occupied). Parallel over lines with
/// OpenMP on `num_threads` threads (<= 0: one per core; a grid too small to gain runs on the
/// calling thread); O(cells) time, no allocation beyond the result and small per-thread
/// buffers.
ScalarGrid BuildSignedDistanceField(const GridGeometry& geometry,
                                    const std::vector<std::uint8_t>& occupied,
                                    double distance_cap_m = std::numeric_limits<double>::infinity(),
                                    int num_threads = 0);

}  // namespace strata
