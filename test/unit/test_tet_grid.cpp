// TetGrid: a query finds exactly the live tets whose current box meets the query box, also after
// the tissue drifted (less than the rebuild limit) and after tets were replaced.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <utility>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/tet_grid.hpp"
#include "mesh_edits.hpp"

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

// Moves every vertex by `distance` in a random direction.
void drift(TetMesh* mesh, double distance, std::mt19937* rng) {
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  for (int v = 0; v < mesh->vertexSlots(); ++v) {
    Vec3 d(unit(*rng), unit(*rng), unit(*rng));
    d *= distance / std::max(d.norm(), 1e-12);
    mesh->current(v) += d;
  }
}

// The built-in block with a grid over it (12 mm cells, a margin of 6 mm), as the tests use it.
struct BlockGrid {
  static constexpr double kMargin = 0.006;
  MeshData block = makeBlock();
  TetMesh mesh{block.V, block.T};
  TetGrid grid;
  BlockGrid() { grid.build(mesh, 0.012, kMargin); }
};

// A box the cutter would keep the grid's candidates for (TetGrid::candidates), and those.
const Vec3 kKeptLo(-0.03, -0.02, 0.0), kKeptHi(0.03, 0.02, 0.03);
std::vector<int> keptCandidates(const BlockGrid& g) {
  std::vector<int> kept;
  g.grid.candidates(g.mesh, kKeptLo, kKeptHi, &kept);
  return kept;
}

// A random box inside [lo, hi].
std::pair<Vec3, Vec3> boxInside(const Vec3& lo, const Vec3& hi, std::mt19937* rng) {
  std::uniform_real_distribution<double> in(0.0, 1.0);
  Vec3 a, b;
  for (int d = 0; d < 3; ++d) {
    const double x = lo[d] + in(*rng) * (hi[d] - lo[d]), y = lo[d] + in(*rng) * (hi[d] - lo[d]);
    a[d] = std::min(x, y);
    b[d] = std::max(x, y);
  }
  return {a, b};
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
  const BlockGrid g;
  const TetMesh& mesh = g.mesh;
  const TetGrid& grid = g.grid;
  std::mt19937 rng(7);
  expectExactQueries(mesh, grid, &rng);
  EXPECT_FALSE(grid.needsRebuild(mesh));
}

// Tets are filed under their vertices' filed positions: every vertex may drift up to the whole
// margin (each its own way) before a box can have moved further than a query looks.
TEST(TetGrid, DriftBelowTheMarginNeedsNoRebuildAndStaysExact) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  const double margin = BlockGrid::kMargin;
  std::mt19937 rng(11);
  drift(&mesh, 0.99 * margin, &rng);
  EXPECT_FALSE(grid.needsRebuild(mesh));
  expectExactQueries(mesh, grid, &rng);
  mesh.current(0) = mesh.rest(0) + Vec3(1.01 * margin, 0.0, 0.0);
  EXPECT_TRUE(grid.needsRebuild(mesh));
}

TEST(TetGrid, ReplacedTetsAreFoundAfterAnUpdate) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  // Split tet 100 at its centroid into four.
  ChangeRecord change;
  const int m = test::splitAt(&mesh, 100, {0.25, 0.25, 0.25, 0.25}, &change);
  grid.update(mesh, change);
  std::mt19937 rng(3);
  expectExactQueries(mesh, grid, &rng);
  const Vec3 at = mesh.current(m);
  const std::vector<int> found = grid.query(mesh, at, at);
  for (int t : change.added_tets)
    EXPECT_TRUE(std::binary_search(found.begin(), found.end(), t)) << "new tet " << t;
}

// A tet replaced by itself takes its own slot back, spanning the same cells: the entries it has
// there serve, and the grid does not fill with copies of them (each replacement had added the
// tet's entries again: some ten thousand made the grid ask for a rebuild). Queries stay exact.
TEST(TetGrid, ATetReplacedInItsOwnCellsAddsNoEntries) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  const int t = 100;
  for (int k = 0; k < 40000; ++k) {
    ChangeRecord change;
    mesh.replaceTets({t}, {mesh.tet(t)}, &change);
    ASSERT_EQ(change.added_tets, std::vector<int>{t}) << "replacement " << k;
    grid.update(mesh, change);
  }
  EXPECT_FALSE(grid.cluttered());
  EXPECT_FALSE(grid.needsRebuild(mesh));
  std::mt19937 rng(11);
  expectExactQueries(mesh, grid, &rng);
}

// What the cutter keeps between ticks: the candidates of a box hold every tet a query of a box
// inside it returns, after drift below the rebuild limit too; a tet filed later joins them when
// filedNear says so, and a query filtered from them equals the grid's.
TEST(TetGrid, CandidatesHoldEveryQueryInsideTheirBox) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  const double margin = BlockGrid::kMargin;
  std::vector<int> kept = keptCandidates(g);
  ASSERT_TRUE(std::is_sorted(kept.begin(), kept.end()));
  ASSERT_EQ(std::adjacent_find(kept.begin(), kept.end()), kept.end()) << "each tet once";
  // Far fewer than all: the candidates are local.
  EXPECT_LT(kept.size(), static_cast<std::size_t>(mesh.numTets()));
  std::mt19937 rng(5);
  drift(&mesh, 0.99 * margin, &rng);
  ASSERT_FALSE(grid.needsRebuild(mesh));
  // Split a tet inside the box; its pieces are filed and join the candidates.
  ChangeRecord change;
  const std::vector<int> inside = grid.query(mesh, Vec3::Zero(), Vec3::Zero());
  ASSERT_FALSE(inside.empty());
  test::splitAt(&mesh, inside.front(), {0.25, 0.25, 0.25, 0.25}, &change);
  grid.update(mesh, change);
  int joined = 0;
  for (int t : change.added_tets)
    if (grid.filedNear(mesh, t, kKeptLo, kKeptHi)) {
      kept.insert(std::lower_bound(kept.begin(), kept.end(), t), t);
      ++joined;
    }
  EXPECT_EQ(joined, 4);
  EXPECT_FALSE(grid.filedNear(mesh, change.added_tets[0], Vec3(1, 1, 1), Vec3(2, 2, 2)));
  // Asked for many tets at once, it answers as for each alone: near and far ones, a dead slot.
  std::vector<int> asked = change.added_tets;
  asked.insert(asked.end(), change.removed_tets.begin(), change.removed_tets.end());
  for (int t = 0; t < mesh.tetSlots(); t += 7) asked.push_back(t);
  auto nearAtOnce = [&](const Vec3& lo, const Vec3& hi) {
    std::vector<unsigned char> near;
    grid.filedNear(mesh, asked, lo, hi, &near);
    EXPECT_EQ(near.size(), asked.size());
    int yes = 0;
    for (std::size_t i = 0; i < asked.size() && i < near.size(); ++i) {
      EXPECT_EQ(near[i] != 0, grid.filedNear(mesh, asked[i], lo, hi)) << "tet " << asked[i];
      yes += near[i];
    }
    return yes;
  };
  EXPECT_GE(nearAtOnce(kKeptLo, kKeptHi), 4);
  EXPECT_LT(nearAtOnce(Vec3(1, 1, 1), Vec3(2, 2, 2)), static_cast<int>(asked.size()));
  kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
  for (int k = 0; k < 200; ++k) {
    const auto [lo, hi] = boxInside(kKeptLo, kKeptHi, &rng);
    const std::vector<int> found = grid.query(mesh, lo, hi);
    ASSERT_EQ(found, bruteForce(mesh, lo, hi)) << "query " << k;
    std::vector<int> filtered;
    for (int t : kept) {
      if (!mesh.tetAlive(t)) continue;
      if (std::binary_search(found.begin(), found.end(), t)) filtered.push_back(t);
    }
    ASSERT_EQ(filtered, found) << "query " << k << ": a tet the grid finds is not a candidate";
  }
}

// The tissue sagging far past the margin, up to 1.5 margins a tick: refresh() files anew the tets
// around the vertices that drifted, and the queries after it stay exact without a rebuild; old
// entries go, so the index does not grow; the refiled tets that come near a kept box join its
// candidates.
TEST(TetGrid, RefreshFollowsDriftFarPastTheMarginWithoutARebuild) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  const double margin = BlockGrid::kMargin;
  std::vector<int> kept = keptCandidates(g);
  std::mt19937 rng(13);
  std::vector<int> refiled;
  std::size_t total_refiled = 0;
  for (int tick = 0; tick < 40; ++tick) {
    // A sag growing with height (up to 1.5 margins a tick at the top) and a sway.
    for (int v = 0; v < mesh.vertexSlots(); ++v) {
      const double h = (mesh.rest(v).z() + 0.01) / 0.04;
      mesh.current(v) += Vec3(0.3 * margin * std::sin(0.3 * tick), 0.0, -1.5 * margin * h);
    }
    refiled.clear();
    grid.refresh(mesh, HUGE_VAL, &refiled);
    // Each once, in increasing order (sorted when few, read off the slots when many).
    EXPECT_TRUE(std::adjacent_find(refiled.begin(), refiled.end(), std::greater_equal<int>()) ==
                refiled.end())
        << "tick " << tick;
    total_refiled += refiled.size();
    for (int t : refiled)
      if (grid.filedNear(mesh, t, kKeptLo, kKeptHi)) kept.push_back(t);
    std::sort(kept.begin(), kept.end());
    kept.erase(std::unique(kept.begin(), kept.end()), kept.end());
    EXPECT_FALSE(grid.needsRebuild(mesh)) << "tick " << tick;
    expectExactQueries(mesh, grid, &rng);
    // What the cutter keeps: every query inside the kept box is among the candidates.
    const Vec3 low(-0.01, -0.01, -0.05), high(0.01, 0.01, 0.0);  // where the top sags to
    ASSERT_EQ(grid.query(mesh, low, high), bruteForce(mesh, low, high)) << "tick " << tick;
  }
  // The top moved 60 margins: everything there was refiled many times, the index did not grow.
  EXPECT_GT(total_refiled, static_cast<std::size_t>(mesh.numTets()));
  EXPECT_FALSE(grid.cluttered());
  for (int k = 0; k < 100; ++k) {
    const auto [lo, hi] = boxInside(kKeptLo, kKeptHi, &rng);
    const std::vector<int> found = grid.query(mesh, lo, hi);
    for (int t : found)
      ASSERT_TRUE(std::binary_search(kept.begin(), kept.end(), t))
          << "query " << k << ": tet " << t << " is not a candidate";
  }
}

// Told how far the tissue moved each tick, refresh() looks at the vertices only when the moves
// add up to the margin, and the queries stay exact.
TEST(TetGrid, RefreshToldTheMotionScansOnlyWhenTheMovesAddUp) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  TetGrid& grid = g.grid;
  const double margin = BlockGrid::kMargin;
  std::mt19937 rng(17);
  std::vector<int> refiled;
  // Nothing moved: nothing to do.
  grid.refresh(mesh, 0.0, &refiled);
  EXPECT_TRUE(refiled.empty());
  int ticks_with_refiles = 0;
  for (int tick = 0; tick < 60; ++tick) {
    // Everything moves 0.1 of the margin a tick, along a slowly turning direction.
    const Vec3 step = 0.1 * margin * Vec3(std::cos(0.05 * tick), 0.0, -std::sin(0.05 * tick));
    for (int v = 0; v < mesh.vertexSlots(); ++v) mesh.current(v) += step;
    refiled.clear();
    grid.refresh(mesh, step.norm(), &refiled);
    if (!refiled.empty()) ++ticks_with_refiles;
    expectExactQueries(mesh, grid, &rng);
  }
  // Six margins in all, refiled about every ten ticks (the margin each time).
  EXPECT_GE(ticks_with_refiles, 4);
  EXPECT_LE(ticks_with_refiles, 7);
  // It trusts the bound: told nothing moved, it does not look (the caller's promise broken here
  // on purpose); told the move, it finds every vertex; a bound that is not known (NaN) looks too.
  // (Two and a half margins: more than the margin past what is left of the drift since each
  // vertex was last filed, whichever way that points.)
  for (int v = 0; v < mesh.vertexSlots(); ++v) mesh.current(v) += Vec3(2.5 * margin, 0.0, 0.0);
  refiled.clear();
  grid.refresh(mesh, 0.0, &refiled);
  EXPECT_TRUE(refiled.empty());
  grid.refresh(mesh, 2.5 * margin, &refiled);
  EXPECT_EQ(refiled.size(), static_cast<std::size_t>(mesh.numTets()));
  expectExactQueries(mesh, grid, &rng);
  for (int v = 0; v < mesh.vertexSlots(); ++v) mesh.current(v) += Vec3(2.5 * margin, 0.0, 0.0);
  refiled.clear();
  grid.refresh(mesh, std::nan(""), &refiled);
  EXPECT_EQ(refiled.size(), static_cast<std::size_t>(mesh.numTets()));
  expectExactQueries(mesh, grid, &rng);
}

// A few vertices drifting alone: refresh() refiles exactly their tets, each once, in increasing
// order (the few sorted; a whole tissue's worth is read off the slots, above), and the queries
// stay exact.
TEST(TetGrid, RefreshRefilesTheTetsOfTheVerticesThatDriftedInOrder) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  std::mt19937 rng(19);
  std::vector<int> moved;
  for (int v = 0; v < mesh.vertexSlots(); v += mesh.vertexSlots() / 3 + 1)
    if (mesh.vertexAlive(v)) moved.push_back(v);
  ASSERT_GE(moved.size(), 2u);
  std::vector<int> expected;
  for (int v : moved) {
    mesh.current(v) += Vec3(0.0, 1.2 * BlockGrid::kMargin, 0.0);
    for (int t : mesh.vertexTets(v)) expected.push_back(t);
  }
  std::sort(expected.begin(), expected.end());
  expected.erase(std::unique(expected.begin(), expected.end()), expected.end());
  std::vector<int> refiled;
  g.grid.refresh(mesh, HUGE_VAL, &refiled);
  EXPECT_EQ(refiled, expected);
  expectExactQueries(mesh, g.grid, &rng);
}

// A change that moves a vertex (as a smoothing move does) past the margin, naming only some of its
// tets: update() files the vertex where it is now with all its tets, reports the ones the change
// did not add, and the queries and the kept candidates stay exact.
TEST(TetGrid, AVertexAChangeMovedIsFiledAnewWithAllItsTets) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  std::vector<int> kept = keptCandidates(g);
  // An inner vertex near the middle, moved three margins up (its tets stay sound enough for
  // boxes: the grid does not look at orientation).
  int v = -1;
  for (int u = 0; u < mesh.vertexSlots() && v < 0; ++u)
    if (mesh.vertexAlive(u) && mesh.current(u).norm() < 0.01 && mesh.vertexTets(u).size() >= 8)
      v = u;
  ASSERT_GE(v, 0);
  const std::vector<int> star(mesh.vertexTets(v).begin(), mesh.vertexTets(v).end());
  mesh.current(v) += Vec3(0.0, 0.0, 3.0 * BlockGrid::kMargin);
  // The change replaces one tet of its star by the same tet (in a new slot, or the same).
  ChangeRecord change;
  mesh.replaceTets({star.front()}, {mesh.tet(star.front())}, &change);
  ASSERT_EQ(change.added_tets.size(), 1u);
  std::vector<int> refiled;
  g.grid.update(mesh, change, &refiled);
  std::sort(refiled.begin(), refiled.end());
  refiled.erase(std::unique(refiled.begin(), refiled.end()), refiled.end());
  std::vector<int> others(mesh.vertexTets(v).begin(), mesh.vertexTets(v).end());
  std::sort(others.begin(), others.end());
  for (int t : others) {
    if (t == change.added_tets.front()) continue;
    EXPECT_TRUE(std::binary_search(refiled.begin(), refiled.end(), t)) << "tet " << t;
  }
  EXPECT_FALSE(g.grid.needsRebuild(mesh));
  std::mt19937 rng(23);
  expectExactQueries(mesh, g.grid, &rng);
  // Around where the vertex went: every tet a query finds is among the kept candidates, once
  // those the change added or refiled near the kept box joined them (as the cutter does).
  for (int t : change.added_tets)
    if (g.grid.filedNear(mesh, t, kKeptLo, kKeptHi)) kept.push_back(t);
  for (int t : refiled)
    if (g.grid.filedNear(mesh, t, kKeptLo, kKeptHi)) kept.push_back(t);
  std::sort(kept.begin(), kept.end());
  const Vec3 at = mesh.current(v);
  const std::vector<int> found = g.grid.query(mesh, at, at);
  EXPECT_EQ(found, bruteForce(mesh, at, at));
  EXPECT_GE(found.size(), others.size());
  for (int t : found) EXPECT_TRUE(std::binary_search(kept.begin(), kept.end(), t)) << "tet " << t;
}

// A tet is filed under where its vertices were filed, not where they are when it is refiled: a
// vertex that drifted almost the margin one way (not refiled) while a neighbour's drift refiled
// their tets, then almost the margin the other way, leaves its tets' boxes within the margin of
// their filed ones. (Filed under the positions at the refile, the box would be almost two margins
// off and a query at the vertex would miss the tet.)
TEST(TetGrid, TetsAreFiledWhereTheirVerticesWereFiled) {
  BlockGrid g;
  TetMesh& mesh = g.mesh;
  const double margin = 0.0005;  // far below the block's edges
  TetGrid grid;
  grid.build(mesh, 0.012, margin);
  // A tet with one vertex lowest by more than the margin, and another of its vertices.
  int tet = -1, low = -1, other = -1;
  for (int t = 0; t < mesh.tetSlots() && tet < 0; ++t) {
    if (!mesh.tetAlive(t)) continue;
    const TetVerts& tv = mesh.tet(t);
    for (int i = 0; i < 4 && tet < 0; ++i) {
      bool lowest = true;
      for (int j = 0; j < 4; ++j)
        if (j != i && !(mesh.current(tv[j]).z() > mesh.current(tv[i]).z() + 2 * margin))
          lowest = false;
      if (lowest) {
        tet = t;
        low = tv[i];
        other = tv[(i + 1) % 4];
      }
    }
  }
  ASSERT_GE(tet, 0);
  std::vector<int> refiled;
  mesh.current(low) += Vec3(0.0, 0.0, 0.9 * margin);
  mesh.current(other) += Vec3(1.1 * margin, 0.0, 0.0);
  grid.refresh(mesh, HUGE_VAL, &refiled);
  ASSERT_TRUE(std::binary_search(refiled.begin(), refiled.end(), tet));  // through `other`
  mesh.current(low) -= Vec3(0.0, 0.0, 1.8 * margin);
  refiled.clear();
  grid.refresh(mesh, HUGE_VAL, &refiled);
  EXPECT_TRUE(refiled.empty()) << "no vertex is past the margin";
  EXPECT_FALSE(grid.needsRebuild(mesh));
  const Vec3 at = mesh.current(low);
  const std::vector<int> found = grid.query(mesh, at, at);
  EXPECT_TRUE(std::binary_search(found.begin(), found.end(), tet));
  EXPECT_EQ(found, bruteForce(mesh, at, at));
  std::mt19937 rng(29);
  expectExactQueries(mesh, grid, &rng);
}
