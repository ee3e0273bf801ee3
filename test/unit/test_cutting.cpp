// Cutting by tetrahedra replacement, replayed on the built-in block: the cut goes where the blade
// went, opens behind it, conserves volume, and leaves a valid mesh of the expected topology.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <limits>
#include <map>
#include <numeric>
#include <random>

#include "../property/random_incision.hpp"
#include "tissue_cut/cut/cutter.hpp"
#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/cut/sweep.hpp"
#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/topology.hpp"
#include "tissue_cut/remesh/collapse_queue.hpp"
#include "tissue_cut/tissue.hpp"

using namespace tissue_cut;

namespace {

Config cutOnly(double blade_length) {
  Config c;
  c.physics.enabled = false;
  c.collapse.enabled = false;
  c.cut.blade_length = blade_length;
  return c;
}

// A straight move of the tool origin from `a` to `b` over `seconds`, blade pointing down.
ScalpelPath line(const Vec3& a, const Vec3& b, double seconds,
                 const Eigen::Quaterniond& q = Eigen::Quaterniond::Identity()) {
  std::vector<ToolPose> poses;
  for (int i = 0; i <= 20; ++i) {
    ToolPose p;
    p.t = seconds * i / 20.0;
    p.position = a + (b - a) * (i / 20.0);
    p.orientation = q;
    poses.push_back(p);
  }
  return ScalpelPath(poses);
}

// Replays the path at `rate` through Tissue::step, then takes the blade away. Returns the first
// validation error ("" when every tick was valid).
std::string replay(Tissue& tissue, const ScalpelPath& path, double rate, bool lift_at_end = true) {
  const double dt = 1.0 / rate;
  const int ticks = static_cast<int>(std::ceil((path.endTime() - path.startTime()) / dt));
  for (int k = 0; k <= ticks; ++k) {
    const ToolPose pose = path.at(path.startTime() + std::min(k * dt, path.endTime()));
    tissue.step(bladeFromPose(pose.position, pose.orientation, tissue.config().cut.blade_length),
                dt);
    const std::string err = tissue.validate();
    if (!err.empty()) return "tick " + std::to_string(k) + ": " + err;
  }
  if (lift_at_end) {
    tissue.step(std::nullopt, dt);
    const std::string err = tissue.validate();
    if (!err.empty()) return "after lifting: " + err;
  }
  return "";
}

// Rest volume of each piece, largest first.
std::vector<double> pieceVolumes(const TetMesh& mesh) {
  std::vector<int> parent(mesh.tetSlots());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t))
      for (int f = 0; f < 4; ++f)
        if (mesh.neighbor(t, f) >= 0) parent[find(t)] = find(mesh.neighbor(t, f));
  std::map<int, double> volume;
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t)) volume[find(t)] += mesh.restVolume(t);
  std::vector<double> out;
  for (const auto& kv : volume) out.push_back(kv.second);
  std::sort(out.rbegin(), out.rend());
  return out;
}

const double kBlockVolume = 0.1 * 0.06 * 0.03;

/// A scalpel tilted 0.3 rad over the block, 5 cm up with a 4 cm blade, trembling: each pose is off
/// by Gaussian noise of `sigma` m in x and y and sigma / 0.01 rad of twist about z.
class TremblingScalpel {
 public:
  TremblingScalpel(unsigned seed, double sigma) : rng_(seed), tremble_(0.0, sigma) {}
  /// The blade at fraction s of the stroke from x = -65 mm to +65 mm along y = 4 mm.
  BladeSegment at(double s) {
    const Vec3 origin(-0.065 + 0.13 * s + tremble_(rng_), 0.004 + tremble_(rng_), 0.05);
    const double turn = 0.01 * tremble_(rng_) / 0.0001;
    const Eigen::Quaterniond twist(Eigen::AngleAxisd(turn, Vec3::UnitZ()));
    return bladeFromPose(origin, tilt_ * twist, 0.04);
  }

 private:
  std::mt19937 rng_;
  std::normal_distribution<double> tremble_;
  const Eigen::Quaterniond tilt_{Eigen::AngleAxisd(0.3, Vec3(1, 0.3, 0).normalized())};
};

}  // namespace

TEST(Cutting, SeveringCutMakesTwoPiecesWhoseVolumesAddUp) {
  Tissue tissue(cutOnly(0.06), makeBlock());
  const double area_before = boundaryRestArea(tissue.mesh());
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 1.0), 1000), "");
  EXPECT_FALSE(tissue.cutter().hasPending());
  const auto pieces = pieceVolumes(tissue.mesh());
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_NEAR(pieces[0] + pieces[1], kBlockVolume, 1e-12 * kBlockVolume);
  // The blade ran at y = 0.0013: the pieces are 0.1 x 0.03 x (0.03 -+ 0.0013).
  EXPECT_NEAR(pieces[0], 0.1 * 0.03 * 0.0313, 0.02 * pieces[0]);
  EXPECT_NEAR(pieces[1], 0.1 * 0.03 * 0.0287, 0.02 * pieces[1]);
  // Both walls of the cut are new boundary: twice the swept area inside the block.
  const double added = boundaryRestArea(tissue.mesh()) - area_before;
  EXPECT_NEAR(added, 2 * 0.1 * 0.03, 0.02 * 2 * 0.1 * 0.03);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 4);  // two sphere-like pieces
  const Statistics s = tissue.statistics();
  EXPECT_GT(s.cut.cut_tetrahedra, 0);
  const double per_cut = double(s.cut.created_tetrahedra) / s.cut.cut_tetrahedra;
  EXPECT_GE(per_cut, 3.0);
  EXPECT_LE(per_cut, 9.0);
  EXPECT_EQ(s.region.tetrahedra, s.cut.created_tetrahedra);  // the flag on exactly those tets
}

TEST(Cutting, CutStoppingInsideLeavesOnePieceWithAClosedBoundary) {
  Tissue tissue(cutOnly(0.03), makeBlock());
  const double area_before = boundaryRestArea(tissue.mesh());
  // The tip runs at z = 0.012 (1.8 cm deep, at the depth of a grid plane of the block) and
  // stops at x = 0.01, inside the block, then is lifted out.
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0021, 0.042}, {0.01, 0.0021, 0.042}, 0.8), 1000), "");
  EXPECT_FALSE(tissue.cutter().hasPending());
  EXPECT_EQ(countPieces(tissue.mesh()), 1);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 2);
  EXPECT_NEAR(tissue.mesh().restVolume(), kBlockVolume, 1e-12 * kBlockVolume);
  // Crack walls: 6 cm long (x from -0.05 to 0.01), 1.8 cm deep, both sides.
  const double added = boundaryRestArea(tissue.mesh()) - area_before;
  EXPECT_NEAR(added, 2 * 0.06 * 0.018, 0.05 * 2 * 0.06 * 0.018);
}

TEST(Cutting, TetsOpenBehindTheBladeWhileItIsStillInside) {
  Tissue tissue(cutOnly(0.03), makeBlock());
  // Stop with the blade still in the block: everything behind it is cut and opened already.
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0021, 0.042}, {0.02, 0.0021, 0.042}, 0.9), 1000,
                   /*lift_at_end=*/false),
            "");
  EXPECT_TRUE(tissue.cutter().hasPending());
  EXPECT_LT(tissue.cutter().numPending(), 40);  // only the tets around the blade
  EXPECT_GT(tissue.cutter().counts().separated_vertices, 50);
  EXPECT_GT(tissue.statistics().cut.cut_tetrahedra, 100);
  tissue.step(std::nullopt, 1e-3);
  EXPECT_EQ(tissue.validate(), "");
  EXPECT_FALSE(tissue.cutter().hasPending());
}

TEST(Cutting, BladeInAGridPlaneSeparatesAlongFacesWithoutSplitting) {
  Tissue tissue(cutOnly(0.06), makeBlock());
  // y = 0 is a plane of grid vertices, edges and faces of the block.
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0, 0.045}, {0.07, 0.0, 0.045}, 1.0), 1000), "");
  const auto pieces = pieceVolumes(tissue.mesh());
  ASSERT_EQ(pieces.size(), 2u);
  EXPECT_NEAR(pieces[0], kBlockVolume / 2, 1e-12 * kBlockVolume);
  EXPECT_NEAR(pieces[1], kBlockVolume / 2, 1e-12 * kBlockVolume);
  EXPECT_EQ(tissue.statistics().cut.cut_tetrahedra, 0);
  EXPECT_EQ(tissue.mesh().numTets(), 5100);
}

TEST(Cutting, BladeThroughAGridLineAtAnAngleStaysValid) {
  Tissue tissue(cutOnly(0.06), makeBlock());
  // A diagonal plane through grid vertices: x = y * (0.1/17) / 0.006 passes vertex columns.
  const double dx = 0.1 / 17;
  ASSERT_EQ(
      replay(tissue, line({-4 * dx, -0.04, 0.045}, {4 * dx * 0.07 / 0.04 * 1.0, 0.07, 0.045}, 1.0),
             1000),
      "");
  EXPECT_EQ(countPieces(tissue.mesh()), 2);
  EXPECT_NEAR(tissue.mesh().restVolume(), kBlockVolume, 1e-12 * kBlockVolume);
}

TEST(Cutting, ZigZagBackAndForthStaysValid) {
  Tissue tissue(cutOnly(0.025), makeBlock());
  std::vector<ToolPose> poses;
  for (int i = 0; i <= 60; ++i) {
    ToolPose p;
    p.t = i * 0.05;
    const double x = -0.06 + 0.1 * std::abs(std::fmod(i / 30.0, 2.0) - 1.0) * 1.1;
    p.position = Vec3(x, 0.012 * std::sin(i * 0.9), 0.045);
    poses.push_back(p);
  }
  ASSERT_EQ(replay(tissue, ScalpelPath(poses), 1000), "");
  EXPECT_FALSE(tissue.cutter().hasPending());
  EXPECT_NEAR(tissue.mesh().restVolume(), kBlockVolume, 1e-12 * kBlockVolume);
  EXPECT_GT(tissue.statistics().cut.cut_tetrahedra, 100);
}

TEST(Cutting, TiltedTremblingBladeStaysValid) {
  Tissue tissue(cutOnly(0.04), makeBlock());
  std::mt19937 rng(42);
  std::normal_distribution<double> tremble(0.0, 0.0004);
  const Eigen::Quaterniond tilt(Eigen::AngleAxisd(0.35, Vec3(1, 0.3, 0).normalized()));
  std::vector<ToolPose> poses;
  for (int i = 0; i <= 200; ++i) {
    ToolPose p;
    p.t = i * 0.01;
    p.position =
        Vec3(-0.07 + 0.14 * i / 200.0 + tremble(rng), 0.004 + tremble(rng), 0.05 + tremble(rng));
    p.orientation =
        tilt * Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * tremble(rng) / 0.0004, Vec3::UnitZ()));
    poses.push_back(p);
  }
  ASSERT_EQ(replay(tissue, ScalpelPath(poses), 1000), "");
  EXPECT_NEAR(tissue.mesh().restVolume(), kBlockVolume, 1e-12 * kBlockVolume);
}

TEST(Cutting, PlungeMoveAndWithdrawInsideTheBlock) {
  Tissue tissue(cutOnly(0.02), makeBlock());
  std::vector<ToolPose> poses;
  auto at = [&](double t, double x, double z) {
    ToolPose p;
    p.t = t;
    p.position = Vec3(x, 0.0031, z);
    poses.push_back(p);
  };
  at(0.0, -0.02, 0.05);  // above the block
  at(0.3, -0.02, 0.04);  // tip 1 cm deep
  at(1.0, 0.025, 0.04);  // along x inside
  at(1.3, 0.025, 0.05);  // withdrawn
  ASSERT_EQ(replay(tissue, ScalpelPath(poses), 1000), "");
  EXPECT_EQ(countPieces(tissue.mesh()), 1);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 2);
  EXPECT_GT(tissue.statistics().cut.cut_tetrahedra, 20);
}

TEST(Cutting, AJumpLiftsTheBladeWithoutCuttingAcrossTheGap) {
  Tissue tissue(cutOnly(0.06), makeBlock());
  std::vector<ToolPose> poses;
  ToolPose a, b;
  a.t = 0.0;
  a.position = Vec3(-0.07, 0.0013, 0.045);
  b.t = 0.001;  // 14 cm in one tick
  b.position = Vec3(0.07, 0.0013, 0.045);
  poses = {a, b};
  const std::string warning = tissue.step(bladeFromPose(a.position, a.orientation, 0.06), 1e-3) +
                              tissue.step(bladeFromPose(b.position, b.orientation, 0.06), 1e-3);
  EXPECT_NE(warning.find("jumped"), std::string::npos);
  tissue.step(std::nullopt, 1e-3);
  EXPECT_EQ(tissue.validate(), "");
  EXPECT_EQ(tissue.statistics().cut.cut_tetrahedra, 0);
  EXPECT_EQ(countPieces(tissue.mesh()), 1);
}

TEST(Cutting, DeformedBodyIsCutWhereTheBladeIsAndRestShapeStaysExact) {
  MeshData block = makeBlock();
  Tissue tissue(cutOnly(0.06), block);
  // Shear the current shape (as if the tissue were pushed sideways): y += 0.3 z.
  auto& current = const_cast<TetMesh&>(tissue.mesh()).currentPositions();
  for (Vec3& p : current) p.y() += 0.3 * p.z();
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0043, 0.045}, {0.07, 0.0043, 0.045}, 1.0), 1000), "");
  const TetMesh& mesh = tissue.mesh();
  // Every new vertex lies on the blade's plane in current positions (up to snapping), and its
  // rest position is where the same material was: rest = current with the shear undone.
  int checked = 0;
  for (int v = static_cast<int>(block.V.rows()); v < mesh.vertexSlots(); ++v) {
    if (!mesh.vertexAlive(v)) continue;
    const Vec3 r = mesh.rest(v), c = mesh.current(v);
    EXPECT_NEAR(c.y(), r.y() + 0.3 * r.z(), 1e-12);
    EXPECT_NEAR(c.x(), r.x(), 1e-12);
    EXPECT_NEAR(c.y(), 0.0043, 1e-3) << "a cut point away from the blade's plane";
    ++checked;
  }
  EXPECT_GT(checked, 100);
  EXPECT_EQ(countPieces(mesh), 2);
  EXPECT_NEAR(mesh.restVolume(), kBlockVolume, 1e-12 * kBlockVolume);
}

// The project's own meshes, from Gmsh and TetGen.
namespace {

MeshData projectMesh(const std::string& name) {
  return readMesh(std::string(TISSUE_CUT_SOURCE_DIR) + "/meshes/" + name);
}

}  // namespace

TEST(CuttingMeshes, EllipsoidIsSeveredInTwo) {
  const MeshData mesh = projectMesh("ellipsoid_v22.msh");
  Tissue tissue(cutOnly(0.25), mesh);
  const double volume = tissue.mesh().restVolume();
  ASSERT_EQ(replay(tissue, line({0.013, -0.13, 0.12}, {0.013, 0.13, 0.12}, 0.6), 1000), "");
  EXPECT_EQ(countPieces(tissue.mesh()), 2);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 4);
  EXPECT_NEAR(tissue.mesh().restVolume(), volume, 1e-12 * volume);
}

TEST(CuttingMeshes, CutBesideAThroughHoleLeavesTheHoleOpen) {
  // The block (0.2 x 0.1 x 0.1 m) has a hole of radius 0.025 m along y at x = 0.1, z = 0.05.
  Tissue tissue(cutOnly(0.04), projectMesh("holed_block_v41.msh"));
  ASSERT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 0);
  // The tip runs at z = 0.082, 7 mm above the hole, the whole length of the block.
  ASSERT_EQ(replay(tissue, line({-0.02, 0.043, 0.122}, {0.22, 0.043, 0.122}, 0.8), 1000), "");
  EXPECT_EQ(countPieces(tissue.mesh()), 1);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 0);  // still genus 1: the hole is open
  EXPECT_GT(tissue.statistics().cut.cut_tetrahedra, 50);
}

TEST(CuttingMeshes, CutThroughTheHoleSplitsTheHoledBlockInTwo) {
  Tissue tissue(cutOnly(0.2), projectMesh("holed_block_v41.msh"));
  ASSERT_EQ(replay(tissue, line({0.1013, -0.03, 0.15}, {0.1013, 0.13, 0.15}, 0.6), 1000), "");
  EXPECT_EQ(countPieces(tissue.mesh()), 2);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 4);  // two pieces, each with a groove
}

TEST(CuttingMeshes, CurvedCutStoppingInsideATetGenSphere) {
  Tissue tissue(cutOnly(0.06), projectMesh("sphere_tetgen.node"));
  const double volume = tissue.mesh().restVolume();
  std::vector<ToolPose> poses;
  for (int i = 0; i <= 40; ++i) {
    const double s = i / 40.0;
    ToolPose p;
    p.t = 0.8 * s;
    // A quadratic Bezier from outside the sphere to a stop inside it, 6 cm deep at most.
    const Vec3 a(-0.14, -0.02, 0.13), b(-0.02, 0.04, 0.13), c(0.03, 0.0, 0.13);
    p.position = (1 - s) * (1 - s) * a + 2 * s * (1 - s) * b + s * s * c;
    poses.push_back(p);
  }
  ASSERT_EQ(replay(tissue, ScalpelPath(poses), 1000), "");
  EXPECT_EQ(countPieces(tissue.mesh()), 1);
  EXPECT_EQ(boundaryEulerCharacteristic(tissue.mesh()), 2);
  EXPECT_NEAR(tissue.mesh().restVolume(), volume, 1e-12 * volume);
  const Statistics s = tissue.statistics();
  EXPECT_GT(s.cut.cut_tetrahedra, 30);
  EXPECT_EQ(s.region.tetrahedra, s.cut.created_tetrahedra);
}

TEST(Cutting, ANonFiniteBladeIsIgnoredAndTheCutGoesOn) {
  Tissue tissue(cutOnly(0.06), makeBlock());
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int k = 0; k <= 300; ++k) {
    BladeSegment blade = bladeFromPose(Vec3(-0.07 + 0.14 * k / 300.0, 0.0013, 0.045),
                                       Eigen::Quaterniond::Identity(), 0.06);
    if (k == 150) blade.tip.x() = nan;
    const std::string warning = tissue.step(blade, 1e-3);
    if (k == 150) {
      EXPECT_NE(warning.find("not finite"), std::string::npos);
    }
    ASSERT_EQ(tissue.validate(), "") << "tick " << k;
  }
  tissue.step(std::nullopt, 1e-3);
  EXPECT_EQ(countPieces(tissue.mesh()), 2);
  for (int v = 0; v < tissue.mesh().vertexSlots(); ++v) {
    if (tissue.mesh().vertexAlive(v)) {
      ASSERT_TRUE(tissue.mesh().current(v).allFinite());
    }
  }
}

TEST(Cutting, AnEmptyOrNonFiniteMeshIsRefused) {
  MeshData empty;
  empty.V.resize(0, 3);
  empty.T.resize(0, 4);
  EXPECT_THROW(Tissue(cutOnly(0.03), empty), std::invalid_argument);
  MeshData bad = makeBlock();
  bad.V(3, 1) = std::numeric_limits<double>::infinity();
  EXPECT_THROW(Tissue(cutOnly(0.03), bad), std::invalid_argument);
}

namespace {

double pointTetDistance(const Vec3& x, const std::array<Vec3, 4>& p) {
  const double whole = signedVolume(p[0], p[1], p[2], p[3]);
  bool inside = true;
  for (int f = 0; f < 4; ++f) {
    std::array<Vec3, 4> q = p;
    q[f] = x;
    if (signedVolume(q[0], q[1], q[2], q[3]) * whole < 0) inside = false;
  }
  if (inside) return 0.0;
  double best = HUGE_VAL;
  for (const auto& f : kTetFace)
    best = std::min(best, pointTriangleDistance(x, p[f[0]], p[f[1]], p[f[2]]));
  return best;
}

// The distance from segment ab to the tet: the distance to a convex set is convex along the
// segment, so a ternary search finds its minimum.
double segmentTetDistance(const Vec3& a, const Vec3& b, const std::array<Vec3, 4>& p) {
  double lo = 0.0, hi = 1.0;
  for (int i = 0; i < 200; ++i) {
    const double m1 = lo + (hi - lo) / 3, m2 = hi - (hi - lo) / 3;
    if (pointTetDistance(a + m1 * (b - a), p) <= pointTetDistance(a + m2 * (b - a), p))
      hi = m2;
    else
      lo = m1;
  }
  return pointTetDistance(a + 0.5 * (lo + hi) * (b - a), p);
}

}  // namespace

// A vertex is taken by a sweep when it lies within a band of a swept triangle's plane and
// projects inside it; the snap band and the wound's wider band ask it of one point and triangle
// in turn. pointNearTriangle() against a plain reference (distance along the unit normal, and
// the projection's coordinates solved from the edges), and PointOverTriangle's answers at
// several distances, asked in any order, against pointNearTriangle()'s own, to the bit.
TEST(SweepGeometry, PointNearTriangleAtSeveralDistancesAnswersAsEachAlone) {
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> unit(-1.0, 1.0), band(0.0, 0.6);
  int near = 0, far = 0, outside = 0, degenerate = 0;
  for (int trial = 0; trial < 4000; ++trial) {
    Triangle t{Vec3(unit(rng), unit(rng), unit(rng)), Vec3(unit(rng), unit(rng), unit(rng)),
               Vec3(unit(rng), unit(rng), unit(rng))};
    if (trial % 500 == 0) t[2] = t[1];  // no area: near nothing
    const PreparedTriangle prepared(t);
    const Vec3 x(unit(rng), unit(rng), unit(rng));
    const std::array<double, 4> distances{band(rng), band(rng), band(rng), 0.0};
    // The reference, where the triangle has an area and x is clear of its edges' planes.
    const Vec3 n = (t[1] - t[0]).cross(t[2] - t[0]);
    bool inside = false, clear = n.norm() > 1e-6;
    if (clear) {
      const Vec3 u = n.normalized();
      const Vec3 y = x - u.dot(x - t[0]) * u;
      // y = t0 + s (t1 - t0) + r (t2 - t0): the 2x2 normal equations.
      const Vec3 e1 = t[1] - t[0], e2 = t[2] - t[0], w = y - t[0];
      const double a11 = e1.dot(e1), a12 = e1.dot(e2), a22 = e2.dot(e2);
      const double det = a11 * a22 - a12 * a12;
      const double s = (a22 * e1.dot(w) - a12 * e2.dot(w)) / det;
      const double r = (a11 * e2.dot(w) - a12 * e1.dot(w)) / det;
      inside = s >= 0 && r >= 0 && s + r <= 1;
      clear = std::min({std::abs(s), std::abs(r), std::abs(1 - s - r)}) > 1e-9;
    }
    const double height = clear ? std::abs(n.normalized().dot(x - t[0])) : 0.0;
    const PointOverTriangle over(x, prepared);
    for (int k : {trial % 4, (trial + 2) % 4, (trial + 1) % 4, (trial + 3) % 4}) {
      const double d = distances[k];
      const bool alone = pointNearTriangle(x, prepared, d);
      ASSERT_EQ(over.near(d), alone) << "trial " << trial << ", distance " << d;
      if (!clear || std::abs(height - d) < 1e-9) continue;
      ASSERT_EQ(alone, inside && height <= d) << "trial " << trial << ", distance " << d;
      (alone ? near : inside ? far : outside) += 1;
    }
    if (n.norm() == 0.0) {
      EXPECT_FALSE(over.near(1e9));
      ++degenerate;
    }
  }
  std::printf("pointNearTriangle: %d near, %d over the triangle but too far, %d outside\n", near,
              far, outside);
  EXPECT_GT(near, 300);
  EXPECT_GT(far, 300);
  EXPECT_GT(outside, 3000);
  EXPECT_EQ(degenerate, 8);
}

// The sweep leaves out tets by this bound while the blade and tissue have not moved enough to
// reach them: it must never exceed the true distance, and it must be close enough to be of use.
TEST(SweepGeometry, SegmentTetGapIsALowerBoundOfTheDistanceAndATightOne) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> corner(-1.0, 1.0), end(-3.0, 3.0);
  int far = 0, stopped_early = 0;
  double ratio_sum = 0.0;
  // One segment prepared once and asked against every tet below (as the cutter asks its blade
  // against each tet near it), and for a corner's distance, answers as each call alone does.
  const Vec3 kept_base(0.3, -2.0, 0.5), kept_tip(-0.2, 2.5, -0.4);
  const PreparedSegment kept(kept_base, kept_tip);
  for (int trial = 0; trial < 3000; ++trial) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(corner(rng), corner(rng), corner(rng));
    if (std::abs(signedVolume(p[0], p[1], p[2], p[3])) < 1e-3) continue;
    Vec3 a(end(rng), end(rng), end(rng)), b(end(rng), end(rng), end(rng));
    if (trial % 10 == 0) b = a;  // a point
    const double distance = segmentTetDistance(a, b, p);
    const double gap = segmentTetGap(a, b, p);
    ASSERT_EQ(segmentTetGap(kept, p, 0.2), segmentTetGap(kept_base, kept_tip, p, 0.2));
    ASSERT_EQ(segmentTetGap(PreparedSegment(a, b), p), gap);
    ASSERT_EQ(kept.distanceTo(p[trial % 4]), distanceToSegment(p[trial % 4], kept_base, kept_tip));
    ASSERT_LE(gap, distance + 1e-9) << "trial " << trial;
    ASSERT_GE(gap, 0.0);
    // Told what is enough, it may stop at a bound past that, and otherwise answers the same.
    for (double enough : {-1.0, 0.0, 0.3, 1.0}) {
      const double early = segmentTetGap(a, b, p, enough);
      ASSERT_GE(early, 0.0) << "trial " << trial;
      ASSERT_LE(early, gap) << "trial " << trial;
      if (gap > std::max(enough, 0.0)) {
        ASSERT_GT(early, std::max(enough, 0.0)) << "trial " << trial << ", enough " << enough;
        stopped_early += early < gap ? 1 : 0;
      } else {
        ASSERT_EQ(early, gap) << "trial " << trial << ", enough " << enough;
      }
    }
    if (distance > 0.5) {
      ++far;
      ratio_sum += gap / distance;
    }
  }
  ASSERT_GT(far, 500);
  std::printf("segmentTetGap: mean bound / distance %.3f over %d pairs at least 0.5 apart; %d "
              "answers stopped early below the full bound\n",
              ratio_sum / far, far, stopped_early);
  EXPECT_GT(ratio_sum / far, 0.75);
  EXPECT_GT(stopped_early, 100);  // the cheaper axes often suffice
  // Meeting (a segment through the tet's centroid) and non-finite corners: no gap.
  const std::array<Vec3, 4> unit{Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  EXPECT_EQ(segmentTetGap(Vec3(-1, -1, -1), Vec3(1, 1, 1), unit), 0.0);
  std::array<Vec3, 4> broken = unit;
  broken[2].y() = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(segmentTetGap(Vec3(5, 5, 5), Vec3(6, 6, 6), broken), 0.0);
}

// A pending tet keeps its face planes while its corners stay where they were (finalizeLeft()
// asks each tick whether the blade is still inside). The answers must be those of planes made
// for each question (segmentMeetsTet()): on a tet that stays, and on one whose corners move (the
// planes made again), for segments that miss it, cross it, end inside it or graze a face within
// the tolerance.
TEST(SweepGeometry, KeptTetPlanesAnswerAsSegmentMeetsTet) {
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> corner(-1.0, 1.0), end(-2.0, 2.0), nudge(-0.3, 0.3);
  int meets = 0, misses = 0, moved = 0;
  for (int tet = 0; tet < 200; ++tet) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(corner(rng), corner(rng), corner(rng));
    if (tet % 20 == 0) p[3] = (p[0] + p[1] + p[2]) / 3.0;  // no volume: four faces in one plane
    if (tet % 20 == 10) p[3] = p[2];  // two corners at one point: two faces without a normal
    TetPlanes planes;
    for (int ask = 0; ask < 60; ++ask) {
      if (ask % 15 == 14) {  // the tet moves: a corner, or all of them a little
        ++moved;
        if (ask % 2)
          p[ask % 4] += Vec3(nudge(rng), nudge(rng), nudge(rng));
        else
          for (Vec3& x : p) x += Vec3(1e-6, -2e-6, 3e-6);
      }
      Vec3 a(end(rng), end(rng), end(rng)), b(end(rng), end(rng), end(rng));
      if (ask % 5 == 1) a = 0.25 * (p[0] + p[1] + p[2] + p[3]);  // from inside
      if (ask % 5 == 2) b = a;                                   // a point
      const double tolerance = ask % 3 == 0 ? 0.0 : 1e-3;
      const bool expected = segmentMeetsTet(a, b, p[0], p[1], p[2], p[3], tolerance);
      ASSERT_EQ(planes.meets(a, b, p[0], p[1], p[2], p[3], tolerance), expected)
          << "tet " << tet << ", question " << ask;
      (expected ? meets : misses) += 1;
    }
  }
  EXPECT_GT(meets, 2000);
  EXPECT_GT(misses, 2000);
  EXPECT_GT(moved, 500);
  // And the answers themselves, on the unit corner tet: inside, through, beside, far, and just
  // below its face z = 0 (within a tolerance of 1e-3, not of 1e-4).
  const Vec3 o(0, 0, 0), x(1, 0, 0), y(0, 1, 0), z(0, 0, 1);
  EXPECT_TRUE(segmentMeetsTet(Vec3(0.1, 0.1, 0.1), Vec3(0.2, 0.2, 0.2), o, x, y, z, 0.0));
  EXPECT_TRUE(segmentMeetsTet(Vec3(-1, 0.1, 0.1), Vec3(2, 0.1, 0.1), o, x, y, z, 0.0));
  EXPECT_FALSE(segmentMeetsTet(Vec3(-1, 0.6, 0.6), Vec3(2, 0.6, 0.6), o, x, y, z, 0.0));
  EXPECT_FALSE(segmentMeetsTet(Vec3(2, 2, 2), Vec3(3, 3, 3), o, x, y, z, 1e-3));
  EXPECT_TRUE(segmentMeetsTet(Vec3(0.2, 0.2, -5e-4), Vec3(0.3, 0.2, -9e-4), o, x, y, z, 1e-3));
  EXPECT_FALSE(segmentMeetsTet(Vec3(0.2, 0.2, -5e-4), Vec3(0.3, 0.2, -9e-4), o, x, y, z, 1e-4));
}

// A segment that moves on a little at a time, as the blade does from tick to tick: TetPlanes
// keeps how deep inside the last segment that met the tet was, and answers yes without the
// planes while both ends moved less than that. The answers must still be segmentMeetsTet()'s, as
// the segment walks in, through and out of the tet, with the tolerance changing now and then.
TEST(SweepGeometry, KeptTetPlanesFollowASegmentMovingOnAsSegmentMeetsTet) {
  std::mt19937 rng(21);
  std::uniform_real_distribution<double> corner(-1.0, 1.0), unit(-1.0, 1.0);
  int meets = 0, misses = 0, changes = 0;
  for (int tet = 0; tet < 100; ++tet) {
    std::array<Vec3, 4> p;
    for (Vec3& x : p) x = Vec3(corner(rng), corner(rng), corner(rng));
    const Vec3 centre = 0.25 * (p[0] + p[1] + p[2] + p[3]);
    const Vec3 along(unit(rng), unit(rng), unit(rng));
    Vec3 a = centre - along, b = centre + along;
    const Vec3 drift = 0.01 * Vec3(unit(rng), unit(rng), unit(rng));  // the stroke's way
    const double step = tet % 2 ? 1e-3 : 2e-2;                         // and each tick's tremble
    TetPlanes planes;
    bool last = true;
    for (int ask = 0; ask < 300; ++ask) {
      a += drift + step * Vec3(unit(rng), unit(rng), unit(rng));
      b += drift + step * Vec3(unit(rng), unit(rng), unit(rng));
      const double tolerance = (ask / 50) % 2 ? 1e-3 : 0.0;
      const bool expected = segmentMeetsTet(a, b, p[0], p[1], p[2], p[3], tolerance);
      ASSERT_EQ(planes.meets(a, b, p[0], p[1], p[2], p[3], tolerance), expected)
          << "tet " << tet << ", question " << ask;
      (expected ? meets : misses) += 1;
      changes += expected != last;
      last = expected;
    }
  }
  EXPECT_GT(meets, 5000);
  EXPECT_GT(misses, 5000);
  EXPECT_GT(changes, 100);  // walked out (and in again) many times
}

// The sweep looks again at a tet only once the blade's moves and the tissue's (as told) could
// have brought it within reach. A cutter told nothing looks at every tet near the blade each
// tick; one told that the tissue stays still reuses its bounds across ticks. Both must cut the
// same: a tilted trembling stroke out and back along its own wound.
TEST(Cutting, SweepBoundsCarriedAcrossTicksCutAsFreshOnesDo) {
  TremblingScalpel scalpel(11, 0.0001);
  std::vector<BladeSegment> blades;
  for (int k = 0; k <= 1000; ++k)
    blades.push_back(scalpel.at(1.0 - std::abs(k / 500.0 - 1.0)));  // out in 0.5 s, back in 0.5
  const MeshData block = makeBlock();
  auto cut = [&](bool told, TetMesh* mesh) {
    Cutter cutter(mesh, CutterOptions{});
    for (const BladeSegment& blade : blades) {
      ChangeRecord change;
      cutter.step(blade, &change);
      if (told) cutter.tissueMoved(0.0);
    }
    ChangeRecord change;
    cutter.step(std::nullopt, &change);
    return cutter.counts();
  };
  TetMesh carried(block.V, block.T), fresh(block.V, block.T);
  const CutCounts a = cut(true, &carried);
  const CutCounts b = cut(false, &fresh);
  EXPECT_GT(a.cut_tetrahedra, 100);
  EXPECT_EQ(a.cut_tetrahedra, b.cut_tetrahedra);
  EXPECT_EQ(a.created_tetrahedra, b.created_tetrahedra);
  EXPECT_EQ(a.separated_vertices, b.separated_vertices);
  ASSERT_EQ(carried.validate(), "");
  ASSERT_EQ(carried.vertexSlots(), fresh.vertexSlots());
  ASSERT_EQ(carried.tetSlots(), fresh.tetSlots());
  for (int t = 0; t < carried.tetSlots(); ++t) {
    ASSERT_EQ(carried.tetAlive(t), fresh.tetAlive(t)) << "tet " << t;
    if (carried.tetAlive(t)) {
      ASSERT_EQ(carried.tet(t), fresh.tet(t)) << "tet " << t;
    }
  }
  for (int v = 0; v < carried.vertexSlots(); ++v) {
    ASSERT_EQ(carried.vertexAlive(v), fresh.vertexAlive(v)) << "vertex " << v;
    if (carried.vertexAlive(v)) {
      ASSERT_EQ(carried.rest(v), fresh.rest(v)) << "vertex " << v;
    }
  }
}

namespace {

// A scalpel trembling by `sigma` [m] a tick along the stroke at 1 kHz, out in 0.5 s and (with
// `back`) back again in 0.5 s more. Its tremble is drawn as it goes: the blades are taken once,
// so that every cut replaying them sees the same ones.
std::vector<BladeSegment> trembling(unsigned seed, double sigma, bool back) {
  TremblingScalpel scalpel(seed, sigma);
  std::vector<BladeSegment> blades;
  for (int k = 0; k <= (back ? 1000 : 500); ++k)
    blades.push_back(scalpel.at(1.0 - std::abs(k / 500.0 - 1.0)));
  return blades;
}

// Trembling hard, out and back.
std::vector<BladeSegment> outAndBack() { return trembling(11, 0.0003, true); }

// Cuts `mesh` along `blades` with these options (the tissue told it does not move), then lifts
// the blade; validates the mesh every `validate_every` ticks (0: only the cutter, at the end).
CutCounts cutAlong(const std::vector<BladeSegment>& blades, const CutterOptions& options,
                   TetMesh* mesh, int validate_every = 0,
                   const std::function<double(std::size_t)>& move = nullptr) {
  Cutter cutter(mesh, options);
  for (std::size_t k = 0; k < blades.size(); ++k) {
    ChangeRecord change;
    cutter.step(blades[k], &change);
    // `move` moves the tissue after tick k and says how far.
    cutter.tissueMoved(move ? move(k) : 0.0);
    if (validate_every > 0 && k % validate_every == 0) {
      EXPECT_EQ(mesh->validate(), "") << "tick " << k;
      if (::testing::Test::HasFailure()) break;
    }
  }
  ChangeRecord change;
  cutter.step(std::nullopt, &change);
  EXPECT_EQ(cutter.validate(), "");
  return cutter.counts();
}

}  // namespace

// separate() takes a vertex's groups as heldSplits() found them unless a split since changed a tet
// of its star (renamed, its marks moved or opened). Kept or found afresh, the same vertices split
// into the same groups: the same mesh to the slot, over a trembling stroke out and back in with
// vertices waiting to split.
TEST(Cutting, KeptGroupsSplitAsGroupsFoundAfresh) {
  const std::vector<BladeSegment> blades = outAndBack();
  const MeshData block = makeBlock();
  auto cut = [&](bool keep, TetMesh* mesh) {
    CutterOptions options;
    options.keep_groups = keep;
    return cutAlong(blades, options, mesh);
  };
  TetMesh kept(block.V, block.T), afresh(block.V, block.T);
  const CutCounts a = cut(true, &kept);
  const CutCounts b = cut(false, &afresh);
  EXPECT_GT(a.separated_vertices, 100);
  EXPECT_GT(a.groups_kept, a.separation_tries / 5);  // kept for a good part of those tried
  EXPECT_EQ(b.groups_kept, 0);
  EXPECT_EQ(a.refused, 0);
  EXPECT_EQ(a.separated_vertices, b.separated_vertices);
  EXPECT_EQ(a.separation_tries, b.separation_tries);
  ASSERT_EQ(kept.validate(), "");
  ASSERT_EQ(kept.tetSlots(), afresh.tetSlots());
  for (int t = 0; t < kept.tetSlots(); ++t) {
    ASSERT_EQ(kept.tetAlive(t), afresh.tetAlive(t)) << "tet " << t;
    if (kept.tetAlive(t)) {
      ASSERT_EQ(kept.tet(t), afresh.tet(t)) << "tet " << t;
    }
  }
  ASSERT_EQ(kept.vertexSlots(), afresh.vertexSlots());
  for (int v = 0; v < kept.vertexSlots(); ++v) {
    if (kept.vertexAlive(v)) {
      ASSERT_EQ(kept.vertexTets(v), afresh.vertexTets(v)) << "vertex " << v;
    }
  }
}

// A blade coming back along its own cut, trembling 10-30 um a tick (the noise of a haptic
// device or a tracked tool), follows the wound: the block stays one piece, its boundary keeps the
// Euler characteristic the way out left (2: a slit), and the way back opens (almost) nothing the
// way out did not. Before, the way back snapped vertices the way out had kept off the cut (a
// point made on one of their edges first stood for them, or they lay in the crease between two
// ticks' quads) and cut 31-64 chips off the wall in each of these 16 runs.
TEST(Cutting, ABladeComingBackAlongItsCutCutsNoChipsOffIt) {
  const MeshData block = makeBlock();
  for (const double sigma : {0.00001, 0.00003}) {
    for (unsigned seed = 11; seed <= 18; ++seed) {
      const std::vector<BladeSegment> blades = trembling(seed, sigma, true);
      const std::vector<BladeSegment> out = trembling(seed, sigma, false);
      TetMesh there(block.V, block.T), back(block.V, block.T);
      const CutCounts a = cutAlong(out, CutterOptions{}, &there);
      const CutCounts b = cutAlong(blades, CutterOptions{}, &back);
      SCOPED_TRACE("tremble " + std::to_string(sigma) + " m, seed " + std::to_string(seed));
      ASSERT_EQ(countPieces(there), 1);
      EXPECT_GT(a.separated_vertices, 100);
      EXPECT_EQ(countPieces(back), 1);
      EXPECT_EQ(boundaryEulerCharacteristic(back), boundaryEulerCharacteristic(there));
      EXPECT_LE(b.separated_vertices - a.separated_vertices, a.separated_vertices / 50);
      EXPECT_EQ(back.validate(), "");
    }
  }
}

// A trembling stroke over the block leaves no bridge across its wound. Where the blade crossed an
// edge of a tet next to a wound vertex its earlier ticks had made, the crossing was dropped (the
// vertex stood for it), and the tet's tent split ended its sheet at its centroid, one face short of
// that vertex: material stayed joined across the wound there, a handle of the boundary. With 30
// um of tremble a tick each of ten strokes is now one piece with the boundary of a slit (Euler
// characteristic 2; one stroke had a handle before); with 0.1 mm the ten wounds hold 17 handles in
// all instead of 51 (the bound below leaves room for change, not for the old count).
TEST(Cutting, ATremblingStrokeLeavesNoBridgeAcrossItsWound) {
  const MeshData block = makeBlock();
  int handles = 0;
  for (const double sigma : {0.00003, 0.0001}) {
    for (unsigned seed = 11; seed <= 20; ++seed) {
      const std::vector<BladeSegment> blades = trembling(seed, sigma, false);
      TetMesh mesh(block.V, block.T);
      const CutCounts counts = cutAlong(blades, CutterOptions{}, &mesh);
      EXPECT_GT(counts.separated_vertices, 100);
      EXPECT_EQ(mesh.validate(), "");
      const int pieces = countPieces(mesh), chi = boundaryEulerCharacteristic(mesh);
      if (sigma < 0.0001) {
        EXPECT_EQ(pieces, 1) << "seed " << seed;
        EXPECT_EQ(chi, 2) << "seed " << seed;
      } else {
        handles += (2 * pieces - chi) / 2;  // the pieces' genera: closed orientable surfaces
      }
    }
  }
  std::printf("handles of the ten 0.1 mm strokes' wounds: %d\n", handles);
  EXPECT_LE(handles, 25);
}

// A pending tet the blade leaves on the tick it takes a new point gets its final split straight
// away, without first being subdivided anew with the point as the tets the blade is still in are
// (a subdivision the final split would replace at once). Over a trembling stroke out and back,
// the mesh is the same tet for tet (only the slots differ) with fewer subdivisions.
TEST(Cutting, TetsLeftAsTheyTakeAPointAreSplitWithoutSubdividingFirst) {
  const std::vector<BladeSegment> blades = outAndBack();
  const MeshData block = makeBlock();
  auto cut = [&](bool subdivide_left, TetMesh* mesh) {
    CutterOptions options;
    options.subdivide_left = subdivide_left;
    return cutAlong(blades, options, mesh, 10);
  };
  // Each live tet as its four corners' rest positions, sorted; all of them sorted.
  auto shapes = [](const TetMesh& mesh) {
    std::vector<std::array<std::array<double, 3>, 4>> out;
    for (int t = 0; t < mesh.tetSlots(); ++t) {
      if (!mesh.tetAlive(t)) continue;
      std::array<std::array<double, 3>, 4> corners;
      for (int k = 0; k < 4; ++k) {
        const Vec3& x = mesh.rest(mesh.tet(t)[k]);
        corners[k] = {x.x(), x.y(), x.z()};
      }
      std::sort(corners.begin(), corners.end());
      out.push_back(corners);
    }
    std::sort(out.begin(), out.end());
    return out;
  };
  TetMesh straight(block.V, block.T), first(block.V, block.T);
  const CutCounts a = cut(false, &straight);
  const CutCounts b = cut(true, &first);
  std::printf("subdivisions %lld straight to the final split, %lld subdividing first\n",
              a.subdivisions, b.subdivisions);
  EXPECT_GT(a.cut_tetrahedra, 100);
  EXPECT_LT(a.subdivisions, b.subdivisions);
  EXPECT_EQ(a.refused, 0);
  EXPECT_EQ(a.cut_tetrahedra, b.cut_tetrahedra);
  EXPECT_EQ(a.created_tetrahedra, b.created_tetrahedra);
  EXPECT_EQ(a.separated_vertices, b.separated_vertices);
  EXPECT_EQ(a.by_kind, b.by_kind);
  EXPECT_EQ(straight.numTets(), first.numTets());
  EXPECT_EQ(straight.numVertices(), first.numVertices());
  EXPECT_TRUE(shapes(straight) == shapes(first));
}

// The quiet ticks (CutterOptions::skip_quiet) keep the features near the blade by this distance:
// it must never exceed the true one, and it must be the distance, not a loose bound. Against the
// nearest of 201 x 201 sample pairs (which is at most half a sample step on each further), over
// random segments with parallel ones and points among them, and the cases a formula may get
// wrong: crossing, collinear, parallel and overlapping, skew with the nearest points inside.
TEST(SweepGeometry, SegmentSegmentDistanceIsTheDistance) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  auto sampled = [](const Vec3& p0, const Vec3& p1, const Vec3& q0, const Vec3& q1) {
    double best = HUGE_VAL;
    for (int i = 0; i <= 200; ++i)
      for (int j = 0; j <= 200; ++j)
        best = std::min(best, (p0 + (p1 - p0) * (i / 200.0) - q0 - (q1 - q0) * (j / 200.0)).norm());
    return best;
  };
  for (int trial = 0; trial < 300; ++trial) {
    const Vec3 p0(u(rng), u(rng), u(rng)), p1(u(rng), u(rng), u(rng));
    Vec3 q0(u(rng), u(rng), u(rng)), q1(u(rng), u(rng), u(rng));
    if (trial % 10 == 1) q1 = q0 + 0.7 * (p1 - p0);  // parallel
    if (trial % 10 == 2) q1 = q0;                    // a point
    const double d = segmentSegmentDistance(p0, p1, q0, q1), s = sampled(p0, p1, q0, q1);
    ASSERT_LE(d, s + 1e-12) << "trial " << trial;
    // Parallel segments and points take the ends: the least of the four ends' distances, to
    // the bit (the ends' squares compared, one root taken).
    if (trial % 10 == 1 || trial % 10 == 2) {
      ASSERT_EQ(d, std::min({distanceToSegment(p0, q0, q1), distanceToSegment(p1, q0, q1),
                             distanceToSegment(q0, p0, p1), distanceToSegment(q1, p0, p1)}))
          << "trial " << trial;
    }
    ASSERT_GE(d, s - 0.5 / 200 * ((p1 - p0).norm() + (q1 - q0).norm()) - 1e-12)
        << "trial " << trial;
  }
  const Vec3 o(0, 0, 0), x(1, 0, 0);
  EXPECT_NEAR(segmentSegmentDistance(-x, x, Vec3(0, -1, 0), Vec3(0, 1, 0)), 0.0, 1e-15);
  EXPECT_NEAR(segmentSegmentDistance(o, x, Vec3(3, 0, 0), Vec3(5, 0, 0)), 2.0, 1e-15);
  EXPECT_NEAR(segmentSegmentDistance(o, x, Vec3(0.5, 0.3, 0), Vec3(2, 0.3, 0)), 0.3, 1e-15);
  EXPECT_NEAR(segmentSegmentDistance(o, x, Vec3(0.5, 1, 2), Vec3(0.5, 1, 2)), std::sqrt(5.0),
              1e-15);
  EXPECT_NEAR(segmentSegmentDistance(-x, x, Vec3(0, -1, 0.25), Vec3(0, 1, 0.25)), 0.25, 1e-15);
}

namespace {

// Both meshes the same to the slot: live tets and their vertices, live vertices and their rest
// and current positions.
void expectSameMesh(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.tetSlots(), b.tetSlots());
  for (int t = 0; t < a.tetSlots(); ++t) {
    ASSERT_EQ(a.tetAlive(t), b.tetAlive(t)) << "tet " << t;
    if (a.tetAlive(t)) {
      ASSERT_EQ(a.tet(t), b.tet(t)) << "tet " << t;
    }
  }
  ASSERT_EQ(a.vertexSlots(), b.vertexSlots());
  for (int v = 0; v < a.vertexSlots(); ++v) {
    ASSERT_EQ(a.vertexAlive(v), b.vertexAlive(v)) << "vertex " << v;
    if (a.vertexAlive(v)) {
      ASSERT_EQ(a.rest(v), b.rest(v)) << "vertex " << v;
      ASSERT_EQ(a.current(v), b.current(v)) << "vertex " << v;
    }
  }
}

// Cuts `mesh` along `blades` (then lifts the blade) with quiet ticks on or off, and with
// check_quiet. With `bend`, the block bends up and down under the blade (each vertex by
// 0.2 mm sin(2 pi x / 5 cm) sin(2 pi k / 200) at tick k), and the cutter is told how far.
CutCounts cutQuietly(const std::vector<BladeSegment>& blades, bool skip, bool check, bool bend,
                     TetMesh* mesh) {
  CutterOptions options;
  options.skip_quiet = skip;
  options.check_quiet = check;
  const double pi = 3.14159265358979323846;
  auto bendBlock = [&](std::size_t k) {
    const double lift = 2e-4 * (std::sin(2 * pi * (k + 1) / 200.0) - std::sin(2 * pi * k / 200.0));
    double moved = 0.0;
    for (int v = 0; v < mesh->vertexSlots(); ++v) {
      if (!mesh->vertexAlive(v)) continue;
      const double dz = lift * std::sin(2 * pi * mesh->rest(v).x() / 0.05);
      mesh->current(v).z() += dz;
      moved = std::max(moved, std::abs(dz));
    }
    return moved;
  };
  return cutAlong(blades, options, mesh, 0,
                  bend ? std::function<double(std::size_t)>(bendBlock) : nullptr);
}

}  // namespace

// A tick whose blade cannot have come near anything a sweep acts on is not swept
// (CutterOptions::skip_quiet), and one that reaches at most one kept vertex tests only the kept
// features it reached: the cut must be the same as when every tick sweeps, to the slot, and
// check_quiet, which sweeps those ticks too, must find that they would have changed nothing
// (more). Strokes out and back over the block trembling 30 um and 0.3 mm a tick, the first also
// over the block bending under the blade.
TEST(Cutting, QuietTicksCutAsSweptOnes) {
  const MeshData block = makeBlock();
  struct Case {
    double sigma;
    bool bend;
  };
  for (const Case& c : {Case{0.00003, false}, Case{0.00003, true}, Case{0.0003, false}}) {
    SCOPED_TRACE("tremble " + std::to_string(c.sigma) + " m" + (c.bend ? ", bending" : ""));
    const std::vector<BladeSegment> blades = trembling(11, c.sigma, true);
    TetMesh quiet(block.V, block.T), swept(block.V, block.T), checked(block.V, block.T);
    const CutCounts a = cutQuietly(blades, true, false, c.bend, &quiet);
    const CutCounts b = cutQuietly(blades, false, false, c.bend, &swept);
    CutCounts checks;
    EXPECT_NO_THROW(checks = cutQuietly(blades, true, true, c.bend, &checked));
    std::printf("tremble %g m%s: %lld of %zu ticks quiet; %lld quiet reaches taken anew "
                "without a sweep (%lld checked); %lld ticks tested their reached features alone "
                "(%lld checked)\n",
                c.sigma, c.bend ? ", bending" : "", a.quiet_ticks, blades.size(),
                a.quiet_refreshes, checks.quiet_refreshes, a.feature_ticks, checks.feature_ticks);
    EXPECT_GT(a.cut_tetrahedra, 100);
    EXPECT_EQ(b.quiet_ticks, 0);
    EXPECT_GT(checks.quiet_ticks, 0);  // some (its sweeps leave the searches' bounds fresher)
    EXPECT_GT(a.quiet_refreshes, 0);
    EXPECT_GT(checks.quiet_refreshes, 0);  // those ticks' sweeps checked too
    // Ticks that reached kept features tested those alone, and a sweep after found nothing
    // more to do (check_quiet).
    EXPECT_GT(a.feature_ticks, 0);
    EXPECT_GT(checks.feature_ticks, 0);
    EXPECT_EQ(b.feature_ticks, 0);
    EXPECT_EQ(a.cut_tetrahedra, b.cut_tetrahedra);
    EXPECT_EQ(a.created_tetrahedra, b.created_tetrahedra);
    EXPECT_EQ(a.separated_vertices, b.separated_vertices);
    expectSameMesh(quiet, swept);
    expectSameMesh(quiet, checked);
  }
}

// The same over random incisions of the project's TetGen sphere and Gmsh ellipsoid (the property
// tests' generator: strokes that start or stop inside, tilted, curved, trembling): skipping the
// quiet ticks and acting on the reached features alone leave the mesh as sweeping every tick
// does, to the slot, and check_quiet finds nothing those ticks missed.
TEST(Cutting, QuietAndFeatureTicksCutAsSweptOnesOnRandomIncisions) {
  long long quiet = 0, features = 0, ticks = 0;
  for (const std::string name : {"sphere_tetgen.node", "ellipsoid_v22.msh"}) {
    const MeshData mesh = readMesh(std::string(TISSUE_CUT_SOURCE_DIR) + "/meshes/" + name);
    for (std::uint64_t seed = 1; seed <= 4; ++seed) {
      const property::RandomIncision incision = property::randomIncision(mesh, seed);
      SCOPED_TRACE(name + ", seed " + std::to_string(seed) + ": " + incision.description);
      const ScalpelPath path(incision.poses);
      const double dt = 1.0 / incision.rate;
      std::vector<BladeSegment> blades;
      for (double t = path.startTime(); t <= path.endTime(); t += dt) {
        const ToolPose pose = path.at(t);
        blades.push_back(bladeFromPose(pose.position, pose.orientation, incision.blade_length));
      }
      auto cut = [&](bool skip, bool check, TetMesh* m) {
        CutterOptions options;
        options.skip_quiet = skip;
        options.check_quiet = check;
        return cutAlong(blades, options, m);
      };
      TetMesh skipped(mesh.V, mesh.T), swept(mesh.V, mesh.T), checked(mesh.V, mesh.T);
      const CutCounts a = cut(true, false, &skipped);
      const CutCounts b = cut(false, false, &swept);
      EXPECT_NO_THROW(cut(true, true, &checked));
      EXPECT_EQ(b.quiet_ticks + b.feature_ticks, 0);
      EXPECT_EQ(a.cut_tetrahedra, b.cut_tetrahedra);
      expectSameMesh(skipped, swept);
      expectSameMesh(skipped, checked);
      quiet += a.quiet_ticks;
      features += a.feature_ticks;
      ticks += static_cast<long long>(blades.size());
    }
  }
  std::printf("%lld ticks: %lld quiet, %lld acted on their reached features alone\n", ticks, quiet,
              features);
  EXPECT_GT(quiet, ticks / 4);
  EXPECT_GT(features, 100);
}

// A cutter never told how far the tissue moves (tissueMoved) must assume that anything may have
// moved: it sweeps every tick. Told that the tissue stays still, it leaves most ticks of the
// same stroke unswept.
TEST(Cutting, ACutterNeverToldHowTheTissueMovesSweepsEveryTick) {
  const MeshData block = makeBlock();
  const std::vector<BladeSegment> blades = trembling(12, 0.00003, false);
  for (const bool told : {false, true}) {
    TetMesh mesh(block.V, block.T);
    Cutter cutter(&mesh, CutterOptions{});
    for (const BladeSegment& blade : blades) {
      ChangeRecord change;
      cutter.step(blade, &change);
      if (told) cutter.tissueMoved(0.0);
    }
    if (told) {
      EXPECT_GT(cutter.counts().quiet_ticks, static_cast<long long>(blades.size() / 5));
    } else {
      EXPECT_EQ(cutter.counts().quiet_ticks, 0);
    }
    // It looks for drift in its tet index at every vertex each tick; told, only on the first
    // (before anything told it), as the tissue stays where the index was built.
    EXPECT_EQ(cutter.counts().grid_scans, told ? 1 : static_cast<long long>(blades.size()));
  }
}

// A Tissue builds its cutter where the vertices are and tells it each tick how far the physics
// moved them: no tick scans the tet index for drift when nothing moves, the first included
// (told nothing at first, the cutter had scanned every vertex on its first tick).
TEST(Cutting, ATissueThatDoesNotMoveNeverScansTheTetIndexForDrift) {
  Tissue tissue(cutOnly(0.03), makeBlock());
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0021, 0.042}, {0.01, 0.0021, 0.042}, 0.3), 1000), "");
  EXPECT_GT(tissue.statistics().cut.cut_tetrahedra, 0);
  EXPECT_EQ(tissue.cutter().counts().grid_scans, 0);
  // After a reset too: the cutter is built anew.
  tissue.reset();
  ASSERT_EQ(replay(tissue, line({-0.07, 0.0021, 0.042}, {0.01, 0.0021, 0.042}, 0.3), 1000), "");
  EXPECT_EQ(tissue.cutter().counts().grid_scans, 0);
}

// The kept features reach a tenth of a mean edge around the blade only while the sweeps' boxes
// stay inside the near cache. Where the blade nears the cache's edge, the cache and the gaps are
// taken anew before the features are (Cutter::roomAround): the blade leaving the cache does not
// send ticks to a full sweep. Before it, the strokes below were swept on 35 and 37 of their 500
// ticks; with it, on 4.
TEST(Cutting, TheNearCachesEdgeSendsNoTickToASweep) {
  const MeshData block = makeBlock();
  for (const double sigma : {0.0, 0.00003}) {
    SCOPED_TRACE("tremble " + std::to_string(sigma) + " m");
    const std::vector<BladeSegment> blades = trembling(12, sigma, false);
    TetMesh mesh(block.V, block.T);
    const CutCounts counts = cutAlong(blades, CutterOptions{}, &mesh);
    // The first tick has no blade before it: it is never swept (nor is the lift after the last,
    // which is not one of these ticks).
    const long long ticks = static_cast<long long>(blades.size()) - 1;
    const long long swept = ticks - counts.quiet_ticks - counts.feature_ticks;
    std::printf("tremble %g m: %lld of %lld ticks swept, %lld quiet, %lld acted on features "
                "alone, %lld quiet reaches taken anew\n",
                sigma, swept, ticks, counts.quiet_ticks, counts.feature_ticks,
                counts.quiet_refreshes);
    EXPECT_GT(counts.cut_tetrahedra, 50);
    EXPECT_LE(swept, 6);
  }
}

// A blade trembling hard inside its own wound leaves hundreds of vertices waiting to split (the
// cut around them stays incomplete: sheets meeting at a crack front). They are tried again only
// near what changed since the last try, not all of them on every tick that changes anything
// (that made ticks of a hundred milliseconds); at the end of the stroke every one is tried.
TEST(Cutting, WaitingVerticesAreTriedAgainOnlyNearChanges) {
  TremblingScalpel scalpel(11, 0.0003);
  const MeshData block = makeBlock();
  TetMesh mesh(block.V, block.T);
  Cutter cutter(&mesh, CutterOptions{});
  long long waiting_ticks = 0;  // the waiting vertices summed over the ticks
  int most_waiting = 0;
  for (int k = 0; k <= 1000; ++k) {
    const BladeSegment blade = scalpel.at(1.0 - std::abs(k / 500.0 - 1.0));  // out and back in 1 s
    waiting_ticks += cutter.numDeferred();
    most_waiting = std::max(most_waiting, cutter.numDeferred());
    ChangeRecord change;
    cutter.step(blade, &change);
    cutter.tissueMoved(0.0);
    if (k % 100 == 0) {
      ASSERT_EQ(mesh.validate(), "") << "tick " << k;
      ASSERT_EQ(cutter.validate(), "") << "tick " << k;
    }
  }
  const long long tries = cutter.counts().separation_tries;
  std::printf("waiting at most %d, %lld waiting-vertex ticks, %lld vertices tried\n", most_waiting,
              waiting_ticks, tries);
  EXPECT_GT(most_waiting, 300);
  EXPECT_LT(tries, waiting_ticks / 4);
  // The blade lifted: the stroke is over and every waiting vertex is tried once more.
  const int waiting = cutter.numDeferred();
  ChangeRecord change;
  cutter.step(std::nullopt, &change);
  EXPECT_GE(cutter.counts().separation_tries - tries, waiting);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_EQ(cutter.validate(), "");
}

// The collapse queue looks again at tets waiting for busy vertices only when the cutter's state
// epoch changed. A collapse, a flip or a smoothing move works only where no vertex is busy and
// leaves every vertex busy or not as it was, so following one does not change the epoch (and
// isBusy() keeps its answers for an epoch: on every tick they must be the ones worked out anew).
// Checked while a trembling blade is inside the block, with tets pending, faces marked and
// vertices waiting to split.
TEST(Cutting, CollapsesLeaveEveryVertexBusyAsItWas) {
  TremblingScalpel scalpel(5, 0.0003);
  const MeshData block = makeBlock();
  TetMesh mesh(block.V, block.T);
  Cutter cutter(&mesh, CutterOptions{});
  CollapseQueue queue(&mesh, 0.3, 0.0);
  queue.setSmoothing(true);
  queue.setFlips(true, [&](int u, int v) { return cutter.mayJoin(u, v); });
  std::vector<unsigned char> created;  // per tet slot: made by the cut (or renamed from one)
  auto follow = [&](const ChangeRecord& change) {
    std::vector<unsigned char> removed(change.removed_tets.size());
    for (std::size_t i = 0; i < change.removed_tets.size(); ++i)
      removed[i] = created[change.removed_tets[i]];
    created.resize(mesh.tetSlots(), 0);
    for (std::size_t i = 0; i < change.added_tets.size(); ++i) {
      const auto from = std::find(change.removed_tets.begin(), change.removed_tets.end(),
                                  change.added_from[i]);
      created[change.added_tets[i]] =
          change.added_from[i] < 0 || from == change.removed_tets.end()
              ? 1
              : removed[from - change.removed_tets.begin()];
    }
  };
  auto isCreated = [&](int t) {
    return t < static_cast<int>(created.size()) && created[t] != 0;
  };
  // Worked out anew (isBusy() keeps its answers for an epoch, which is what this test checks);
  // and the kept answers must be these.
  int kept_wrong = 0;
  auto busyNow = [&] {
    std::vector<signed char> busy(mesh.vertexSlots(), -1);  // -1: dead
    for (int v = 0; v < mesh.vertexSlots(); ++v)
      if (mesh.vertexAlive(v)) {
        busy[v] = cutter.isBusyAfresh(v) ? 1 : 0;
        if (cutter.isBusy(v) != (busy[v] == 1)) ++kept_wrong;
      }
    return busy;
  };
  created.assign(mesh.tetSlots(), 0);
  long long last_epoch = -1;
  int collapsing_ticks = 0, busy_seen = 0, answers_changed = 0;
  for (int k = 0; k <= 400; ++k) {
    ChangeRecord change;
    cutter.step(scalpel.at(k / 500.0), &change);
    cutter.tissueMoved(0.0);
    follow(change);
    queue.queueFrom(change, isCreated);
    const long long epoch = cutter.stateEpoch();
    const auto before = busyNow();
    ChangeRecord collapsed;
    queue.process([&](int v) { return cutter.isBusy(v); }, isCreated, &collapsed,
                  epoch != last_epoch);
    last_epoch = epoch;
    if (collapsed.empty()) {
      busyNow();  // the kept answers checked on every tick
      continue;
    }
    follow(collapsed);
    cutter.follow(collapsed);
    ++collapsing_ticks;
    EXPECT_EQ(cutter.stateEpoch(), epoch) << "tick " << k;
    const auto after = busyNow();
    for (std::size_t v = 0; v < before.size(); ++v) {
      if (before[v] == 1) ++busy_seen;
      if (before[v] >= 0 && v < after.size() && after[v] >= 0 && before[v] != after[v])
        ++answers_changed;
    }
    if (k % 50 == 0) {
      ASSERT_EQ(mesh.validate(), "") << "tick " << k;
      ASSERT_EQ(cutter.validate(), "") << "tick " << k;
    }
  }
  std::printf("%d ticks with collapses, %d busy vertex-ticks around them, %d answers changed\n",
              collapsing_ticks, busy_seen, answers_changed);
  EXPECT_GT(collapsing_ticks, 20);
  EXPECT_GT(busy_seen, 1000);
  EXPECT_EQ(answers_changed, 0);
  EXPECT_EQ(kept_wrong, 0);
  EXPECT_GT(queue.counts().collapsed_edges, 0);
  EXPECT_EQ(mesh.validate(), "");
}
