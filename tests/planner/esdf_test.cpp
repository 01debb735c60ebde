#include "strata/assessment/esdf.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "test_util/gradient_check.hpp"

namespace strata {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// The definition, evaluated naively: out[q] = min_p (q − p)² + f[p].
std::vector<float> BruteForce1D(const std::vector<float>& f) {
  const int n = static_cast<int>(f.size());
  std::vector<float> out(f.size(), kInf);
  for (int q = 0; q < n; ++q) {
    for (int p = 0; p < n; ++p) {
      const float dq = static_cast<float>(q - p);
      out[q] = std::min(out[q], dq * dq + f[p]);
    }
  }
  return out;
}

std::vector<float> Transform1D(const std::vector<float>& f) {
  const int n = static_cast<int>(f.size());
  std::vector<float> out(f.size());
  std::vector<int> v(f.size());
  std::vector<float> z(f.size() + 1);
  SquaredDistanceTransform1D(f.data(), out.data(), n, 1, v.data(), z.data());
  return out;
}

// Signed distance at every cell centre from its definition, by exhaustive search: a free cell
// gets the distance to the nearest occupied centre, an occupied cell the resolution minus the
// distance to the nearest free centre, and a missing other class counts as the grid diagonal.
// O(free · occupied) time.
std::vector<double> BruteForceField(const GridGeometry& g, const std::vector<std::uint8_t>& occ) {
  const double r = g.resolution_m;
  const double diagonal = g.size.cast<double>().norm() * r;
  std::vector<Eigen::Vector3i> by_class[2];
  for (int iz = 0; iz < g.size.z(); ++iz) {
    for (int iy = 0; iy < g.size.y(); ++iy) {
      for (int ix = 0; ix < g.size.x(); ++ix) {
        by_class[occ[g.Index(ix, iy, iz)] != 0 ? 1 : 0].emplace_back(ix, iy, iz);
      }
    }
  }
  std::vector<double> out(static_cast<std::size_t>(g.CellCount()));
  for (const int cls : {0, 1}) {
    for (const Eigen::Vector3i& c : by_class[cls]) {
      std::int64_t best = std::numeric_limits<std::int64_t>::max();
      for (const Eigen::Vector3i& o : by_class[1 - cls]) {
        best = std::min<std::int64_t>(best, (o - c).squaredNorm());
      }
      const double distance =
          best == std::numeric_limits<std::int64_t>::max() ? diagonal : std::sqrt(double(best)) * r;
      out[g.Index(c)] = cls == 1 ? r - distance : distance;
    }
  }
  return out;
}

GridGeometry MakeGeometry(const Eigen::Vector3i& size, double resolution) {
  GridGeometry g;
  g.origin_m = Eigen::Vector3d(-1.3, 2.2, 0.4);
  g.resolution_m = resolution;
  g.size = size;
  return g;
}

std::vector<std::uint8_t> RandomOccupancy(const GridGeometry& g, double density,
                                          std::mt19937& rng) {
  std::bernoulli_distribution occupied(density);
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(g.CellCount()));
  for (std::uint8_t& o : occ) o = occupied(rng) ? 1 : 0;
  return occ;
}

void ExpectFieldMatchesBruteForce(const GridGeometry& g, const std::vector<std::uint8_t>& occ,
                                  const std::string& label) {
  const ScalarGrid field = BuildSignedDistanceField(g, occ);
  ASSERT_EQ(field.geometry().size, g.size);
  ASSERT_EQ(static_cast<std::int64_t>(field.values().size()), g.CellCount());
  const std::vector<double> expected = BruteForceField(g, occ);
  int mismatches = 0;
  for (std::size_t i = 0; i < expected.size(); ++i) {
    const double tolerance = 1e-5 * std::max(1.0, std::abs(expected[i]));
    if (std::abs(field.values()[i] - expected[i]) > tolerance && ++mismatches <= 5) {
      ADD_FAILURE() << label << ": cell " << i << " has " << field.values()[i] << ", expected "
                    << expected[i] << " (occupied " << int(occ[i]) << ")";
    }
  }
  EXPECT_EQ(mismatches, 0) << label;
}

TEST(SquaredDistanceTransform1DTest, MatchesBruteForceOnIntegerInputsExactly) {
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> length(1, 60);
  std::uniform_int_distribution<int> value(0, 80);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 3000; ++trial) {
    const double p_site = unit(rng);
    std::vector<float> f(static_cast<std::size_t>(length(rng)));
    for (float& x : f) x = unit(rng) < p_site ? static_cast<float>(value(rng)) : kInf;
    const std::vector<float> got = Transform1D(f);
    const std::vector<float> want = BruteForce1D(f);
    // The field only ever feeds integer squared distances: there the result must be exact.
    ASSERT_EQ(got, want) << "trial " << trial;
  }
}

TEST(SquaredDistanceTransform1DTest, IsExactOnLongLinesWithLargeValues) {
  // Lines as long as a large map's grid, with squared distances as large as the grid allows:
  // the float arithmetic must still be exact (f + n² < 2^24).
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> length(500, 2500);
  std::uniform_int_distribution<int> value(0, 6'000'000);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    const double p_site = trial % 2 == 0 ? 0.01 : 0.5;
    std::vector<float> f(static_cast<std::size_t>(length(rng)));
    for (float& x : f) x = unit(rng) < p_site ? static_cast<float>(value(rng)) : kInf;
    ASSERT_EQ(Transform1D(f), BruteForce1D(f)) << "trial " << trial;
  }
}

TEST(SquaredDistanceTransform1DTest, MatchesBruteForceOnRealInputs) {
  std::mt19937 rng(2);
  std::uniform_int_distribution<int> length(1, 60);
  std::uniform_real_distribution<float> value(0.0f, 50.0f);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  for (int trial = 0; trial < 3000; ++trial) {
    std::vector<float> f(static_cast<std::size_t>(length(rng)));
    for (float& x : f) x = unit(rng) < 0.4 ? value(rng) : kInf;
    const std::vector<float> got = Transform1D(f);
    const std::vector<float> want = BruteForce1D(f);
    for (std::size_t q = 0; q < f.size(); ++q) {
      // Intersections are computed in float: a near-tie may pick the other parabola, whose
      // value differs by float rounding only.
      if (std::isinf(want[q])) {
        EXPECT_EQ(got[q], want[q]);
      } else {
        EXPECT_NEAR(got[q], want[q], 1e-5f * std::max(1.0f, want[q])) << "trial " << trial;
      }
    }
  }
}

TEST(SquaredDistanceTransform1DTest, LineWithoutSitesStaysInfinite) {
  for (const int n : {1, 2, 17}) {
    const std::vector<float> got = Transform1D(std::vector<float>(n, kInf));
    for (const float x : got) EXPECT_EQ(x, kInf);
  }
}

TEST(SquaredDistanceTransform1DTest, HonoursStride) {
  std::mt19937 rng(4);
  std::uniform_int_distribution<int> value(0, 30);
  const int n = 23;
  const int stride = 3;
  std::vector<float> f(n * stride, -1.0f);
  std::vector<float> line(n);
  for (int i = 0; i < n; ++i) {
    line[i] = i % 4 == 1 ? static_cast<float>(value(rng)) : kInf;
    f[i * stride] = line[i];
  }
  std::vector<float> out(n * stride, -7.0f);
  std::vector<int> v(n);
  std::vector<float> z(n + 1);
  SquaredDistanceTransform1D(f.data(), out.data(), n, stride, v.data(), z.data());
  const std::vector<float> want = BruteForce1D(line);
  for (int i = 0; i < n * stride; ++i) {
    if (i % stride == 0) {
      EXPECT_EQ(out[i], want[i / stride]);
    } else {
      EXPECT_EQ(out[i], -7.0f) << "wrote between the strided samples at " << i;
    }
  }
}

TEST(BuildSignedDistanceFieldTest, MatchesBruteForceOnRandomGrids) {
  const GridGeometry g = MakeGeometry({17, 13, 11}, 0.2);
  int seed = 100;
  for (const double density : {0.0, 0.002, 0.02, 0.1, 0.3, 0.7, 0.98, 1.0}) {
    for (int repeat = 0; repeat < 2; ++repeat) {
      std::mt19937 rng(++seed);
      ExpectFieldMatchesBruteForce(
          g, RandomOccupancy(g, density, rng),
          "density " + std::to_string(density) + " seed " + std::to_string(seed));
    }
  }
}

TEST(BuildSignedDistanceFieldTest, MatchesBruteForceOnGridsBigEnoughForThreads) {
  // Large enough to take the parallel path; sparse or dense so the brute force stays quick.
  const GridGeometry g = MakeGeometry({70, 50, 24}, 0.2);
  ASSERT_GE(g.CellCount(), std::int64_t{1} << 16);
  int seed = 400;
  for (const double density : {0.0, 0.01, 0.99, 1.0}) {
    std::mt19937 rng(++seed);
    std::vector<std::uint8_t> occ = RandomOccupancy(g, density, rng);
    if (density == 0.01) {
      // A solid block too, so some occupied cells lie deep inside.
      for (int iz = 5; iz < 11; ++iz) {
        for (int iy = 10; iy < 20; ++iy) {
          for (int ix = 20; ix < 32; ++ix) occ[g.Index(ix, iy, iz)] = 1;
        }
      }
    }
    ExpectFieldMatchesBruteForce(g, occ, "density " + std::to_string(density));
  }
}

TEST(BuildSignedDistanceFieldTest, MatchesBruteForceOnThinAndOddShapes) {
  std::mt19937 rng(200);
  for (const Eigen::Vector3i& size :
       {Eigen::Vector3i(1, 1, 1), Eigen::Vector3i(1, 1, 9), Eigen::Vector3i(1, 8, 1),
        Eigen::Vector3i(40, 1, 1), Eigen::Vector3i(33, 2, 5), Eigen::Vector3i(3, 31, 4),
        Eigen::Vector3i(16, 16, 16), Eigen::Vector3i(35, 9, 1), Eigen::Vector3i(300, 3, 2),
        Eigen::Vector3i(2, 260, 3), Eigen::Vector3i(3, 2, 270)}) {
    const GridGeometry g = MakeGeometry(size, 0.15);
    for (const double density : {0.0, 0.01, 0.05, 0.5, 1.0}) {
      ExpectFieldMatchesBruteForce(g, RandomOccupancy(g, density, rng),
                                   "size " + std::to_string(size.x()) + "x" +
                                       std::to_string(size.y()) + "x" + std::to_string(size.z()) +
                                       " density " + std::to_string(density));
    }
  }
}

TEST(BuildSignedDistanceFieldTest, MatchesBruteForceOnStructuredScenes) {
  // Slabs and walls, like the terrain it is built for: long runs of one class.
  const GridGeometry g = MakeGeometry({29, 23, 17}, 0.1);
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(g.CellCount()), 0);
  for (int iy = 0; iy < 23; ++iy) {
    for (int ix = 0; ix < 29; ++ix) {
      occ[g.Index(ix, iy, 2)] = 1;                           // Floor.
      if (ix > 10 && iy < 15) occ[g.Index(ix, iy, 12)] = 1;  // Overhang.
    }
  }
  for (int iz = 0; iz < 17; ++iz) {
    for (int iy = 4; iy < 20; ++iy) occ[g.Index(22, iy, iz)] = 1;  // Wall.
  }
  ExpectFieldMatchesBruteForce(g, occ, "slabs and walls");
}

TEST(BuildSignedDistanceFieldTest, MatchesDirectScanAlongLongLines) {
  // Too big for the brute force, but with a few obstacles the nearest one is found by a
  // direct scan. Lines of 3000 cells reach squared distances of ~9e6 cells², where a float
  // intersection test would lose the precision it needs.
  for (const Eigen::Vector3i& size :
       {Eigen::Vector3i(3000, 3, 2), Eigen::Vector3i(2, 3000, 3), Eigen::Vector3i(3, 2, 3000)}) {
    const GridGeometry g = MakeGeometry(size, 0.1);
    std::vector<std::uint8_t> occ(static_cast<std::size_t>(g.CellCount()), 0);
    const std::vector<Eigen::Vector3i> obstacles = {Eigen::Vector3i::Zero(),
                                                    (size - Eigen::Vector3i::Ones()) / 3,
                                                    size - Eigen::Vector3i::Ones()};
    for (const Eigen::Vector3i& o : obstacles) occ[g.Index(o)] = 1;
    const ScalarGrid field = BuildSignedDistanceField(g, occ);
    for (int iz = 0; iz < size.z(); ++iz) {
      for (int iy = 0; iy < size.y(); ++iy) {
        for (int ix = 0; ix < size.x(); ++ix) {
          const Eigen::Vector3i c(ix, iy, iz);
          std::int64_t best = std::numeric_limits<std::int64_t>::max();
          for (const Eigen::Vector3i& o : obstacles) {
            best = std::min<std::int64_t>(best, (o - c).squaredNorm());
          }
          // An obstacle's nearest free cell is a face neighbour: value r − r = 0.
          const double expected = best == 0 ? 0.0 : std::sqrt(double(best)) * g.resolution_m;
          ASSERT_NEAR(field.at(ix, iy, iz), expected, 1e-5 * std::max(1.0, expected))
              << "cell " << c.transpose();
        }
      }
    }
  }
}

TEST(BuildSignedDistanceFieldTest, EmptyAndFullGridsUseTheDiagonal) {
  const GridGeometry g = MakeGeometry({7, 5, 3}, 0.2);
  const double diagonal = g.size.cast<double>().norm() * g.resolution_m;
  const ScalarGrid empty = BuildSignedDistanceField(g, std::vector<std::uint8_t>(g.CellCount(), 0));
  for (const float v : empty.values()) EXPECT_NEAR(v, diagonal, 1e-6);
  const ScalarGrid full = BuildSignedDistanceField(g, std::vector<std::uint8_t>(g.CellCount(), 1));
  for (const float v : full.values()) EXPECT_NEAR(v, g.resolution_m - diagonal, 1e-6);
}

TEST(BuildSignedDistanceFieldTest, SignIsNegativeInsideZeroOnTheBoundaryPositiveOutside) {
  const GridGeometry g = MakeGeometry({21, 21, 21}, 0.2);
  const double r = g.resolution_m;
  std::vector<std::uint8_t> occ(static_cast<std::size_t>(g.CellCount()), 0);
  const auto in_block = [](const Eigen::Vector3i& c) {
    return (c.array() >= 6).all() && (c.array() <= 14).all();
  };
  for (int iz = 0; iz < 21; ++iz) {
    for (int iy = 0; iy < 21; ++iy) {
      for (int ix = 0; ix < 21; ++ix) occ[g.Index(ix, iy, iz)] = in_block({ix, iy, iz}) ? 1 : 0;
    }
  }
  const ScalarGrid field = BuildSignedDistanceField(g, occ);
  for (int iz = 0; iz < 21; ++iz) {
    for (int iy = 0; iy < 21; ++iy) {
      for (int ix = 0; ix < 21; ++ix) {
        const Eigen::Vector3i c(ix, iy, iz);
        const float v = field.at(ix, iy, iz);
        if (!in_block(c)) {
          EXPECT_GT(v, 0.0f);
          continue;
        }
        // Depth in cells below the block's surface; the outer layer has depth 0.
        const int depth = std::min((c.array() - 6).minCoeff(), (14 - c.array()).minCoeff());
        if (depth == 0) {
          EXPECT_NEAR(v, 0.0f, 1e-6);
        } else {
          EXPECT_NEAR(v, -depth * r, 1e-5);
        }
      }
    }
  }
  // Outside, along an axis from a face centre, the distance grows by one cell per cell.
  for (int ix = 15; ix < 21; ++ix) EXPECT_NEAR(field.at(ix, 10, 10), (ix - 14) * r, 1e-5);
}

TEST(BuildSignedDistanceFieldTest, InterpolatedGradientMatchesFiniteDifferences) {
  const GridGeometry g = MakeGeometry({17, 13, 11}, 0.2);
  for (int seed = 300; seed < 303; ++seed) {
    std::mt19937 rng(seed);
    const ScalarGrid field = BuildSignedDistanceField(g, RandomOccupancy(g, 0.03, rng));
    const auto f = [&field](const Eigen::Vector3d& p) { return field.Sample(p); };
    for (int trial = 0; trial < 500; ++trial) {
      // Stay 0.05 cells (0.01 m) from the interpolant's kinks so the ±1e-5 m probes remain
      // within one trilinear piece; values are O(1) m, so rounding error is ~1e-11.
      Eigen::Vector3d p;
      for (int a = 0; a < 3; ++a) {
        const int cell = std::uniform_int_distribution<int>(0, g.size[a] - 2)(rng);
        const double u = cell + std::uniform_real_distribution<double>(0.05, 0.95)(rng);
        p[a] = g.origin_m[a] + (u + 0.5) * g.resolution_m;
      }
      Eigen::Vector3d gradient;
      field.Sample(p, &gradient);
      const Eigen::Vector3d numerical = test_util::NumericalFieldGradient(f, p, 1e-5);
      EXPECT_LT(test_util::RelativeError(gradient, numerical), 1e-6)
          << "at " << p.transpose() << ": " << gradient.transpose() << " vs "
          << numerical.transpose();
    }
  }
}

}  // namespace
}  // namespace strata
