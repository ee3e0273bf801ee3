// On-the-fly edge collapse behind the cut: fewer, better tets, with the same topology and volume,
// never touching tets the blade is still inside.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/topology.hpp"
#include "tissue_cut/remesh/collapse_queue.hpp"
#include "tissue_cut/tissue.hpp"
#include "mesh_edits.hpp"

using namespace tissue_cut;

namespace {

Config withCollapse(bool collapse, double blade_length, double budget_us = 0.0) {
  Config c;
  c.physics.enabled = false;
  c.collapse.enabled = collapse;
  c.collapse.budget_us = budget_us;
  c.cut.blade_length = blade_length;
  return c;
}

ScalpelPath line(const Vec3& a, const Vec3& b, double seconds) {
  return ScalpelPath({ToolPose{0.0, a, Eigen::Quaterniond::Identity()},
                      ToolPose{seconds, b, Eigen::Quaterniond::Identity()}});
}

// Replays at 1 kHz, validating every tick, then lifts the blade and runs `settle_ticks` more.
std::string replay(Tissue& tissue, const ScalpelPath& path, int settle_ticks = 0) {
  const int ticks = static_cast<int>(std::ceil(path.endTime() / 1e-3));
  for (int k = 0; k <= ticks + 1 + settle_ticks; ++k) {
    std::optional<BladeSegment> blade;
    if (k <= ticks) {
      const ToolPose p = path.at(k * 1e-3);
      blade = bladeFromPose(p.position, p.orientation, tissue.config().cut.blade_length);
    }
    tissue.step(blade, 1e-3);
    const std::string err = tissue.validate();
    if (!err.empty()) return "tick " + std::to_string(k) + ": " + err;
  }
  return "";
}

struct Outcome {
  int pieces, euler, tets;
  double volume;
  Statistics stats;
};

Outcome run(bool collapse, const ScalpelPath& path, double blade_length) {
  Tissue tissue(withCollapse(collapse, blade_length), makeBlock());
  EXPECT_EQ(replay(tissue, path), "");
  return {countPieces(tissue.mesh()), boundaryEulerCharacteristic(tissue.mesh()),
          tissue.mesh().numTets(), tissue.mesh().restVolume(), tissue.statistics()};
}

}  // namespace

TEST(Collapse, SeveringCutKeepsItsTopologyAndVolumeWithFewerBetterTets) {
  const ScalpelPath path = line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.6);
  const Outcome plain = run(false, path, 0.06);
  const Outcome collapsed = run(true, path, 0.06);
  EXPECT_EQ(collapsed.pieces, plain.pieces);
  EXPECT_EQ(collapsed.euler, plain.euler);
  EXPECT_NEAR(collapsed.volume, plain.volume, 1e-3 * plain.volume);
  EXPECT_GT(collapsed.stats.collapse.collapsed_edges, 20);
  EXPECT_EQ(collapsed.tets, plain.tets - collapsed.stats.collapse.removed_tetrahedra);
  EXPECT_LT(collapsed.stats.region.tetrahedra, plain.stats.region.tetrahedra);
  EXPECT_GT(collapsed.stats.region.quality_mean, plain.stats.region.quality_mean);
  EXPECT_GE(collapsed.stats.region.quality_min, plain.stats.region.quality_min);
}

TEST(Collapse, CrackStoppingInsideKeepsItsTopology) {
  const ScalpelPath path = line({-0.07, 0.0021, 0.041}, {0.015, 0.0021, 0.041}, 0.6);
  const Outcome plain = run(false, path, 0.03);
  const Outcome collapsed = run(true, path, 0.03);
  EXPECT_EQ(collapsed.pieces, 1);
  EXPECT_EQ(collapsed.euler, plain.euler);
  EXPECT_NEAR(collapsed.volume, plain.volume, 1e-3 * plain.volume);
  EXPECT_GT(collapsed.stats.collapse.collapsed_edges, 10);
}

TEST(Collapse, ABudgetLeavesWorkQueuedForLaterTicks) {
  const ScalpelPath path = line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.3);
  // 20 us a tick is far less than the cut queues while the blade runs (measured: about 1,900
  // ticks of settling drain it, one queued tet a tick).
  Tissue tissue(withCollapse(true, 0.06, 20.0), makeBlock());
  ASSERT_EQ(replay(tissue, path), "");
  const int queued = tissue.statistics().collapse.pending;
  EXPECT_GT(queued, 0);
  for (int k = 0; k < 3000 && tissue.statistics().collapse.pending > 0; ++k)
    tissue.step(std::nullopt, 1e-3);  // settling: the queue is worked off
  ASSERT_EQ(tissue.validate(), "");
  EXPECT_EQ(tissue.statistics().collapse.pending, 0);
  EXPECT_GT(tissue.statistics().collapse.collapsed_edges, 0);
}

TEST(Collapse, LeavesTheTetsAroundTheBladeAlone) {
  // Stop with the blade inside: collapses happen behind it, none next to a pending tet (the mesh
  // is validated every tick, and the pending tets' own check sees their pieces intact).
  Tissue tissue(withCollapse(true, 0.03), makeBlock());
  const ScalpelPath path = line({-0.07, 0.0021, 0.041}, {0.02, 0.0021, 0.041}, 0.6);
  const int ticks = 600;
  for (int k = 0; k <= ticks; ++k) {
    const ToolPose p = path.at(k * 1e-3);
    tissue.step(bladeFromPose(p.position, p.orientation, 0.03), 1e-3);
    ASSERT_EQ(tissue.validate(), "") << "tick " << k;
  }
  EXPECT_TRUE(tissue.cutter().hasPending());
  EXPECT_GT(tissue.statistics().collapse.collapsed_edges, 0);
}

// A tet waiting for a busy neighbourhood is looked at again only when the caller says busy()
// may answer otherwise; then it is worked as usual.
TEST(Collapse, WaitingTetsWakeWhenTheBusyStateChanges) {
  const MeshData block = makeBlock();
  TetMesh mesh(block.V, block.T);
  // Split tet 100 at a point just off one face: four tets, three of them slivers.
  ChangeRecord change;
  const int m = test::splitAt(&mesh, 100, {0.32, 0.33, 0.33, 0.02}, &change);
  CollapseQueue queue(&mesh, 0.3, 0.0);
  auto created = [&](int t) {
    return std::find(change.added_tets.begin(), change.added_tets.end(), t) !=
           change.added_tets.end();
  };
  queue.queueFrom(change, created);
  const int queued = queue.pending();
  ASSERT_GT(queued, 0);
  bool blade_near = true;
  auto busy = [&](int v) { return blade_near && v == m; };
  ChangeRecord out;
  queue.process(busy, created, &out, true);
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(queue.pending(), queued);
  blade_near = false;
  queue.process(busy, created, &out, false);  // told nothing changed: the tets keep waiting
  EXPECT_TRUE(out.empty());
  EXPECT_EQ(queue.pending(), queued);
  queue.process(busy, created, &out, true);
  EXPECT_FALSE(out.empty()) << "the woken tets were worked";
  EXPECT_LT(queue.pending(), queued);
  EXPECT_EQ(mesh.validate(), "");
}

// A tet's work (collapse checks, flips, smoothing) can outlast the budget. Past it, a tet other
// than the tick's first stops between steps and goes back to the queue, the next tick's first
// to be worked: worked off over many ticks, the queue must end exactly where one worked off at
// once ends. The budget is measured on a clock that advances 10 us a reading, so that it ends
// inside tets' work at known places.
TEST(Collapse, ATetStoppedAtTheBudgetFinishesLaterAsIfUninterrupted) {
  const ScalpelPath path = line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.3);
  Tissue tissue(withCollapse(false, 0.06), makeBlock());
  ASSERT_EQ(replay(tissue, path), "");
  ChangeRecord all;  // every tet, as if the cut had just made it
  for (int t = 0; t < tissue.mesh().tetSlots(); ++t)
    if (tissue.mesh().tetAlive(t)) all.added_tets.push_back(t);
  auto everyTet = [](int) { return true; };
  auto noneBusy = [](int) { return false; };
  const double tau = tissue.config().collapse.tau;

  TetMesh at_once = tissue.mesh(), in_ticks = tissue.mesh();
  CollapseQueue once(&at_once, tau, 0.0);
  once.queueFrom(all, everyTet);
  ChangeRecord change;
  once.process(noneBusy, everyTet, &change);
  EXPECT_EQ(once.pending(), 0);

  CollapseQueue ticks(&in_ticks, tau, 35.0);
  double clock = 0.0;
  ticks.setBudgetClock([&] { return clock += 10.0; });
  ticks.queueFrom(all, everyTet);
  int calls = 0;
  for (; calls < 100000 && ticks.pending() > 0; ++calls) {
    ChangeRecord step;
    ticks.process(noneBusy, everyTet, &step);
  }
  std::printf("%d collapses, %d flips, %d smoothing moves; in %d ticks, %d tets stopped\n",
              once.counts().collapsed_edges, once.counts().flips, once.counts().smoothed_vertices,
              calls, ticks.counts().stopped);
  EXPECT_EQ(ticks.pending(), 0);
  EXPECT_GT(ticks.counts().stopped, 20);
  EXPECT_GT(once.counts().collapsed_edges + once.counts().smoothed_vertices, 20);
  EXPECT_EQ(ticks.counts().collapsed_edges, once.counts().collapsed_edges);
  EXPECT_EQ(ticks.counts().flips, once.counts().flips);
  EXPECT_EQ(ticks.counts().smoothed_vertices, once.counts().smoothed_vertices);
  ASSERT_EQ(in_ticks.validate(), "");
  ASSERT_EQ(in_ticks.tetSlots(), at_once.tetSlots());
  for (int t = 0; t < at_once.tetSlots(); ++t) {
    ASSERT_EQ(in_ticks.tetAlive(t), at_once.tetAlive(t)) << "tet " << t;
    if (at_once.tetAlive(t)) {
      ASSERT_EQ(in_ticks.tet(t), at_once.tet(t)) << "tet " << t;
    }
  }
  ASSERT_EQ(in_ticks.vertexSlots(), at_once.vertexSlots());
  for (int v = 0; v < at_once.vertexSlots(); ++v)
    if (at_once.vertexAlive(v)) {
      ASSERT_EQ(in_ticks.rest(v), at_once.rest(v)) << "vertex " << v;
    }
}
