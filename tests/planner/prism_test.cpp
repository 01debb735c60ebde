#include "strata/prism.hpp"

#include <random>

#include <gtest/gtest.h>

namespace strata {
namespace {

// An L: the unit square [0, 2]^2 without its [1, 2] x [1, 2] quarter; concave at (1, 1).
Prism LShape() { return Prism{{{0, 0}, {2, 0}, {2, 1}, {1, 1}, {1, 2}, {0, 2}}, -1.0, 3.0}; }

TEST(PrismTest, ContainsTheInsideAndBoundaryNotTheNotch) {
  const Prism l = LShape();
  EXPECT_TRUE(l.Contains({0.5, 0.5, 0}));
  EXPECT_TRUE(l.Contains({1.5, 0.5, 2.9}));
  EXPECT_TRUE(l.Contains({0.5, 1.5, -1}));
  EXPECT_TRUE(l.Contains({2.0, 0.5, 0}));     // On an edge.
  EXPECT_TRUE(l.Contains({1.0, 1.0, 0}));     // On the concave corner.
  EXPECT_FALSE(l.Contains({1.5, 1.5, 0}));    // The notch.
  EXPECT_FALSE(l.Contains({0.5, 0.5, 3.1}));  // Above.
  EXPECT_FALSE(l.Contains({-0.1, 0.5, 0}));
}

TEST(PrismTest, SignedDistanceAgainstHandComputedValues) {
  const Prism l = LShape();
  EXPECT_NEAR(l.SignedDistanceXY({0.5, 0.5}), -0.5, 1e-12);
  EXPECT_NEAR(l.SignedDistanceXY({1.5, 1.5}), 0.5, 1e-12);  // In the notch.
  EXPECT_NEAR(l.SignedDistanceXY({3, 0.5}), 1.0, 1e-12);
  EXPECT_NEAR(l.SignedDistanceXY({3, 4}), std::hypot(2.0, 2.0), 1e-12);  // Past (1, 2).
}

TEST(PrismTest, GradientMatchesCentralDifferences) {
  const Prism l = LShape();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> coord(-1.0, 3.0);
  constexpr double kStep = 1e-6;
  int checked = 0;
  for (int i = 0; i < 500; ++i) {
    const Eigen::Vector2d p(coord(rng), coord(rng));
    Eigen::Vector2d gradient;
    const double d = l.SignedDistanceXY(p, &gradient);
    if (std::abs(d) < 1e-3) continue;  // The boundary, where d is not differentiable.
    for (int axis = 0; axis < 2; ++axis) {
      Eigen::Vector2d step = Eigen::Vector2d::Zero();
      step(axis) = kStep;
      const double numeric =
          (l.SignedDistanceXY(p + step) - l.SignedDistanceXY(p - step)) / (2 * kStep);
      // Ridges (equidistant from two edges) are measure zero; a sample on one shows as a
      // mismatch, so allow none beyond rounding.
      EXPECT_NEAR(gradient(axis), numeric, 1e-5) << "at " << p.transpose();
    }
    ++checked;
  }
  EXPECT_GT(checked, 400);
}

TEST(PrismTest, ValidateBlamesTheBadField) {
  EXPECT_TRUE(LShape().Validate("keep_out[0]"));

  Prism nan_corner = LShape();
  nan_corner.polygon_m[3].y() = std::nan("");
  const Status nan_status = nan_corner.Validate("keep_out[0]");
  ASSERT_FALSE(nan_status);
  EXPECT_EQ(nan_status.error().field, "keep_out[0].polygon_m[3].y");

  Prism bow_tie{{{0, 0}, {2, 2}, {2, 0}, {0, 1}}, 0, 1};
  const Status crossing = bow_tie.Validate("zone");
  ASSERT_FALSE(crossing);
  EXPECT_NE(crossing.error().message.find("crosses"), std::string::npos);

  Prism line{{{0, 0}, {1, 1}, {2, 2}}, 0, 1};
  EXPECT_FALSE(line.Validate("zone"));

  Prism upside_down = LShape();
  upside_down.z_max_m = -2;
  const Status inverted = upside_down.Validate("zone");
  ASSERT_FALSE(inverted);
  EXPECT_EQ(inverted.error().field, "zone.z_max_m");

  Prism too_few{{{0, 0}, {1, 0}}, 0, 1};
  EXPECT_EQ(too_few.Validate("zone").error().field, "zone.polygon_m");
}

TEST(PrismTest, BoxPrismCoversItsBox) {
  const Eigen::AlignedBox3d box(Eigen::Vector3d(-1, 2, 0), Eigen::Vector3d(3, 5, 1));
  const Prism prism = BoxPrism(box);
  ASSERT_TRUE(prism.Validate("box"));
  EXPECT_TRUE(prism.Bounds().isApprox(box));
  EXPECT_TRUE(prism.Contains({0, 3, 0.5}));
  EXPECT_FALSE(prism.Contains({0, 6, 0.5}));
}

}  // namespace
}  // namespace strata
