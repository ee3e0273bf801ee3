// 2-3 and 3-2 flips (our extension to the paper's collapse): legal only where the new edge or
// face lies inside the tets replaced, taken only when the worst quality rises, and volume, shape
// and the simulation's masses stay as they were.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <vector>

#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/physics/mass_spring.hpp"
#include "tissue_cut/remesh/collapse_queue.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"
#include "tissue_cut/remesh/flips.hpp"

using namespace tissue_cut;

namespace {

// Triangle abc in the plane z = 0 (edge 1 m), d below and e above its inside at height h.
// Vertex ids: a 0, b 1, c 2, d 3, e 4, then `extra` points.
Eigen::MatrixXd points(double h, const Vec3& e_shift = Vec3::Zero(),
                       const std::vector<Vec3>& extra = {}) {
  std::vector<Vec3> p = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0.5, 0.866, 0),
                         Vec3(0.5, 0.29, -h), Vec3(0.5, 0.29, h) + e_shift};
  p.insert(p.end(), extra.begin(), extra.end());
  Eigen::MatrixXd V(p.size(), 3);
  for (std::size_t i = 0; i < p.size(); ++i) V.row(i) = p[i].transpose();
  return V;
}

Eigen::MatrixXi tets(const std::vector<TetVerts>& list) {
  Eigen::MatrixXi T(list.size(), 4);
  for (std::size_t i = 0; i < list.size(); ++i)
    for (int k = 0; k < 4; ++k) T(i, k) = list[i][k];
  return T;
}

// The pair abcd, abce sharing face abc (TetMesh orients them).
TetMesh pair(double h, const Vec3& e_shift = Vec3::Zero()) {
  return TetMesh(points(h, e_shift), tets({{0, 1, 2, 3}, {0, 1, 2, 4}}));
}

// The three tets around edge de.
TetMesh triple(double h) {
  return TetMesh(points(h), tets({{0, 1, 3, 4}, {1, 2, 3, 4}, {2, 0, 3, 4}}));
}

// Tet 0's face shared with tet 1.
int sharedFace(const TetMesh& mesh) {
  for (int f = 0; f < 4; ++f)
    if (mesh.neighbor(0, f) == 1) return f;
  return -1;
}

std::set<std::set<int>> tetSets(const TetMesh& mesh) {
  std::set<std::set<int>> out;
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t)) out.insert(std::set<int>(mesh.tet(t).begin(), mesh.tet(t).end()));
  return out;
}

double worst(const TetMesh& mesh) { return summarizeQuality(mesh).min; }

}  // namespace

TEST(Flips, TwoThreeFlipOfAFlatPairRaisesTheWorstQualityAndKeepsTheVolume) {
  TetMesh mesh = pair(0.1);  // two flat tets, Q 0.085 each
  const double volume = mesh.restVolume(), before = worst(mesh);
  FlipCandidate flip;
  ASSERT_TRUE(flip23(mesh, 0, sharedFace(mesh), 1e-3, &flip));
  EXPECT_EQ(flip.added.size(), 3u);
  EXPECT_NEAR(flip.worst_before, before, 1e-12);
  EXPECT_GT(flip.worst_after, 0.35);  // the three tets around de: 0.36
  ChangeRecord record;
  const std::vector<int> added = applyFlip(&mesh, flip, &record);
  EXPECT_EQ(added.size(), 3u);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_EQ(mesh.edgeTets(3, 4).size(), 3u);  // the new edge de
  EXPECT_NEAR(mesh.restVolume(), volume, 1e-12 * volume);
  EXPECT_NEAR(worst(mesh), flip.worst_after, 1e-12);
  EXPECT_EQ(record.removed_tets.size(), 2u);
  EXPECT_EQ(record.added_tets.size(), 3u);
  for (int from : record.added_from) EXPECT_EQ(from, -1);  // new elements
}

TEST(Flips, TwoThreeFlipIsRefusedWhereItCannotHelpOrWouldFold) {
  // A good pair (Q 0.86): the three tets would be worse.
  FlipCandidate flip;
  TetMesh good = pair(0.5);
  EXPECT_FALSE(flip23(good, 0, sharedFace(good), 1e-3, &flip));
  // de misses the triangle abc: one of the three tets would be inverted.
  TetMesh aside = pair(0.1, Vec3(1.5, 0, 0));
  EXPECT_FALSE(flip23(aside, 0, sharedFace(aside), -1.0, &flip));
  // A boundary face has nothing behind it.
  TetMesh flat = pair(0.1);
  for (int f = 0; f < 4; ++f)
    if (f != sharedFace(flat)) {
      EXPECT_FALSE(flip23(flat, 0, f, -1.0, &flip));
    }
  // de exists already (in a tet elsewhere): a flip would make a second one.
  TetMesh joined(points(0.1, Vec3::Zero(), {Vec3(3, 0, 0), Vec3(3, 1, 0.5)}),
                 tets({{0, 1, 2, 3}, {0, 1, 2, 4}, {3, 4, 5, 6}}));
  EXPECT_FALSE(flip23(joined, 0, sharedFace(joined), -1.0, &flip));
}

// The rest positions decide the quality, but no flip may fold a tet where the tissue is now: the
// pair above, sound and flippable at rest, with e carried in current positions to where de misses
// the triangle abc (as in `aside`), is not flipped. (soundQualityInMesh() tests the current
// corners only where they differ from the rest ones.)
TEST(Flips, TwoThreeFlipIsRefusedWhereItWouldFoldInCurrentPositions) {
  TetMesh mesh = pair(0.1);
  FlipCandidate flip;
  ASSERT_TRUE(flip23(mesh, 0, sharedFace(mesh), 1e-3, &flip));
  const TetVerts new_tet = flip.added[0];
  const double at_rest = soundQualityInMesh(mesh, new_tet);
  EXPECT_GT(at_rest, 0.0);
  EXPECT_EQ(at_rest, soundTetQuality(mesh.rest(new_tet[0]), mesh.rest(new_tet[1]),
                                     mesh.rest(new_tet[2]), mesh.rest(new_tet[3]),
                                     kMinCollapseRelativeVolume));
  mesh.current(4) += Vec3(1.5, 0, 0);
  EXPECT_FALSE(flip23(mesh, 0, sharedFace(mesh), 1e-3, &flip));
  int folded = 0;  // the three tets around de: at least one turned over where the tissue is
  for (const TetVerts& tv : {TetVerts{0, 1, 3, 4}, TetVerts{1, 2, 3, 4}, TetVerts{2, 0, 3, 4}}) {
    TetVerts positive = tv;
    if (signedVolume(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3])) < 0)
      std::swap(positive[0], positive[1]);
    folded += soundQualityInMesh(mesh, positive) < 0.0;
  }
  EXPECT_GT(folded, 0);
}

TEST(Flips, ThreeTwoFlipOfThreeNeedlesRaisesTheWorstQualityAndKeepsTheVolume) {
  TetMesh mesh = triple(1.5);  // three needles around a 3 m edge, Q 0.11
  ASSERT_EQ(mesh.validate(), "");
  const double volume = mesh.restVolume();
  FlipCandidate flip;
  ASSERT_TRUE(removeEdge(mesh, 3, 4, 1e-3, &flip));
  EXPECT_EQ(flip.added.size(), 2u);
  EXPECT_GT(flip.worst_after, 0.8);  // the pair: 0.83
  applyFlip(&mesh, flip, nullptr);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_TRUE(mesh.edgeTets(3, 4).empty());
  EXPECT_EQ(tetSets(mesh), (std::set<std::set<int>>{{0, 1, 2, 3}, {0, 1, 2, 4}}));
  EXPECT_NEAR(mesh.restVolume(), volume, 1e-12 * volume);
}

TEST(Flips, ThreeTwoFlipIsRefusedOnBoundaryEdgesAndWhereItCannotHelp) {
  FlipCandidate flip;
  TetMesh good = triple(0.3);  // the three tets (Q 0.66) beat the pair (0.52)
  EXPECT_FALSE(removeEdge(good, 3, 4, 1e-3, &flip));
  TetMesh needles = triple(1.5);
  EXPECT_FALSE(removeEdge(needles, 0, 1, -1.0, &flip));  // ab lies on the boundary
  EXPECT_FALSE(removeEdge(needles, 0, 3, -1.0, &flip));  // so does ad
}

// n needles around the edge from (0, 0, -h) (vertex 0) to (0, 0, h) (vertex 1), their ring on the
// unit circle (vertices 2 ...); `extra` tets (vertex ids) may be added elsewhere.
TetMesh needles(int n, double h, const std::vector<Vec3>& extra_points = {},
                const std::vector<TetVerts>& extra_tets = {}) {
  std::vector<Vec3> p = {Vec3(0, 0, -h), Vec3(0, 0, h)};
  for (int i = 0; i < n; ++i)
    p.push_back(Vec3(std::cos(2 * M_PI * i / n), std::sin(2 * M_PI * i / n), 0.0));
  p.insert(p.end(), extra_points.begin(), extra_points.end());
  Eigen::MatrixXd V(p.size(), 3);
  for (std::size_t i = 0; i < p.size(); ++i) V.row(i) = p[i].transpose();
  std::vector<TetVerts> list;
  for (int i = 0; i < n; ++i) list.push_back({0, 1, 2 + i, 2 + (i + 1) % n});
  list.insert(list.end(), extra_tets.begin(), extra_tets.end());
  return TetMesh(V, tets(list));
}

TEST(Flips, EdgeRemovalRetriangulatesRingsOfEveryLength) {
  // Up to 7 needles (Q 0.19-0.32) the ring's triangulation is clearly better (0.37-0.94); from 8
  // on the polygon's own triangles get thin too, and the removal is only checked for being legal.
  for (int n = 3; n <= kMaxEdgeRing; ++n) {
    TetMesh mesh = needles(n, 2.0);
    ASSERT_EQ(mesh.validate(), "") << n;
    const double volume = mesh.restVolume(), before = worst(mesh);
    FlipCandidate flip;
    ASSERT_TRUE(removeEdge(mesh, 0, 1, n <= 7 ? 0.05 : -1.0, &flip)) << n;
    EXPECT_EQ(static_cast<int>(flip.added.size()), 2 * n - 4) << n;
    if (n <= 7) {
      EXPECT_GT(flip.worst_after, before + 0.05) << n;
    }
    applyFlip(&mesh, flip, nullptr);
    EXPECT_EQ(mesh.validate(), "") << n;
    EXPECT_TRUE(mesh.edgeTets(0, 1).empty()) << n;
    EXPECT_NEAR(mesh.restVolume(), volume, 1e-12 * volume) << n;
    EXPECT_NEAR(worst(mesh), flip.worst_after, 1e-12) << n;
  }
  TetMesh too_long = needles(kMaxEdgeRing + 1, 2.0);
  FlipCandidate flip;
  EXPECT_FALSE(removeEdge(too_long, 0, 1, -1.0, &flip));
}

namespace {

// Every triangulation of the polygon ring[i..j] (as triangles of places in the ring).
std::vector<std::vector<std::array<int, 3>>> triangulations(int i, int j) {
  if (j - i < 2) return {{}};
  std::vector<std::vector<std::array<int, 3>>> out;
  for (int k = i + 1; k < j; ++k)
    for (const auto& left : triangulations(i, k))
      for (const auto& right : triangulations(k, j)) {
        std::vector<std::array<int, 3>> t = left;
        t.insert(t.end(), right.begin(), right.end());
        t.push_back({i, k, j});
        out.push_back(t);
      }
  return out;
}

// The rest Q of tet (p, q, r, s), or -1 when it is not sound (flat, or turned over).
double soundQ(const TetMesh& mesh, int p, int q, int r, int s) {
  return soundTetQuality(mesh.rest(p), mesh.rest(q), mesh.rest(r), mesh.rest(s),
                         kMinCollapseRelativeVolume);
}

}  // namespace

TEST(Flips, EdgeRemovalFindsTheBestOfAllTriangulations) {
  // Jittered rings of 4 to 9 tets around an interior edge: removeEdge must take a flip exactly
  // when the best triangulation of the ring (every one enumerated here, not by the programme)
  // raises the worst Q by min_gain, and then with that best worst Q. The gains include ones a
  // hair either side of what the best reaches, where a shortcut that misjudged a candidate
  // would answer the other way.
  std::srand(3);
  auto uniform = [] { return std::rand() / static_cast<double>(RAND_MAX); };
  int taken = 0, refused = 0;
  for (int trial = 0; trial < 400; ++trial) {
    const int n = 4 + trial % 6;
    const double h = 0.3 + 2.5 * uniform();
    std::vector<Vec3> p = {Vec3(0, 0, -h), Vec3(0, 0, h)};
    for (int i = 0; i < n; ++i) {
      const double angle = 2 * M_PI * (i + 0.35 * (uniform() - 0.5)) / n;
      const double radius = 0.6 + 0.8 * uniform();
      p.push_back(Vec3(radius * std::cos(angle), radius * std::sin(angle),
                       0.6 * h * (uniform() - 0.5)));
    }
    Eigen::MatrixXd V(p.size(), 3);
    for (std::size_t i = 0; i < p.size(); ++i) V.row(i) = p[i].transpose();
    std::vector<TetVerts> list;
    for (int i = 0; i < n; ++i) list.push_back({0, 1, 2 + i, 2 + (i + 1) % n});
    TetMesh mesh(V, tets(list));
    ASSERT_EQ(mesh.validate(), "") << trial;
    double before = 1.0;
    for (int t = 0; t < n; ++t) before = std::min(before, restQuality(mesh, t));
    // The ring counter-clockwise seen from vertex 1: triangle (i, k, j), i < k < j, makes the
    // tets (r_i, r_k, r_j, 1) and (r_i, r_j, r_k, 0), each of which must be sound.
    std::vector<int> ring;
    for (int i = 0; i < n; ++i) ring.push_back(2 + i);
    if (signedVolume(mesh.rest(0), mesh.rest(1), mesh.rest(ring[0]), mesh.rest(ring[1])) < 0)
      std::reverse(ring.begin(), ring.end());
    double best = -1.0;
    for (const auto& triangulation : triangulations(0, n - 1)) {
      double worst_q = 1.0;
      for (const auto& tri : triangulation) {
        const int a = ring[tri[0]], b = ring[tri[1]], c = ring[tri[2]];
        worst_q = std::min({worst_q, soundQ(mesh, a, b, c, 1), soundQ(mesh, a, c, b, 0)});
      }
      best = std::max(best, worst_q);
    }
    for (const double gain : {-1.0, 0.02, best - before - 1e-9, best - before + 1e-9}) {
      FlipCandidate flip;
      const bool found = removeEdge(mesh, 0, 1, gain, &flip);
      ASSERT_EQ(found, best >= 0.0 && best >= before + gain)
          << "trial " << trial << " n " << n << " gain " << gain << " best " << best;
      if (!found) {
        ++refused;
        continue;
      }
      ++taken;
      EXPECT_EQ(static_cast<int>(flip.added.size()), 2 * n - 4);
      EXPECT_DOUBLE_EQ(flip.worst_after, best) << "trial " << trial;
    }
  }
  EXPECT_GT(taken, 400);
  EXPECT_GT(refused, 400);
}

TEST(Flips, EdgeRemovalUsesNoChordThatIsAnEdgeAlready) {
  // A square ring: its two diagonals are the only ways to triangulate it. A tet far away that
  // holds ring vertices 2 and 4 (one diagonal) leaves only the other, 3-5.
  const std::vector<Vec3> far = {Vec3(5, 0, 0), Vec3(5, 1, 1)};
  TetMesh mesh = needles(4, 2.0, far, {{2, 4, 6, 7}});
  FlipCandidate flip;
  ASSERT_TRUE(removeEdge(mesh, 0, 1, 1e-3, &flip));
  applyFlip(&mesh, flip, nullptr);
  EXPECT_EQ(mesh.edgeTets(2, 4).size(), 1u);  // only the far tet
  EXPECT_EQ(mesh.edgeTets(3, 5).size(), 4u);
  // Both diagonals taken: no triangulation is left.
  TetMesh blocked = needles(4, 2.0, {Vec3(5, 0, 0), Vec3(5, 1, 1), Vec3(6, 0, 0), Vec3(6, 1, 1)},
                            {{2, 4, 6, 7}, {3, 5, 8, 9}});
  EXPECT_FALSE(removeEdge(blocked, 0, 1, -1.0, &flip));
}

TEST(Flips, NewEdgesNeedTheCallersConsent) {
  FlipCandidate flip;
  TetMesh flat = pair(0.1);
  auto never = [](int, int) { return false; };
  EXPECT_FALSE(flip23(flat, 0, sharedFace(flat), 1e-3, &flip, never));  // de refused
  EXPECT_TRUE(flip23(flat, 0, sharedFace(flat), 1e-3, &flip, [](int u, int v) {
    return std::min(u, v) == 3 && std::max(u, v) == 4;
  }));
  // Three needles: no chord is needed; a square ring needs one of its diagonals.
  TetMesh three = needles(3, 2.0), four = needles(4, 2.0);
  EXPECT_TRUE(removeEdge(three, 0, 1, 1e-3, &flip, never));
  EXPECT_FALSE(removeEdge(four, 0, 1, 1e-3, &flip, never));
  auto only35 = [](int u, int v) { return std::min(u, v) == 3 && std::max(u, v) == 5; };
  ASSERT_TRUE(removeEdge(four, 0, 1, 1e-3, &flip, only35));
  applyFlip(&four, flip, nullptr);
  EXPECT_TRUE(four.edgeTets(2, 4).empty());
  EXPECT_EQ(four.edgeTets(3, 5).size(), 4u);
}

TEST(Flips, TwoTwoFlipSwapsTheDiagonalOfAFlatBoundaryPair) {
  // Square a (0,0,0), c (1,0,0), b (1,1,0), d (0,1,0) on the bottom face, split along ab, under
  // an apex x at (0.1, 0.9, 0.7) above d's corner: the pair over diagonal cd is better (worst Q
  // 0.62 -> 0.74).
  Eigen::MatrixXd V(5, 3);
  V << 0, 0, 0, 1, 1, 0, 1, 0, 0, 0, 1, 0, 0.1, 0.9, 0.7;
  TetMesh mesh(V, tets({{0, 1, 2, 4}, {0, 1, 3, 4}}));
  ASSERT_EQ(mesh.validate(), "");
  const double volume = mesh.restVolume();
  FlipCandidate flip;
  ASSERT_TRUE(flip22(mesh, 0, 1, 0.0, 1e-3, &flip));
  EXPECT_NEAR(flip.worst_after, 0.739, 1e-3);
  EXPECT_NEAR(flip.volume_change, 0.0, 1e-15);
  applyFlip(&mesh, flip, nullptr);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_TRUE(mesh.edgeTets(0, 1).empty());
  EXPECT_EQ(mesh.edgeTets(2, 3).size(), 2u);
  EXPECT_NEAR(mesh.restVolume(), volume, 1e-12 * volume);
  // Bent by 0.05 (5% of the longest edge): refused at 1% tolerance, taken at 8% with the volume
  // it changes.
  V(3, 2) = 0.05;
  TetMesh bent(V, tets({{0, 1, 2, 4}, {0, 1, 3, 4}}));
  EXPECT_FALSE(flip22(bent, 0, 1, 0.01, 1e-3, &flip));
  ASSERT_TRUE(flip22(bent, 0, 1, 0.08, 1e-3, &flip));
  const double bent_volume = bent.restVolume();
  applyFlip(&bent, flip, nullptr);
  EXPECT_NEAR(bent.restVolume() - bent_volume, flip.volume_change, 1e-15);
  EXPECT_GT(std::abs(flip.volume_change), 1e-4);
  // An interior edge, or an edge of three tets, is no 2-2 flip.
  TetMesh ring = needles(4, 2.0);
  EXPECT_FALSE(flip22(ring, 0, 1, 1.0, -1.0, &flip));
}

TEST(Flips, TwoThreeThenThreeTwoGivesBackThePair) {
  TetMesh mesh = pair(0.1);
  const std::set<std::set<int>> original = tetSets(mesh);
  FlipCandidate flip;
  ASSERT_TRUE(flip23(mesh, 0, sharedFace(mesh), 1e-3, &flip));
  applyFlip(&mesh, flip, nullptr);
  ASSERT_FALSE(removeEdge(mesh, 3, 4, 1e-3, &flip));  // no way back uphill: flips cannot cycle
  ASSERT_TRUE(removeEdge(mesh, 3, 4, -1.0, &flip));
  applyFlip(&mesh, flip, nullptr);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_EQ(tetSets(mesh), original);
}

TEST(Flips, MassesFollowAFlip) {
  TetMesh mesh = pair(0.1);
  MassSpringParams params;
  params.fixed_band = 0.0;
  MassSpring physics(&mesh, params);
  const double mass = physics.totalMass();
  FlipCandidate flip;
  ASSERT_TRUE(flip23(mesh, 0, sharedFace(mesh), 1e-3, &flip));
  ChangeRecord record;
  applyFlip(&mesh, flip, &record);
  physics.follow(record);
  EXPECT_NEAR(physics.totalMass(), mass, 1e-12 * mass);
  // Each vertex holds what a model built on the flipped mesh gives it, and the new edge de has
  // its spring: 9 edges before and 10 after.
  TetMesh fresh(points(0.1), mesh.liveTets());
  MassSpring rebuilt(&fresh, params);
  for (int v = 0; v < 5; ++v) EXPECT_NEAR(physics.mass(v), rebuilt.mass(v), 1e-12 * mass);
  EXPECT_EQ(physics.numSprings(), rebuilt.numSprings());
  EXPECT_EQ(physics.numSprings(), 10);
}

TEST(Flips, TheQueueFlipsOnlyTetsMadeByCutsAndCountsIt) {
  auto run = [](bool flips, bool all_cut, CollapseCounts* counts) {
    TetMesh mesh = pair(0.1);
    ChangeRecord all;
    for (int t = 0; t < mesh.tetSlots(); ++t) all.added_tets.push_back(t);
    CollapseQueue queue(&mesh, 0.6, 0.0);
    queue.setFlips(flips);
    // Tet 1 counts as original tissue unless all_cut.
    auto created = [&](int t) { return all_cut || t != 1; };
    queue.queueFrom(all, created);
    ChangeRecord change;
    queue.process([](int) { return false; }, created, &change);
    EXPECT_EQ(mesh.validate(), "");
    *counts = queue.counts();
    return mesh.liveTets().rows();
  };
  CollapseCounts counts;
  // Every vertex is a corner of the boundary, so nothing collapses or moves; a flip helps.
  EXPECT_EQ(run(true, true, &counts), 3);
  EXPECT_EQ(counts.flips, 1);
  EXPECT_EQ(counts.collapsed_edges, 0);
  EXPECT_EQ(run(false, true, &counts), 2);
  EXPECT_EQ(counts.flips, 0);
  EXPECT_EQ(run(true, false, &counts), 2);  // tet 1 is not the cut's to re-make
  EXPECT_EQ(counts.flips, 0);
}
