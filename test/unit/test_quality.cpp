// Q = 3 r_in / R_circ pinned on tets whose radii are known in closed form.
#include <gtest/gtest.h>

#include <cmath>

#include "tissue_cut/mesh/quality.hpp"

using tissue_cut::tetQuality;
using tissue_cut::Vec3;

TEST(Quality, RegularTetIsOne) {
  const Vec3 a(1, 1, 1), b(1, -1, -1), c(-1, 1, -1), d(-1, -1, 1);
  EXPECT_NEAR(tetQuality(a, b, c, d), 1.0, 1e-14);
}

TEST(Quality, CubeCornerTetIsSqrt3Minus1) {
  // r_in = 1/(3+sqrt3), R = sqrt3/2  =>  Q = sqrt3 - 1.
  EXPECT_NEAR(tetQuality(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)),
              std::sqrt(3.0) - 1.0, 1e-14);
}

TEST(Quality, SliverMatchesClosedForm) {
  // Four points at height +-h over a square's diagonals: R = sqrt(1+h^2), r = h / sqrt(1+4h^2).
  for (double h : {0.3, 0.1, 0.01}) {
    const double expected = 3.0 * h / (std::sqrt(1 + 4 * h * h) * std::sqrt(1 + h * h));
    EXPECT_NEAR(tetQuality(Vec3(1, 0, h), Vec3(-1, 0, h), Vec3(0, 1, -h), Vec3(0, -1, -h)),
                expected, 1e-14)
        << "h = " << h;
  }
}

TEST(Quality, FlatTetIsZero) {
  EXPECT_EQ(tetQuality(Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(1, 1, 0)), 0.0);
}

TEST(Quality, DoesNotDependOnOrientationOrScale) {
  const Vec3 a(0.1, 0.2, 0.3), b(1.1, 0.2, 0.4), c(0.3, 1.0, 0.2), d(0.4, 0.5, 1.2);
  const double q = tetQuality(a, b, c, d);
  EXPECT_NEAR(tetQuality(a, b, d, c), q, 1e-14);
  EXPECT_NEAR(tetQuality(a * 1e-3, b * 1e-3, c * 1e-3, d * 1e-3), q, 1e-12);
}
