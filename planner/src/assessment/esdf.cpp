#include "strata/assessment/esdf.hpp"

#include <algorithm>
#include <cassert>
#include <cmath>
#include <limits>
#include <vector>

#include "parallel_internal.hpp"

namespace strata {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// Columns gathered per block in the y and z passes: 16 floats are one 64-byte cache line, so
// each strided row read brings in a full line that is used entirely.
constexpr int kBlockWidth = 16;

// Below this many cells the transform takes well under a millisecond on one core, less than
// waking a team of threads (and much less on a loaded machine), so it runs serially. Read
// only by an OpenMP pragma: unused, not wrong, in a build without OpenMP (ThreadSanitizer's).
[[maybe_unused]] constexpr std::int64_t kMinCellsForThreads = std::int64_t{1} << 16;

// Felzenszwalb–Huttenlocher lower envelope of the parabolas (q − p)² + f[p] over the sites
// with finite f[p], for the general strided API, in float. For integer-valued f (squared
// distances in cells) it is exact while f + n² < 2^24: every h = f + q² and difference is then
// an exact float, and a non-integer intersection of two parabolas lies at least 1/(2n) from any
// integer, more than the quotient's rounding (half an ulp of s < n), so rounding never changes
// which parabola wins at a sample; an intersection at an integer is a tie, where either
// parabola gives the same value.
void LowerEnvelopeStrided(const float* f, float* out, int n, std::int64_t stride, int* v,
                          float* z) {
  if (n <= 0) return;
  int k = -1;  // Index of the rightmost parabola in the envelope.
  for (int q = 0; q < n; ++q) {
    const float fq = f[q * stride];
    if (fq == kInf) continue;  // Not a site.
    const float hq = fq + static_cast<float>(q) * static_cast<float>(q);
    float s = -kInf;
    while (k >= 0) {
      const int p = v[k];
      const float hp = f[p * stride] + static_cast<float>(p) * static_cast<float>(p);
      s = (hq - hp) / (2.0f * static_cast<float>(q - p));
      if (s > z[k]) break;
      --k;  // Parabola p is hidden by q from z[k] on; z[0] = −∞ stops this at k = 0.
    }
    ++k;
    v[k] = q;
    z[k] = s;
  }
  if (k < 0) {
    for (int q = 0; q < n; ++q) out[q * stride] = kInf;
    return;
  }
  z[k + 1] = kInf;
  int j = 0;
  for (int q = 0; q < n; ++q) {
    while (z[j + 1] < static_cast<float>(q)) ++j;
    const int p = v[j];
    const float dq = static_cast<float>(q - p);
    out[q * stride] = dq * dq + f[p * stride];
  }
}

// The field keeps one float per cell for both transforms: |value| is the squared distance (in
// cells) found so far to the nearest cell of the *other* class, and the sign bit marks an
// occupied cell. The distance to a cell's own class is 0, so nothing is lost, and each pass
// moves half the memory of two separate transforms. |value| >= 1 always, so the sign is never
// that of a zero.
inline bool IsOccupied(float value) { return std::signbit(value); }

// Per-thread scratch for the field's line transforms, sized for the longest line.
struct LineScratch {
  explicit LineScratch(int n) : v(n), h(n) {}
  std::vector<int> v;           // Sites of the envelope's parabolas, left to right.
  std::vector<std::int64_t> h;  // f(v) + v² of each.
};

// The same lower envelope, specialised for the field's hot loop. The field's values are
// integers (squared distances in cells), so it works in exact integer arithmetic: with
// h(p) = f(p) + p², the parabolas of sites p < q meet at s = (h(q) − h(p)) / (2(q − p)), and
// every comparison of such an s against another intersection or a sample position is made by
// cross-multiplying the (positive) denominators. No division, no rounding at any grid size,
// and sites are added explicitly, so a run's neighbours can be added with value 0.
class Envelope {
 public:
  explicit Envelope(LineScratch& s) : v_(s.v.data()), h_(s.h.data()) {}

  void Clear() { k_ = -1; }

  // Adds the parabola (x − q)² + fq, fq an integer-valued float; q must exceed every site
  // added since Clear().
  void Add(int q, float fq) {
    const std::int64_t hq = static_cast<std::int64_t>(fq) + std::int64_t{q} * q;
    int k = k_;
    // Pop parabola k while it is nowhere strictly lowest: its intersection with q is at or
    // left of its intersection with parabola k − 1.
    while (k >= 1 &&
           (hq - h_[k]) * (v_[k] - v_[k - 1]) <= (h_[k] - h_[k - 1]) * std::int64_t{q - v_[k]}) {
      --k;
    }
    ++k;
    v_[k] = q;
    h_[k] = hq;
    k_ = k;
  }

  // Calls emit(q, min over sites p of (q − p)² + f(p)) for q in [a, b], or +∞ without sites.
  template <typename Emit>
  void Evaluate(int a, int b, const Emit& emit) const {
    if (k_ < 0) {
      for (int q = a; q <= b; ++q) emit(q, kInf);
      return;
    }
    int j = 0;
    for (int q = a; q <= b; ++q) {
      // Advance while parabolas j and j + 1 meet left of q.
      while (j < k_ && h_[j + 1] - h_[j] < 2 * std::int64_t{q} * (v_[j + 1] - v_[j])) ++j;
      const std::int64_t p = v_[j];
      emit(q, static_cast<float>(std::int64_t{q} * (q - 2 * p) + h_[j]));
    }
  }

 private:
  int* v_;
  std::int64_t* h_;
  int k_ = -1;
};

// One line of the separable transform on the signed encoding. Within a maximal run of cells of
// one class, the nearest cell of the other class along the line is either a run's neighbour
// (value 0 for this transform) or reached through a cell of the run itself: any site beyond a
// neighbour is farther than that neighbour and can be dropped. So each run is an independent
// envelope over itself plus its (at most two) neighbours, and the whole line costs O(n) for
// both transforms together. `in` and `out` must not overlap.
void TransformSignedLine(const float* in, float* out, int n, LineScratch& scratch) {
  Envelope envelope(scratch);
  int a = 0;
  while (a < n) {
    const bool occupied = IsOccupied(in[a]);
    envelope.Clear();
    if (a > 0) envelope.Add(a - 1, 0.0f);
    int b = a;
    for (; b < n && IsOccupied(in[b]) == occupied; ++b) {
      const float f = std::fabs(in[b]);
      if (f != kInf) envelope.Add(b, f);
    }
    // Now the run is [a, b - 1] and b is its right neighbour, if any.
    if (b < n) envelope.Add(b, 0.0f);
    if (occupied) {
      envelope.Evaluate(a, b - 1, [out](int q, float d) { out[q] = -d; });
    } else {
      envelope.Evaluate(a, b - 1, [out](int q, float d) { out[q] = d; });
    }
    a = b;
  }
}

// The x pass starts from the binary occupancy, where the transform is just the squared
// distance to the nearest cell of the other class in the row: two sweeps, no envelope. Returns
// false when the row holds one class only (all values ±∞), which is most rows of a terrain.
bool TransformOccupancyRow(const std::uint8_t* occupied, float* out, int n) {
  // Branch-free reductions first: they vectorise, and settle the common one-class rows.
  unsigned any = 0;
  unsigned all = 1;
  for (int x = 0; x < n; ++x) {
    any |= occupied[x] != 0;
    all &= occupied[x] != 0;
  }
  if (any == 0 || all == 1) {
    std::fill(out, out + n, any == 0 ? kInf : -kInf);
    return false;
  }
  int last_occupied = -1;
  int last_free = -1;
  for (int x = 0; x < n; ++x) {
    if (occupied[x] != 0) {
      last_occupied = x;
      out[x] = last_free >= 0 ? static_cast<float>(x - last_free) : kInf;
    } else {
      last_free = x;
      out[x] = last_occupied >= 0 ? static_cast<float>(x - last_occupied) : kInf;
    }
  }
  int next_occupied = -1;
  int next_free = -1;
  for (int x = n - 1; x >= 0; --x) {
    if (occupied[x] != 0) {
      next_occupied = x;
      const float right = next_free >= 0 ? static_cast<float>(next_free - x) : kInf;
      const float d = std::min(out[x], right);
      out[x] = -(d * d);
    } else {
      next_free = x;
      const float right = next_occupied >= 0 ? static_cast<float>(next_occupied - x) : kInf;
      const float d = std::min(out[x], right);
      out[x] = d * d;
    }
  }
  return true;
}

}  // namespace

void SquaredDistanceTransform1D(const float* f, float* out, int n, std::int64_t stride,
                                int* scratch_v, float* scratch_z) {
  LowerEnvelopeStrided(f, out, n, stride, scratch_v, scratch_z);
}

ScalarGrid BuildSignedDistanceField(const GridGeometry& geometry,
                                    const std::vector<std::uint8_t>& occupied,
                                    double distance_cap_m,
                                    [[maybe_unused]] int num_threads) {  // OpenMP only.
  assert(static_cast<std::int64_t>(occupied.size()) == geometry.CellCount());
  const int nx = geometry.size.x();
  const int ny = geometry.size.y();
  const int nz = geometry.size.z();
  const std::int64_t layer = geometry.LayerCellCount();
  const double r = geometry.resolution_m;
  // Without a cap: farther than any two cell centres, the value where no cell of the other
  // class exists.
  const double cap_m =
      std::isfinite(distance_cap_m) ? distance_cap_m : geometry.size.cast<double>().norm() * r;
  const int blocks_per_row = (nx + kBlockWidth - 1) / kBlockWidth;
  const int longest_line = std::max({nx, ny, nz});

  std::vector<float> field(static_cast<std::size_t>(geometry.CellCount()));
  float* const d = field.data();
  const std::uint8_t* const occ = occupied.data();

  // An explicit team size: a caller's one-thread region around this call is not an active
  // level of parallelism, so without it the transform would take every core.
#pragma omp parallel if (geometry.CellCount() >= kMinCellsForThreads) \
    num_threads(internal::ResolveThreadCount(num_threads))
  {
    // Per-thread scratch: a gathered block of columns (input and output) and the envelope.
    std::vector<float> block_in(static_cast<std::size_t>(kBlockWidth) * longest_line);
    std::vector<float> block_out(block_in.size());
    LineScratch line_scratch(longest_line);

    // x then y, one horizontal layer at a time: the layer (nx·ny floats) stays in cache
    // between the two passes.
#pragma omp for schedule(dynamic, 1)
    for (int iz = 0; iz < nz; ++iz) {
      float* const slab = d + iz * layer;
      const std::uint8_t* const occ_slab = occ + iz * layer;
      bool mixed_rows = false;
      const bool first_row_occupied = occ_slab[0] != 0;
      bool same_class_rows = true;
      for (int iy = 0; iy < ny; ++iy) {
        const std::int64_t row = std::int64_t{iy} * nx;
        mixed_rows |= TransformOccupancyRow(occ_slab + row, slab + row, nx);
        same_class_rows &= (occ_slab[row] != 0) == first_row_occupied;
      }
      // A layer of one class (often: empty air above the terrain) stays ±∞ through y.
      if (ny == 1 || (!mixed_rows && same_class_rows)) continue;
      for (int x0 = 0; x0 < nx; x0 += kBlockWidth) {
        const int w = std::min(kBlockWidth, nx - x0);
        for (int iy = 0; iy < ny; ++iy) {
          const float* row = slab + std::int64_t{iy} * nx + x0;
          for (int c = 0; c < w; ++c) block_in[c * ny + iy] = row[c];
        }
        for (int c = 0; c < w; ++c) {
          TransformSignedLine(&block_in[c * ny], &block_out[c * ny], ny, line_scratch);
        }
        for (int iy = 0; iy < ny; ++iy) {
          float* row = slab + std::int64_t{iy} * nx + x0;
          for (int c = 0; c < w; ++c) row[c] = block_out[c * ny + iy];
        }
      }
    }

    // z, one block of columns at a time, converting to signed metres on the way out.
    // Float throughout: the values are stored as float anyway, and float sqrt is far cheaper.
    const float r_f = static_cast<float>(r);
    const float cap_f = static_cast<float>(cap_m);
    const auto to_metres = [r_f, cap_f](float squared_cells) {
      const float distance = std::min(std::sqrt(std::fabs(squared_cells)) * r_f, cap_f);
      return IsOccupied(squared_cells) ? r_f - distance : distance;
    };
    const int block_count = ny * blocks_per_row;
#pragma omp for schedule(dynamic, 8)
    for (int item = 0; item < block_count; ++item) {
      const int iy = item / blocks_per_row;
      const int x0 = (item % blocks_per_row) * kBlockWidth;
      const int w = std::min(kBlockWidth, nx - x0);
      float* const column_base = d + std::int64_t{iy} * nx + x0;
      for (int iz = 0; iz < nz; ++iz) {
        const float* row = column_base + iz * layer;
        for (int c = 0; c < w; ++c) block_in[c * nz + iz] = row[c];
      }
      for (int c = 0; c < w; ++c) {
        TransformSignedLine(&block_in[c * nz], &block_out[c * nz], nz, line_scratch);
      }
      for (int iz = 0; iz < nz; ++iz) {
        float* row = column_base + iz * layer;
        for (int c = 0; c < w; ++c) row[c] = to_metres(block_out[c * nz + iz]);
      }
    }
  }

  return ScalarGrid(geometry, std::move(field));
}

}  // namespace strata
