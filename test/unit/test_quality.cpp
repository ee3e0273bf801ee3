// Q = 3 r_in / R_circ pinned on tets whose radii are known in closed form.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>

#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"

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

TEST(Quality, AgreesWithItsRadiiOnRandomTets) {
  // tetQuality takes Q from squared lengths in one expression; it must still be 3 r_in / R of
  // tetInradius and tetCircumradius (written from the definitions) on any tet: random ones,
  // needles, slivers and caps, at mesh scales from a micrometre to a metre.
  std::srand(7);
  auto uniform = [] { return std::rand() / static_cast<double>(RAND_MAX) - 0.5; };
  int checked = 0;
  for (int i = 0; i < 20000; ++i) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(uniform(), uniform(), uniform());
    const int shape = i % 4;  // 0: as drawn; 1: flattened (sliver); 2: needle; 3: cap
    if (shape == 1) p[3] = 0.5 * (p[0] + p[1]) + 1e-3 * (p[3] - p[2]);
    if (shape == 2) p[3] = p[0] + 1e-3 * (p[3] - p[0]);
    if (shape == 3) p[3] = (p[0] + p[1] + p[2]) / 3.0 + 1e-2 * (p[3] - p[0]);
    const double scale = std::pow(10.0, -(i % 7));
    for (Vec3& x : p) x *= scale;
    const double expected = std::min(1.0, 3.0 * tissue_cut::tetInradius(p[0], p[1], p[2], p[3]) /
                                              tissue_cut::tetCircumradius(p[0], p[1], p[2], p[3]));
    const double q = tetQuality(p[0], p[1], p[2], p[3]);
    ASSERT_NEAR(q, expected, 1e-12 + 1e-9 * expected) << "tet " << i;
    ++checked;
  }
  EXPECT_EQ(checked, 20000);
}

TEST(Quality, SoundTetQualityIsTheSoundnessTestAndQualityInOnePass) {
  // The remeshers ask soundTetQuality() instead of isSoundTet() then tetQuality(): it must give
  // the very same answer, to the bit (a smoothing or flip decision compares these values), on
  // both sides of the soundness threshold and for either orientation.
  std::srand(11);
  auto uniform = [] { return std::rand() / static_cast<double>(RAND_MAX) - 0.5; };
  const double k = tissue_cut::kMinCollapseRelativeVolume;
  int sound = 0, unsound = 0, near_threshold = 0;
  for (int i = 0; i < 20000; ++i) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(uniform(), uniform(), uniform());
    // Every third tet flattened towards the plane of its first three corners, by a factor
    // spread over 1e-8 .. 1e-3: volume over longest edge cubed from well below k to above it.
    if (i % 3 == 1) {
      const Vec3 n = (p[1] - p[0]).cross(p[2] - p[0]).normalized();
      const double height = n.dot(p[3] - p[0]);
      const double factor = std::pow(10.0, -3.0 - 5.0 * (i % 97) / 96.0);
      p[3] -= (1.0 - factor) * height * n;
    }
    for (Vec3& x : p) x *= std::pow(10.0, -(i % 5));
    const bool is_sound = tissue_cut::isSoundTet(p[0], p[1], p[2], p[3]);
    const double expected = is_sound ? tetQuality(p[0], p[1], p[2], p[3]) : -1.0;
    ASSERT_EQ(tissue_cut::soundTetQuality(p[0], p[1], p[2], p[3], k), expected) << "tet " << i;
    (is_sound ? sound : unsound) += 1;
    const double vol = std::abs(tissue_cut::signedVolume(p[0], p[1], p[2], p[3]));
    double longest = 0.0;
    for (int a = 0; a < 4; ++a)
      for (int b = a + 1; b < 4; ++b) longest = std::max(longest, (p[a] - p[b]).norm());
    const double relative = vol / (longest * longest * longest);
    if (relative > 0.3 * k && relative < 3.0 * k) ++near_threshold;
  }
  // Both answers, and tets on both sides near the threshold, were met.
  EXPECT_GT(sound, 5000);
  EXPECT_GT(unsound, 5000);
  EXPECT_GT(near_threshold, 100);
  // Flattened exactly, or inverted: -1.
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
  EXPECT_EQ(tissue_cut::soundTetQuality(a, b, c, Vec3(0.3, 0.3, 0), k), -1.0);
  EXPECT_EQ(tissue_cut::soundTetQuality(a, c, b, d, k), -1.0);
  EXPECT_EQ(tissue_cut::soundTetQuality(a, b, c, d, k), tetQuality(a, b, c, d));
}

TEST(Quality, AMovingCornerGivesSoundTetQualityToTheBit) {
  // The smoothing tries a vertex at many places in its star through MovingCornerTet: each
  // answer must be soundTetQuality()'s own, to the bit (the smoothing compares them), whichever
  // corner moves, sound or not, on both sides of the threshold.
  std::srand(23);
  auto uniform = [] { return std::rand() / static_cast<double>(RAND_MAX) - 0.5; };
  const double k = tissue_cut::kMinCollapseRelativeVolume;
  int sound = 0, unsound = 0;
  std::array<int, 4> per_corner{};
  for (int i = 0; i < 4000; ++i) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(uniform(), uniform(), uniform()) * std::pow(10.0, -(i % 5));
    const int moving = i % 4;
    const tissue_cut::MovingCornerTet tet(p, moving);
    for (int trial = 0; trial < 6; ++trial) {
      Vec3 at = Vec3(uniform(), uniform(), uniform()) * std::pow(10.0, -(i % 5));
      // Every third trial near the plane of the fixed face (flattened by 1e-8 .. 1e-3).
      if (trial % 3 == 1) {
        const Vec3 &a = p[(moving + 1) % 4], &b = p[(moving + 2) % 4], &c = p[(moving + 3) % 4];
        const Vec3 n = (b - a).cross(c - a).normalized();
        const double factor = std::pow(10.0, -3.0 - 5.0 * (i % 89) / 88.0);
        at -= (1.0 - factor) * n.dot(at - a) * n;
      }
      std::array<Vec3, 4> q = p;
      q[moving] = at;
      const double expected = tissue_cut::soundTetQuality(q[0], q[1], q[2], q[3], k);
      ASSERT_EQ(tet.soundQuality(at, k), expected) << "tet " << i << " trial " << trial;
      (expected >= 0.0 ? sound : unsound) += 1;
      ++per_corner[moving];
    }
  }
  EXPECT_GT(sound, 4000);
  EXPECT_GT(unsound, 4000);
  for (int n : per_corner) EXPECT_EQ(n, 6000);
}

TEST(Quality, DegenerateOrUndefinedTetsAreZero) {
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0), d(0, 0, 1);
  const double nan = std::nan("");
  EXPECT_EQ(tetQuality(a, a, c, d), 0.0);                     // two corners on one point
  EXPECT_EQ(tetQuality(a, b, Vec3(2, 0, 0), d), 0.0);         // three on a line
  EXPECT_EQ(tetQuality(a, b, c, Vec3(nan, 0, 0)), 0.0);       // undefined
  EXPECT_EQ(tetQuality(a, b, c, Vec3(HUGE_VAL, 0, 1)), 0.0);  // at infinity
  EXPECT_GT(tetQuality(a, b, c, d), 0.0);
}
