// Vertex smoothing (our extension to the paper's collapse): a vertex moves to raise its star's
// worst quality, freely inside the body, within its plane on a flat boundary patch, along its
// line on a straight crease, never at a corner; the material point's motion comes with it.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <vector>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/remesh/collapse_queue.hpp"
#include "tissue_cut/remesh/vertex_smoothing.hpp"

using namespace tissue_cut;

namespace {

// A block of unit Kuhn cells from the origin to (nx, ny, nz) [m], vertex `at` moved to `to`.
TetMesh blockWithMoved(int nx, int ny, int nz, const Vec3& at, const Vec3& to, int* moved) {
  BlockSpec spec;
  spec.min = Vec3::Zero();
  spec.max = Vec3(nx, ny, nz);
  spec.cell_size = 1.0;
  MeshData m = makeBlock(spec);
  *moved = -1;
  for (int r = 0; r < m.V.rows(); ++r)
    if ((Vec3(m.V.row(r)) - at).norm() < 1e-9) *moved = r;
  if (*moved < 0) throw std::logic_error("no vertex there");
  m.V.row(*moved) = to.transpose();
  return TetMesh(m.V, m.T);
}

double worstOfStar(const TetMesh& mesh, int v) {
  double worst = 1.0;
  for (int t : mesh.vertexTets(v)) worst = std::min(worst, restQuality(mesh, t));
  return worst;
}

}  // namespace

TEST(VertexSmoothing, FreedomFollowsTheBoundaryAroundTheVertex) {
  int v = -1;
  const TetMesh mesh = blockWithMoved(2, 2, 2, Vec3::Zero(), Vec3::Zero(), &v);
  auto freedomAt = [&](const Vec3& p, Vec3* dir) {
    for (int u = 0; u < mesh.vertexSlots(); ++u)
      if ((mesh.rest(u) - p).norm() < 1e-9) return vertexFreedom(mesh, u, dir);
    throw std::logic_error("no vertex there");
  };
  Vec3 dir;
  EXPECT_EQ(freedomAt(Vec3(1, 1, 1), &dir), VertexFreedom::kInterior);
  EXPECT_EQ(freedomAt(Vec3(1, 1, 0), &dir), VertexFreedom::kPlane);
  EXPECT_NEAR(std::abs(dir.z()), 1.0, 1e-12);  // the bottom's normal
  EXPECT_EQ(freedomAt(Vec3(1, 0, 0), &dir), VertexFreedom::kLine);
  EXPECT_NEAR(std::abs(dir.x()), 1.0, 1e-12);  // along the bottom front edge
  EXPECT_EQ(freedomAt(Vec3(0, 0, 0), &dir), VertexFreedom::kPinned);
}

TEST(VertexSmoothing, InteriorVertexMovesToRaiseTheWorstQualityAndKeepsTheVolume) {
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 1, 1), Vec3(1.3, 1.2, 1.25), &v);
  ASSERT_EQ(mesh.validate(), "");
  ASSERT_EQ(mesh.reoriented(), 0);
  const double before = worstOfStar(mesh, v);
  ChangeRecord record;
  SmoothingCheck check;
  ASSERT_TRUE(smoothVertex(&mesh, v, 1e-3, &record, &check));
  EXPECT_EQ(check.freedom, VertexFreedom::kInterior);
  EXPECT_NEAR(check.worst_before, before, 1e-12);
  EXPECT_GE(check.worst_after, before + 1e-3);
  EXPECT_NEAR(worstOfStar(mesh, v), check.worst_after, 1e-9);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_NEAR(mesh.restVolume(), 8.0, 1e-12);
  // The star is announced as replaced by itself: the same elements, nothing new.
  std::vector<int> removed = record.removed_tets, added = record.added_tets;
  std::sort(removed.begin(), removed.end());
  std::sort(added.begin(), added.end());
  EXPECT_EQ(added, removed);
  EXPECT_EQ(added.size(), mesh.vertexTets(v).size());
  for (int from : record.added_from) EXPECT_GE(from, 0);
  EXPECT_TRUE(record.added_vertices.empty());
  EXPECT_TRUE(record.removed_vertices.empty());
}

TEST(VertexSmoothing, BoundaryVertexOnAFlatFaceStaysInItsPlane) {
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 1, 0), Vec3(1.3, 1.2, 0), &v);
  const double before = worstOfStar(mesh, v);
  SmoothingCheck check;
  ASSERT_TRUE(smoothVertex(&mesh, v, 1e-3, nullptr, &check));
  EXPECT_EQ(check.freedom, VertexFreedom::kPlane);
  EXPECT_EQ(mesh.rest(v).z(), 0.0);
  EXPECT_LT((mesh.rest(v) - Vec3(1, 1, 0)).norm(), (Vec3(1.3, 1.2, 0) - Vec3(1, 1, 0)).norm());
  EXPECT_GT(worstOfStar(mesh, v), before);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_NEAR(mesh.restVolume(), 8.0, 1e-12);
}

TEST(VertexSmoothing, BoundaryVertexOnAStraightCreaseMovesAlongIt) {
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 0, 0), Vec3(1.3, 0, 0), &v);
  SmoothingCheck check;
  ASSERT_TRUE(smoothVertex(&mesh, v, 1e-3, nullptr, &check));
  EXPECT_EQ(check.freedom, VertexFreedom::kLine);
  EXPECT_EQ(mesh.rest(v).y(), 0.0);
  EXPECT_EQ(mesh.rest(v).z(), 0.0);
  EXPECT_LT(mesh.rest(v).x(), 1.3);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_NEAR(mesh.restVolume(), 8.0, 1e-12);
}

TEST(VertexSmoothing, CornerNeverMoves) {
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3::Zero(), Vec3::Zero(), &v);
  ChangeRecord record;
  SmoothingCheck check;
  EXPECT_FALSE(smoothVertex(&mesh, v, 0.0, &record, &check));
  EXPECT_EQ(check.freedom, VertexFreedom::kPinned);
  EXPECT_EQ(mesh.rest(v), Vec3::Zero());
  EXPECT_TRUE(record.empty());
}

TEST(VertexSmoothing, NoMoveWhenTheGainIsTooSmall) {
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 1, 1), Vec3(1, 1, 1), &v);  // already optimal
  EXPECT_FALSE(smoothVertex(&mesh, v, 1e-3, nullptr));
  EXPECT_EQ(mesh.rest(v), Vec3(1, 1, 1));
}

TEST(VertexSmoothing, CurrentPositionFollowsTheMaterialPoint) {
  // A deformed body (an affine map of rest): the moved vertex's current position and velocity
  // are those of the material point it moves to.
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 1, 1), Vec3(1.3, 1.2, 1.25), &v);
  Eigen::Matrix3d A;
  A << 1.1, 0.2, 0.0, 0.0, 0.9, 0.1, 0.05, 0.0, 1.0;
  const Vec3 b(0.01, -0.02, 0.03), w(0.5, 0.0, -0.25);
  for (int u = 0; u < mesh.vertexSlots(); ++u) {
    mesh.current(u) = A * mesh.rest(u) + b;
    mesh.velocity(u) = w.cross(mesh.rest(u));
  }
  ASSERT_TRUE(smoothVertex(&mesh, v, 1e-3, nullptr));
  EXPECT_LT((mesh.current(v) - (A * mesh.rest(v) + b)).norm(), 1e-12);
  EXPECT_LT((mesh.velocity(v) - w.cross(mesh.rest(v))).norm(), 1e-12);
}

TEST(VertexSmoothing, QueueSmoothsWhatItCannotCollapseAndNeverLosesVolume) {
  // The interior vertex pushed towards a corner of its cell makes bad tets; every tet counts as
  // made by a cut. The queue collapses or smooths until the worst quality rose.
  int v = -1;
  TetMesh mesh = blockWithMoved(2, 2, 2, Vec3(1, 1, 1), Vec3(1.35, 1.3, 1.38), &v);
  ASSERT_EQ(mesh.validate(), "");
  const double worst_before = summarizeQuality(mesh).min;
  ChangeRecord all;
  for (int t = 0; t < mesh.tetSlots(); ++t) all.added_tets.push_back(t);
  CollapseQueue queue(&mesh, 0.6, 0.0);
  queue.setShapeTolerance(0.08, 1e-3 * mesh.restVolume());
  auto yes = [](int) { return true; };
  auto no = [](int) { return false; };
  queue.queueFrom(all, yes);
  ChangeRecord change;
  queue.process(no, yes, &change);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_GT(queue.counts().smoothed_vertices + queue.counts().collapsed_edges, 0);
  EXPECT_GT(summarizeQuality(mesh).min, worst_before);
  EXPECT_NEAR(mesh.restVolume(), 8.0, 1e-3 * 8.0);
  EXPECT_LE(std::abs(queue.volumeChanged()), 1e-3 * 8.0);
}

TEST(VertexSmoothing, QueueKeepsBoundaryCollapsesWithinTheVolumeBudget) {
  // A 2 x 2 x 1 block whose top vertex (1, 1, 1) sits at (0.2, 1, 1.02), a slight bulge next to
  // the top edge: collapsing it flattens the bulge (about -0.02 m^3), which only a budget allows.
  auto run = [](double budget, CollapseCounts* counts) {
    int v = -1;
    TetMesh mesh = blockWithMoved(2, 2, 1, Vec3(1, 1, 1), Vec3(0.2, 1, 1.02), &v);
    const double volume = mesh.restVolume();
    ChangeRecord all;
    for (int t = 0; t < mesh.tetSlots(); ++t) all.added_tets.push_back(t);
    CollapseQueue queue(&mesh, 0.6, 0.0);
    queue.setShapeTolerance(0.08, budget);
    auto yes = [](int) { return true; };
    queue.queueFrom(all, yes);
    ChangeRecord change;
    queue.process([](int) { return false; }, yes, &change);
    EXPECT_EQ(mesh.validate(), "");
    EXPECT_NEAR(mesh.restVolume() - volume, queue.volumeChanged(), 1e-12);
    *counts = queue.counts();
    return mesh.restVolume() - volume;
  };
  CollapseCounts tight, loose;
  EXPECT_NEAR(run(1e-9, &tight), 0.0, 1e-9);
  EXPECT_GT(tight.rejected_boundary, 0);
  EXPECT_LT(run(1.0, &loose), -1e-3);
  EXPECT_GT(loose.collapsed_edges, tight.collapsed_edges);
}
