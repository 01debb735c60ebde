#include "strata/assessment/grid.hpp"

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "test_util/gradient_check.hpp"

namespace strata {
namespace {

using ::testing::HasSubstr;

GridGeometry MakeGeometry(const Eigen::Vector3d& origin, double resolution,
                          const Eigen::Vector3i& size) {
  GridGeometry g;
  g.origin_m = origin;
  g.resolution_m = resolution;
  g.size = size;
  return g;
}

ScalarGrid RandomGrid(const GridGeometry& g, std::mt19937& rng) {
  std::uniform_real_distribution<float> value(-3.0f, 3.0f);
  std::vector<float> values(static_cast<std::size_t>(g.CellCount()));
  for (float& v : values) v = value(rng);
  return ScalarGrid(g, std::move(values));
}

// A random point inside the hull of cell centres whose centre coordinate on every axis is at
// least `margin` (in cells) away from an integer, i.e. from the interpolant's kinks.
Eigen::Vector3d RandomPointAwayFromKinks(const GridGeometry& g, double margin, std::mt19937& rng) {
  Eigen::Vector3d p;
  for (int a = 0; a < 3; ++a) {
    std::uniform_int_distribution<int> cell(0, std::max(0, g.size[a] - 2));
    std::uniform_real_distribution<double> frac(margin, 1.0 - margin);
    const double u = cell(rng) + frac(rng);
    p[a] = g.origin_m[a] + (u + 0.5) * g.resolution_m;
  }
  return p;
}

TEST(GridGeometryTest, IndexEnumeratesCellsXFastest) {
  const GridGeometry g = MakeGeometry(Eigen::Vector3d::Zero(), 0.5, {5, 4, 3});
  std::int64_t expected = 0;
  for (int iz = 0; iz < 3; ++iz) {
    for (int iy = 0; iy < 4; ++iy) {
      for (int ix = 0; ix < 5; ++ix) {
        EXPECT_EQ(g.Index(ix, iy, iz), expected);
        EXPECT_EQ(g.Index(Eigen::Vector3i(ix, iy, iz)), expected);
        ++expected;
      }
    }
  }
  EXPECT_EQ(expected, g.CellCount());
  EXPECT_EQ(g.LayerCellCount(), 20);
}

TEST(GridGeometryTest, CellOfAndCellCenterRoundTrip) {
  std::mt19937 rng(7);
  const GridGeometry g = MakeGeometry({-3.7, 12.1, -0.4}, 0.2, {40, 30, 20});
  for (int trial = 0; trial < 1000; ++trial) {
    const Eigen::Vector3i c(std::uniform_int_distribution<int>(0, 39)(rng),
                            std::uniform_int_distribution<int>(0, 29)(rng),
                            std::uniform_int_distribution<int>(0, 19)(rng));
    EXPECT_TRUE(g.Contains(c));
    EXPECT_EQ(g.CellOf(g.CellCenter(c)), c);
  }
  // A point lies in the cell whose centre is within half a cell of it.
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 1000; ++trial) {
    const Eigen::Vector3d p =
        g.origin_m + Eigen::Vector3d(unit(rng) * 8.0, unit(rng) * 6.0, unit(rng) * 4.0);
    const Eigen::Vector3i c = g.CellOf(p);
    ASSERT_TRUE(g.Contains(c));
    EXPECT_LE((g.CellCenter(c) - p).cwiseAbs().maxCoeff(), 0.5 * g.resolution_m + 1e-12);
  }
  EXPECT_FALSE(g.Contains(g.CellOf(g.origin_m - Eigen::Vector3d(0.01, 0.0, 0.0))));
  EXPECT_FALSE(g.Contains(Eigen::Vector3i(40, 0, 0)));
}

// OffsetsOfIndex must agree with floor(d / r) to the bit, at its ends and one ulp beside
// them, for resolutions that are no binary fractions and for negative cells too.
TEST(GridGeometryTest, OffsetsOfIndexAgreeWithTheDivisionAtTheirEnds) {
  int off_product = 0;  // Ends that differ from index·r: the search for them matters.
  for (const double r : {0.1, 0.2, 0.3, 0.05, 0.15, 1.0}) {
    GridGeometry g;
    g.resolution_m = r;
    for (int index = -300; index <= 300; ++index) {
      const GridGeometry::OffsetRange range = g.OffsetsOfIndex(index);
      const auto cell = [r](double d) { return std::floor(d / r); };
      const double inf = std::numeric_limits<double>::infinity();
      EXPECT_EQ(cell(range.low), index) << r << " " << index;
      EXPECT_EQ(cell(std::nextafter(range.low, -inf)), index - 1) << r << " " << index;
      EXPECT_EQ(cell(std::nextafter(range.high, -inf)), index) << r << " " << index;
      EXPECT_EQ(cell(range.high), index + 1) << r << " " << index;
      off_product += range.low != index * r;
    }
  }
  EXPECT_GT(off_product, 100);
  // A position that overflowed has no cell, and the search for the ends must not hang on it.
  GridGeometry g;
  for (const double index :
       {-std::numeric_limits<double>::infinity(), std::numeric_limits<double>::infinity()}) {
    const GridGeometry::OffsetRange range = g.OffsetsOfIndex(index);
    EXPECT_FALSE(range.low < range.high) << index;
  }
  EXPECT_FALSE(g.OffsetsOfIndex(std::numeric_limits<double>::quiet_NaN()).low <= 0);
}

TEST(MakeGridGeometryTest, CoversBoundsGrownByPadding) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> coord(-50.0, 50.0);
  std::uniform_real_distribution<double> extent(0.0, 20.0);
  std::uniform_real_distribution<double> resolution(0.05, 0.5);
  std::uniform_real_distribution<double> padding(0.0, 2.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d lo(coord(rng), coord(rng), coord(rng));
    const Eigen::Vector3d hi = lo + Eigen::Vector3d(extent(rng), extent(rng), extent(rng));
    const double r = resolution(rng);
    const double pad = padding(rng);
    const Expected<GridGeometry> g = MakeGridGeometry({lo, hi}, r, pad, 200'000'000);
    ASSERT_TRUE(g.ok()) << g.error().message;
    EXPECT_EQ(g->resolution_m, r);
    EXPECT_LT((g->origin_m - (lo.array() - pad).matrix()).norm(), 1e-12);
    for (int a = 0; a < 3; ++a) {
      EXPECT_GE(g->size[a], 1);
      // Covers [lo − pad, hi + pad] with no spare cell.
      const double top = g->origin_m[a] + g->size[a] * r;
      EXPECT_GE(top, hi[a] + pad - 1e-9);
      EXPECT_LT(top - r, hi[a] + pad);
    }
    EXPECT_TRUE(g->Contains(g->CellOf(lo)));
    EXPECT_TRUE(g->Contains(g->CellOf(0.5 * (lo + hi))));
  }
}

TEST(MakeGridGeometryTest, PointBoundsGetOneCellPerAxis) {
  const Eigen::Vector3d p(1.0, 2.0, 3.0);
  const Expected<GridGeometry> g = MakeGridGeometry({p, p}, 0.2, 0.0, 1000);
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->size, Eigen::Vector3i(1, 1, 1));
}

TEST(MakeGridGeometryTest, RefusesAbsurdBoundsWithTheLimitInTheMessage) {
  const Eigen::AlignedBox3d bounds(Eigen::Vector3d(0.0, 0.0, 0.0),
                                   Eigen::Vector3d(1.0e7, 3.0, 5.0));
  const Expected<GridGeometry> g = MakeGridGeometry(bounds, 0.2, 0.0, 200'000'000);
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, ErrorCode::kResourceExhausted);
  EXPECT_THAT(g.error().message, HasSubstr("2e+08"));
  EXPECT_THAT(g.error().message, HasSubstr("1e+07"));
  EXPECT_THAT(g.error().message, HasSubstr("columns"));
}

TEST(MakeGridGeometryTest, RefusesAxesBeyondIntEvenWithoutACellLimit) {
  const Eigen::AlignedBox3d bounds(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0e12, 0.0, 0.0));
  const Expected<GridGeometry> g =
      MakeGridGeometry(bounds, 0.1, 0.0, std::numeric_limits<std::int64_t>::max());
  ASSERT_FALSE(g.ok());
  EXPECT_EQ(g.error().code, ErrorCode::kResourceExhausted);
}

TEST(MakeGridGeometryTest, RefusesBadResolutionBoundsAndPadding) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d::Zero(), Eigen::Vector3d::Ones());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  for (const double r : {0.0, -0.2, nan, inf}) {
    const Expected<GridGeometry> g = MakeGridGeometry(box, r, 0.5, 1'000'000);
    ASSERT_FALSE(g.ok()) << "resolution " << r;
    EXPECT_EQ(g.error().code, ErrorCode::kInvalidInput);
    EXPECT_THAT(g.error().message, HasSubstr("resolution"));
  }
  for (const double pad : {-0.1, nan}) {
    const Expected<GridGeometry> g = MakeGridGeometry(box, 0.2, pad, 1'000'000);
    ASSERT_FALSE(g.ok()) << "padding " << pad;
    EXPECT_EQ(g.error().code, ErrorCode::kInvalidInput);
  }
  EXPECT_EQ(MakeGridGeometry(Eigen::AlignedBox3d(), 0.2, 0.5, 1'000'000).error().code,
            ErrorCode::kInvalidInput);
  const Eigen::AlignedBox3d not_finite(Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, nan, 1.0));
  EXPECT_EQ(MakeGridGeometry(not_finite, 0.2, 0.5, 1'000'000).error().code,
            ErrorCode::kInvalidInput);
}

TEST(ScalarGridTest, SampleIsExactAtCellCentres) {
  std::mt19937 rng(3);
  const GridGeometry g = MakeGeometry({1.3, -2.1, 0.7}, 0.2, {9, 7, 5});
  const ScalarGrid grid = RandomGrid(g, rng);
  for (int iz = 0; iz < 5; ++iz) {
    for (int iy = 0; iy < 7; ++iy) {
      for (int ix = 0; ix < 9; ++ix) {
        const Eigen::Vector3i c(ix, iy, iz);
        // Only the rounding of the centre's coordinates separates this from exact.
        EXPECT_NEAR(grid.Sample(g.CellCenter(c)), grid.at(ix, iy, iz), 1e-12);
      }
    }
  }
}

TEST(ScalarGridTest, ReproducesLinearFunctionsWithExactGradient) {
  // Dyadic origin, resolution and coefficients make every centre value exact in float, so
  // the interpolant is the linear function itself up to double rounding.
  const GridGeometry g = MakeGeometry({-2.0, 1.0, 0.5}, 0.25, {12, 10, 8});
  const Eigen::Vector3d slope(1.5, -2.0, 0.75);
  const double offset = 3.0;
  std::vector<float> values(static_cast<std::size_t>(g.CellCount()));
  for (int iz = 0; iz < 8; ++iz) {
    for (int iy = 0; iy < 10; ++iy) {
      for (int ix = 0; ix < 12; ++ix) {
        const double v = slope.dot(g.CellCenter({ix, iy, iz})) + offset;
        values[g.Index(ix, iy, iz)] = static_cast<float>(v);
        ASSERT_EQ(static_cast<double>(values[g.Index(ix, iy, iz)]), v);
      }
    }
  }
  const ScalarGrid grid(g, std::move(values));
  std::mt19937 rng(5);
  const Eigen::Vector3d lo = g.CellCenter({0, 0, 0});
  const Eigen::Vector3d hi = g.CellCenter(g.size - Eigen::Vector3i::Ones());
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d p =
        lo + (hi - lo).cwiseProduct(Eigen::Vector3d(unit(rng), unit(rng), unit(rng)));
    Eigen::Vector3d gradient;
    const double value = grid.Sample(p, &gradient);
    EXPECT_NEAR(value, slope.dot(p) + offset, 1e-12);
    EXPECT_LT((gradient - slope).norm(), 1e-12) << gradient.transpose();
  }
}

TEST(ScalarGridTest, GradientMatchesFiniteDifferences) {
  std::mt19937 rng(13);
  const GridGeometry g = MakeGeometry({-1.1, 0.3, 2.0}, 0.2, {11, 9, 7});
  const ScalarGrid grid = RandomGrid(g, rng);
  const auto f = [&grid](const Eigen::Vector3d& p) { return grid.Sample(p); };
  for (int trial = 0; trial < 2000; ++trial) {
    // A margin of 0.05 cells keeps the ±h probes (h = 1e-5 m = 5e-5 cells) inside one cell,
    // where the interpolant is trilinear and central differences carry only rounding error
    // (~1e-16 · 3 / 1e-5 ≈ 3e-11).
    const Eigen::Vector3d p = RandomPointAwayFromKinks(g, 0.05, rng);
    Eigen::Vector3d gradient;
    grid.Sample(p, &gradient);
    const Eigen::Vector3d numerical = test_util::NumericalFieldGradient(f, p, 1e-5);
    EXPECT_LT(test_util::RelativeError(gradient, numerical), 1e-6)
        << "at " << p.transpose() << ": " << gradient.transpose() << " vs "
        << numerical.transpose();
  }
}

TEST(ScalarGridTest, ClampsOutsideTheHullOfCentres) {
  std::mt19937 rng(17);
  const GridGeometry g = MakeGeometry({0.0, 0.0, 0.0}, 0.2, {6, 5, 4});
  const ScalarGrid grid = RandomGrid(g, rng);
  const Eigen::Vector3d lo = g.CellCenter({0, 0, 0});
  const Eigen::Vector3d hi = g.CellCenter(g.size - Eigen::Vector3i::Ones());
  std::uniform_real_distribution<double> coord(-2.0, 3.0);
  int clamped_seen = 0;
  for (int trial = 0; trial < 2000; ++trial) {
    const Eigen::Vector3d p(coord(rng), coord(rng), coord(rng));
    const Eigen::Vector3d q = p.cwiseMax(lo).cwiseMin(hi);
    Eigen::Vector3d gp;
    Eigen::Vector3d gq;
    const double vp = grid.Sample(p, &gp);
    const double vq = grid.Sample(q, &gq);
    EXPECT_NEAR(vp, vq, 1e-12);
    for (int a = 0; a < 3; ++a) {
      if (p[a] < lo[a] || p[a] > hi[a]) {
        ++clamped_seen;
        EXPECT_EQ(gp[a], 0.0);
      } else {
        EXPECT_NEAR(gp[a], gq[a], 1e-9);
      }
    }
  }
  EXPECT_GT(clamped_seen, 1000);
  // Far away and non-finite positions still read a corner value instead of out-of-range memory.
  EXPECT_NEAR(grid.Sample({1e9, -1e9, 1e9}), grid.at(5, 0, 3), 1e-12);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_TRUE(std::isfinite(grid.Sample({nan, nan, nan})));
}

TEST(ScalarGridTest, OneCellAxisIsConstantAlongIt) {
  std::mt19937 rng(19);
  const GridGeometry g = MakeGeometry({0.0, 0.0, 0.0}, 0.2, {5, 4, 1});
  const ScalarGrid grid = RandomGrid(g, rng);
  std::uniform_real_distribution<double> xy(0.1, 0.7);
  std::uniform_real_distribution<double> z(-1.0, 1.0);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Vector3d p(xy(rng), xy(rng), z(rng));
    Eigen::Vector3d gradient;
    const double value = grid.Sample(p, &gradient);
    EXPECT_NEAR(value, grid.Sample({p.x(), p.y(), 0.1}), 1e-12);
    EXPECT_EQ(gradient.z(), 0.0);
  }
}

}  // namespace
}  // namespace strata
