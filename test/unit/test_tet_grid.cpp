// TetGrid: a query finds exactly the live tets whose current box meets the query box, also after
// the tissue drifted (less than the rebuild limit) and after tets were replaced.
#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/tet_grid.hpp"

using namespace tissue_cut;

namespace {

std::vector<int> bruteForce(const TetMesh& mesh, const Vec3& lo, const Vec3& hi) {
  std::vector<int> out;
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    Vec3 tlo = mesh.current(mesh.tet(t)[0]), thi = tlo;
    for (int v : mesh.tet(t)) {
      tlo = tlo.cwiseMin(mesh.current(v));
      thi = thi.cwiseMax(mesh.current(v));
    }
    if ((tlo.array() <= hi.array()).all() && (thi.array() >= lo.array()).all()) out.push_back(t);
  }
  return out;
}

// Random thin boxes like one tick's sweep, some reaching outside the block.
void expectExactQueries(const TetMesh& mesh, const TetGrid& grid, std::mt19937* rng) {
  std::uniform_real_distribution<double> x(-0.06, 0.06), y(-0.04, 0.04), z(-0.01, 0.04),
      size(0.0, 0.01);
  for (int k = 0; k < 200; ++k) {
    const Vec3 lo(x(*rng), y(*rng), z(*rng));
    const Vec3 hi = lo + Vec3(size(*rng), size(*rng), 3 * size(*rng));
    const std::vector<int> found = grid.query(mesh, lo, hi);
    ASSERT_EQ(found, bruteForce(mesh, lo, hi)) << "query " << k;
  }
}

}  // namespace

TEST(TetGrid, QueriesAreExactAndInIdOrder) {
  const MeshData block = makeBlock();
  const TetMesh mesh(block.V, block.T);
  TetGrid grid;
  grid.build(mesh, 0.012, 0.006);
  std::mt19937 rng(7);
  expectExactQueries(mesh, grid, &rng);
  EXPECT_FALSE(grid.needsRebuild(mesh));
}

TEST(TetGrid, DriftBelowHalfTheMarginNeedsNoRebuildAndStaysExact) {
  const MeshData block = makeBlock();
  TetMesh mesh(block.V, block.T);
  const double margin = 0.006;
  TetGrid grid;
  grid.build(mesh, 0.012, margin);
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int v = 0; v < mesh.vertexSlots(); ++v) {
    Vec3 d(unit(rng), unit(rng), unit(rng));
    d *= 0.49 * margin / std::max(d.norm(), 1e-12);
    mesh.current(v) += d;
  }
  EXPECT_FALSE(grid.needsRebuild(mesh));
  expectExactQueries(mesh, grid, &rng);
  mesh.current(0) = mesh.rest(0) + Vec3(0.51 * margin, 0.0, 0.0);
  EXPECT_TRUE(grid.needsRebuild(mesh));
}

TEST(TetGrid, ReplacedTetsAreFoundAfterAnUpdate) {
  const MeshData block = makeBlock();
  TetMesh mesh(block.V, block.T);
  TetGrid grid;
  grid.build(mesh, 0.012, 0.006);
  // Split tet 100 at its centroid into four.
  ChangeRecord change;
  const TetVerts c = mesh.tet(100);
  const int m = mesh.addVertex({{c[0], 0.25}, {c[1], 0.25}, {c[2], 0.25}, {c[3], 0.25}}, &change);
  std::vector<TetVerts> add;
  for (int f = 0; f < 4; ++f) {
    TetVerts t = c;
    t[f] = m;
    add.push_back(t);
  }
  mesh.replaceTets({100}, add, &change);
  grid.update(mesh, change);
  std::mt19937 rng(3);
  expectExactQueries(mesh, grid, &rng);
  const Vec3 at = mesh.current(m);
  const std::vector<int> found = grid.query(mesh, at, at);
  for (int t : change.added_tets)
    EXPECT_TRUE(std::binary_search(found.begin(), found.end(), t)) << "new tet " << t;
}
