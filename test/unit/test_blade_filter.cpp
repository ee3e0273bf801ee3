// BladeFilter: the blade's path smoothed before cutting (cut/filter_min_cutoff, cut/filter_beta).
// What it must do: nothing while off; a still blade's jitter mostly gone; a moving blade trailing
// the tool by no more than its bound and catching up once the tool stops; jumps and lifts passed
// whole; the blade's length kept. And what it is for: strokes over the block with a tool that
// trembles or a tracker that wavers come out clean where the unfiltered strokes do not.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "tissue_cut/cut/blade_filter.hpp"
#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/topology.hpp"
#include "tissue_cut/tissue.hpp"

using namespace tissue_cut;

namespace {

constexpr double kDt = 0.001;  // 1 kHz

BladeFilterParams on(double min_cutoff = 1.0, double beta = 20.0) {
  BladeFilterParams p;
  p.min_cutoff = min_cutoff;
  p.beta = beta;
  return p;
}

BladeSegment blade(const Vec3& base, const Vec3& tip) { return BladeSegment{base, tip}; }

// The blade of a tool tilted 0.3 rad over the block, 5 cm up with a 4 cm blade, at fraction s of
// a stroke from x = -65 mm to +65 mm along y = 4 mm (out in 0.5 s), its origin off by `offset`
// and its blade turned by `turn` rad about z.
BladeSegment strokeAt(double s, const Vec3& offset, double turn) {
  static const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.3, Vec3(1, 0.3, 0).normalized()));
  const Vec3 origin = Vec3(-0.065 + 0.13 * s, 0.004, 0.05) + offset;
  return bladeFromPose(origin, tilt * Eigen::Quaterniond(Eigen::AngleAxisd(turn, Vec3::UnitZ())),
                       0.04);
}

// A stroke (and back along it) with noise of `sigma` [m] in x and y and sigma / 0.01 rad of turn:
// drawn afresh every `every` ticks and interpolated linearly between (1: a tool trembling every
// tick; 16: a 62.5 Hz tracker's noise on a 1 kHz loop).
std::vector<BladeSegment> noisyStroke(unsigned seed, double sigma, int every, bool back) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, sigma);
  const int ticks = back ? 1000 : 500;
  std::vector<Vec3> offsets;
  std::vector<double> turns;
  for (int k = 0; k <= ticks / every + 1; ++k) {
    offsets.emplace_back(noise(rng), noise(rng), 0.0);
    turns.push_back(0.01 * noise(rng) / 0.0001);
  }
  std::vector<BladeSegment> out;
  for (int k = 0; k <= ticks; ++k) {
    const int i = k / every;
    const double f = static_cast<double>(k % every) / every;
    out.push_back(strokeAt(1.0 - std::abs(k / 500.0 - 1.0),
                           (1 - f) * offsets[i] + f * offsets[i + 1],
                           (1 - f) * turns[i] + f * turns[i + 1]));
  }
  return out;
}

struct Outcome {
  int pieces = 0, chi = 0;
  bool clean() const { return pieces == 1 && chi == 2; }  // one piece, the boundary of a slit
};

// Cuts the block along `blades` through Tissue (no physics, no collapse), the filter as given,
// then lifts the blade.
Outcome cut(const std::vector<BladeSegment>& blades, double min_cutoff) {
  Config c;
  c.physics.enabled = false;
  c.collapse.enabled = false;
  c.cut.blade_length = 0.04;
  c.cut.filter_min_cutoff = min_cutoff;
  Tissue tissue(c, makeBlock());
  for (const BladeSegment& b : blades) tissue.step(b, kDt);
  tissue.step(std::nullopt, kDt);
  EXPECT_EQ(tissue.validate(), "");
  return {countPieces(tissue.mesh()), boundaryEulerCharacteristic(tissue.mesh())};
}

// Strokes of seeds first..last (noisyStroke()'s arguments otherwise): each must come out clean
// filtered at 1 Hz / 20 per m. Returns how many came out clean unfiltered.
int cleanUnfiltered(unsigned first, unsigned last, double sigma, int every, bool back) {
  int clean_raw = 0;
  for (unsigned seed = first; seed <= last; ++seed) {
    const std::vector<BladeSegment> blades = noisyStroke(seed, sigma, every, back);
    const Outcome raw = cut(blades, 0.0), filtered = cut(blades, 1.0);
    clean_raw += raw.clean();
    EXPECT_TRUE(filtered.clean()) << "seed " << seed << ": " << filtered.pieces << " pieces, chi "
                                  << filtered.chi;
  }
  return clean_raw;
}

}  // namespace

TEST(BladeFilter, OffPassesEveryBladeUnchanged) {
  BladeFilter filter;  // min_cutoff 0
  ASSERT_FALSE(filter.enabled());
  const std::vector<BladeSegment> blades = noisyStroke(3, 0.0003, 1, false);
  for (const BladeSegment& b : blades) {
    const auto out = filter(b, kDt);
    ASSERT_TRUE(out);
    EXPECT_EQ(out->base, b.base);
    EXPECT_EQ(out->tip, b.tip);
  }
  EXPECT_FALSE(filter(std::nullopt, kDt));
}

TEST(BladeFilter, AStillBladeLosesMostOfItsTremble) {
  BladeFilter filter(on());
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.0001);
  const Vec3 base(0, 0, 0.05), tip(0, 0, 0.01);
  double raw2 = 0.0, out2 = 0.0;
  int n = 0;
  for (int k = 0; k < 3000; ++k) {
    const Vec3 e(noise(rng), noise(rng), 0.0);
    const auto out = filter(blade(base + e, tip + e), kDt);
    ASSERT_TRUE(out);
    if (k < 1000) continue;  // settled
    raw2 += e.squaredNorm();
    out2 += (out->base - base).squaredNorm();
    ++n;
  }
  const double raw = std::sqrt(raw2 / n), filtered = std::sqrt(out2 / n);
  std::printf("a still blade's tremble: %.1f um raw, %.1f um filtered\n", 1e6 * raw,
              1e6 * filtered);
  EXPECT_LT(filtered, raw / 5.0);
}

TEST(BladeFilter, AMovingBladeTrailsWithinItsBoundAndCatchesUpWhenTheToolStops) {
  for (const double speed : {0.01, 0.05, 0.26}) {  // m/s
    BladeFilter filter(on());
    const Vec3 dir(1, 0, 0), down(0, 0, -0.04);
    Vec3 at(0, 0, 0.05);
    double lag = 0.0;
    for (int k = 0; k < 1000; ++k) {  // 1 s at the speed
      at += speed * kDt * dir;
      lag = (filter(blade(at, at + down), kDt)->base - at).norm();
    }
    // Steady: the speed the filter sees includes its own lag over a tick, so the lag settles
    // just under sqrt(v dt / (2 pi beta)): 0.25, 0.58 and 1.29 mm here.
    const double bound = std::sqrt(speed * kDt / (2 * M_PI * 20.0));
    SCOPED_TRACE("speed " + std::to_string(speed) + " m/s, lag " + std::to_string(lag) + " m");
    EXPECT_LT(lag, bound);
    EXPECT_GT(lag, 0.8 * bound);
    double left = 0.0;
    for (int k = 0; k < 1000; ++k) left = (filter(blade(at, at + down), kDt)->base - at).norm();
    EXPECT_LT(left, 1e-6);  // within a micrometre a second after the tool stopped
  }
}

TEST(BladeFilter, KeepsTheBladesLengthWhileItTurns) {
  BladeFilter filter(on());
  for (int k = 0; k < 500; ++k) {
    const BladeSegment b = strokeAt(k / 500.0, Vec3::Zero(), 0.5 * std::sin(k * 0.05));
    const auto out = filter(b, kDt);
    ASSERT_TRUE(out);
    EXPECT_NEAR((out->tip - out->base).norm(), 0.04, 1e-12);
  }
}

TEST(BladeFilter, AJumpOrALiftPassesWhole) {
  BladeFilter filter(on());
  const Vec3 down(0, 0, -0.03);
  Vec3 at(0, 0, 0.05);
  for (int k = 0; k < 100; ++k) {
    at.x() += 1e-4;
    filter(blade(at, at + down), kDt);
  }
  // More than max_jump (20 mm) from the filtered blade: the tool's blade, exactly, so that the
  // cutter sees the jump and lifts the blade over the gap.
  const Vec3 far = at + Vec3(0.025, 0, 0);
  auto out = filter(blade(far, far + down), kDt);
  ASSERT_TRUE(out);
  EXPECT_EQ(out->base, far);
  EXPECT_EQ(out->tip, far + down);
  // Less than that: smoothed.
  const Vec3 near = far + Vec3(0.01, 0, 0);
  out = filter(blade(near, near + down), kDt);
  EXPECT_GT((out->base - near).norm(), 0.009);
  // A lift passes and restarts the filter: the next blade comes through unchanged.
  EXPECT_FALSE(filter(std::nullopt, kDt));
  out = filter(blade(at, at + down), kDt);
  EXPECT_EQ(out->base, at);
  // Turned off and on again: restarted too.
  filter.setParams(BladeFilterParams{});
  filter.setParams(on());
  out = filter(blade(far, far + down), kDt);
  EXPECT_EQ(out->base, far);
}

// A tool trembling 0.1 mm a tick (white noise at 1 kHz), out along the block and back along its
// own cut: unfiltered, most of these strokes cut chips or leave handles (README, Reliability);
// filtered at 1 Hz / 20 per m, every one leaves one piece with the boundary of a slit.
TEST(BladeFilter, StrokesOfATremblingToolComeOutClean) {
  const int clean_raw = cleanUnfiltered(11, 20, 0.0001, 1, true);
  std::printf("clean strokes of ten, unfiltered: %d\n", clean_raw);
  EXPECT_LE(clean_raw, 5);  // the filter is what makes them clean
}

// A 62.5 Hz tracker's noise of 0.15 mm (drawn every 16 ticks, interpolated), strokes out along
// the block: unfiltered some leave handles or chips; filtered, none.
TEST(BladeFilter, StrokesOfAWaveringTrackerComeOutClean) {
  const int clean_raw = cleanUnfiltered(11, 30, 0.00015, 16, false);
  std::printf("clean strokes of twenty, unfiltered: %d\n", clean_raw);
  EXPECT_LE(clean_raw, 18);
}

// The filter's keys go through Config and Tissue::reconfigure: turned on live, the next blades
// are smoothed; bad values are refused by name and change nothing.
TEST(BladeFilter, IsSetByConfigurationAndRefusesBadValues) {
  Config c;
  c.physics.enabled = false;
  c.collapse.enabled = false;
  Tissue tissue(c, makeBlock());
  EXPECT_EQ(bladeFilterParams(c).min_cutoff, 0.0);
  Config bad = c;
  bad.cut.filter_min_cutoff = -1.0;
  EXPECT_NE(tissue.reconfigure(bad).find("cut/filter_min_cutoff"), std::string::npos);
  bad.cut.filter_min_cutoff = 600.0;  // above rate / 2
  EXPECT_NE(tissue.reconfigure(bad).find("cut/filter_min_cutoff"), std::string::npos);
  bad = c;
  bad.cut.filter_beta = std::nan("");
  EXPECT_NE(tissue.reconfigure(bad).find("cut/filter_beta"), std::string::npos);
  EXPECT_EQ(tissue.config().cut.filter_min_cutoff, 0.0);
  Config good = c;
  good.cut.filter_min_cutoff = 2.0;
  good.cut.filter_beta = 10.0;
  EXPECT_EQ(tissue.reconfigure(good), "");
  const BladeFilterParams p = bladeFilterParams(tissue.config());
  EXPECT_EQ(p.min_cutoff, 2.0);
  EXPECT_EQ(p.beta, 10.0);
  EXPECT_EQ(p.max_jump, good.cut.max_jump);
  // Reconfigured on, the tissue cuts a trembling stroke as one built with the filter on does, and
  // not as it would unfiltered.
  const std::vector<BladeSegment> blades = noisyStroke(12, 0.0001, 1, false);
  Tissue built(good, makeBlock()), raw(c, makeBlock());
  for (const BladeSegment& b : blades) {
    tissue.step(b, kDt);
    built.step(b, kDt);
    raw.step(b, kDt);
  }
  EXPECT_EQ(tissue.mesh().numTets(), built.mesh().numTets());
  EXPECT_EQ(tissue.mesh().numVertices(), built.mesh().numVertices());
  EXPECT_NE(tissue.mesh().numTets(), raw.mesh().numTets());
}
