// A running model's ticks that change no tet take nothing from the heap: the node runs them at 1
// kHz beside a haptic loop, where an allocation can wait on a lock the allocator holds for another
// thread. This binary links src/tools/heap_count.cpp, which replaces operator new with one that
// counts.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <optional>
#include <string>
#include <vector>

#include "heap_count.hpp"
#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/cut/split_table.hpp"
#include "tissue_cut/tissue.hpp"

using namespace tissue_cut;

namespace {

// The allocations `ticks` ticks make with the blade at `blade` (none: away).
long long allocationsOver(Tissue* tissue, int ticks, const std::optional<BladeSegment>& blade) {
  const double dt = 1.0 / tissue->config().rate;
  const long long before = heapAllocations();
  for (int k = 0; k < ticks; ++k) {
    const std::string warning = tissue->step(blade, dt);
    if (!warning.empty()) ADD_FAILURE() << "tick " << k << ": " << warning;
  }
  return heapAllocations() - before;
}

// The blade 30 mm long, upright, its tip `height` [m] above the block's floor at (x, y) [m].
BladeSegment upright(double x, double y, double height) {
  return {Vec3(x, y, height + 0.03), Vec3(x, y, height)};
}

// A tet (corners 0-3) and the points a cut left on it, positions by global id.
struct CutTet {
  std::vector<Vec3> pos{{0, 0, 0}, {1, 0, 0}, {0.2, 1, 0}, {0.3, 0.3, 1}};
  TetCut cut;
  CutTet() { cut.corner = {0, 1, 2, 3}; }
  int add(const Vec3& p) {
    pos.push_back(p);
    return static_cast<int>(pos.size()) - 1;
  }
  void edgePoint(int e) {
    cut.edge_point[e] = add(0.5 * (pos[kTetEdge[e][0]] + pos[kTetEdge[e][1]]));
  }
  void facePoint(int f) {
    cut.face_point[f] =
        add((pos[kTetFace[f][0]] + pos[kTetFace[f][1]] + pos[kTetFace[f][2]]) / 3.0);
  }
};

}  // namespace

// Without this, the tests below would pass with a counter that never counts.
TEST(Allocations, TheCounterCountsThisBinarysAllocations) {
  const long long before = heapAllocations();
  auto* v = new std::vector<int>(1000, 7);
  const long long after = heapAllocations();
  EXPECT_GE(after - before, 2);  // the vector and its elements
  delete v;
}

// Once the first steps have sized the step's buffers, a step with the blade away, or above the
// tissue, allocates nothing: on one thread and on two, with either integrator. The blade's first
// ticks over the tissue size the cutter's search lists and its first pass over a stretch sizes
// them for that stretch (each list grows to the most it held, as std::vector does); the ticks
// after allocate nothing. (Every step had allocated twice: two of the implicit step's loops went
// to the worker team as a std::function too small for their lambdas' captures; and every tick
// the blade moved near the tissue, three times: the sweep's and its fronts' segment lists.)
TEST(Allocations, StepsThatChangeNoTetAllocateNothingOnceRunning) {
  for (const char* integrator : {"implicit", "semi_implicit"})
    for (int threads : {1, 2}) {
      SCOPED_TRACE(std::string(integrator) + ", threads " + std::to_string(threads));
      Config config;
      config.physics.integrator = integrator;
      config.physics.threads = threads;
      Tissue tissue(config, loadTissueMesh(config));
      allocationsOver(&tissue, 20, std::nullopt);  // the first steps size the buffers
      EXPECT_EQ(allocationsOver(&tissue, 200, std::nullopt), 0);
      // The blade upright 5 mm above the top face (at 30 mm): put down, then still.
      allocationsOver(&tissue, 10, upright(-0.02, 0.0, 0.035));
      EXPECT_EQ(allocationsOver(&tissue, 100, upright(-0.02, 0.0, 0.035)), 0);
      // Moving 0.2 mm a tick along x, 40 mm and back: the way back is counted.
      const double dt = 1.0 / config.rate;
      for (int k = 1; k <= 200; ++k) tissue.step(upright(-0.02 + 2e-4 * k, 0.0, 0.035), dt);
      const long long before = heapAllocations();
      for (int k = 199; k >= 0; --k) tissue.step(upright(-0.02 + 2e-4 * k, 0.0, 0.035), dt);
      EXPECT_EQ(heapAllocations() - before, 0);
      EXPECT_EQ(tissue.cutter().counts().cut_tetrahedra, 0);
      EXPECT_GT(tissue.physics().timeMs(), 0.0);  // the physics ran all along
    }
}

// Replacing a cut tet takes from the heap only the two lists it returns (its tets, its cut
// faces): the faces' triangles, the candidate cones and the checks' lists stay in place. A cut
// tick replaces and subdivides tets by the dozen (each had made 26-78 allocations here). Into a
// split whose lists have room, as the cutter's, nothing.
TEST(Allocations, ASplitAllocatesOnlyTheListsItReturns) {
  struct Case {
    const char* name;
    std::vector<int> edges, faces;
    bool steiner;
    SplitKind kind;
  };
  const std::vector<Case> cases = {
      {"3 edges around a corner", {0, 1, 2}, {}, false, SplitKind::kComplete},
      {"4 edges, a quad", {1, 2, 3, 4}, {}, false, SplitKind::kComplete},
      {"a front across two faces", {0}, {2, 3}, false, SplitKind::kPartial},
      {"a face's three edges", {0, 1, 3}, {}, true, SplitKind::kTent},
      {"opposite edges", {0, 5}, {}, false, SplitKind::kCone},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    CutTet tet;
    for (int e : c.edges) tet.edgePoint(e);
    for (int f : c.faces) tet.facePoint(f);
    const int steiner =
        c.steiner ? tet.add((tet.pos[0] + tet.pos[1] + tet.pos[2] + tet.pos[3]) / 4.0) : -1;
    const std::vector<Vec3>& pos = tet.pos;
    const PositionFn at = [&pos](int v) { return pos[v]; };
    long long before = heapAllocations();
    const TetSplit split = splitTet(tet.cut, at, at, steiner);
    const long long made = heapAllocations() - before;
    EXPECT_EQ(split.kind, c.kind) << splitKindName(split.kind);
    EXPECT_GE(split.tets.size(), 2u);
    EXPECT_EQ(made, split.cut_faces.empty() ? 1 : 2);
    before = heapAllocations();
    const TetSplit pieces = subdivideTet(tet.cut, at, at, steiner);
    EXPECT_EQ(heapAllocations() - before, 1);
    EXPECT_GE(pieces.tets.size(), 2u);
    // Into a split whose lists have room (the cutter keeps one): nothing, and the same answer.
    TetSplit kept;
    kept.tets.reserve(48);  // a split's most
    kept.cut_faces.reserve(16);
    before = heapAllocations();
    splitTet(tet.cut, at, at, steiner, &kept);
    subdivideTet(tet.cut, at, at, steiner, &kept);
    splitTet(tet.cut, at, at, steiner, &kept);
    EXPECT_EQ(heapAllocations() - before, 0);
    EXPECT_EQ(kept.kind, split.kind);
    EXPECT_EQ(kept.tets, split.tets);
    EXPECT_EQ(kept.cut_faces, split.cut_faces);
  }
}

// A tick's record composed with each change after it (a cut's, a collapse's) takes nothing from
// the heap once its lists have room: append() keeps its own lists a thread, for short records
// (scanned) and long ones (noted in a table) alike.
TEST(Allocations, ComposingIntoARecordWithRoomAllocatesNothing) {
  ChangeRecord tick, later;
  auto fill = [&](int n) {
    tick.clear();
    later.clear();
    for (int t = 0; t < n; ++t) {
      tick.added_tets.push_back(t);
      tick.added_from.push_back(-1);
    }
    for (int t = 0; t < n; t += 2) later.removed_tets.push_back(t);  // half of them go again
    later.removed_tets.push_back(n + 5);                             // and one there before
    for (int t = 0; t < n / 2; ++t) {
      later.added_tets.push_back(n + 10 + t);
      later.added_from.push_back(2 * t);  // continuing one added and removed again
    }
  };
  for (int n : {8, 400}) {
    SCOPED_TRACE(n);
    fill(n);
    tick.append(later);  // the lists grow to this size
    fill(n);
    const long long before = heapAllocations();
    tick.append(later);
    EXPECT_EQ(heapAllocations() - before, 0);
    EXPECT_EQ(tick.removed_tets, std::vector<int>{n + 5});
    EXPECT_EQ(tick.added_tets.size(), static_cast<std::size_t>(n));  // n / 2 kept, n / 2 new
    for (int from : tick.added_from) EXPECT_EQ(from, -1);            // new elements, all of them
  }
}

// A cutting stroke takes little from the heap for each tet it cuts: the block's incision
// without physics, collapses unbounded (the same work on any machine), counts 25 allocations a
// cut tet here, the first ticks' sizing of the buffers included (session 48: the split table's
// lists, the change records, the cutter's lists of coarse tets and separate()'s, flip candidates,
// refused collapses' hash nodes and std::functions too big for their own room had made about
// 300; cut_replay counts 276 -> 31 for the same stroke; session 49: the splits', replacements'
// and renames' result lists kept by the cutter and the mesh, the crack-front checks' lists on the
// stack, 44 -> 25). Still allocating: the new tets' and vertices' lists.
TEST(Allocations, ACuttingStrokeAllocatesLittleForEachTetItCuts) {
  Config config;
  config.physics.enabled = false;
  config.collapse.budget_us = 0.0;
  Tissue tissue(config, loadTissueMesh(config));
  const ScalpelPath path =
      ScalpelPath::read(std::string(TISSUE_CUT_SOURCE_DIR) + "/meshes/paths/incision_block.csv");
  const double dt = 1.0 / config.rate;
  const long ticks = std::lround((path.endTime() - path.startTime()) / dt);
  long long allocations = 0;
  for (long k = 0; k <= ticks + 1; ++k) {
    std::optional<BladeSegment> blade;
    if (k <= ticks) {
      const ToolPose p = path.at(path.startTime() + k * dt);
      blade = bladeFromPose(p.position, p.orientation, config.cut.blade_length);
    }
    allocations += allocationsOver(&tissue, 1, blade);
  }
  ASSERT_EQ(tissue.validate(), "");
  const int cut = tissue.cutter().counts().cut_tetrahedra;
  EXPECT_GT(cut, 300);
  EXPECT_GT(tissue.statistics().collapse.collapsed_edges, 100);
  std::printf("%lld allocations, %d cut tets: %.1f a cut tet\n", allocations, cut,
              static_cast<double>(allocations) / cut);
  EXPECT_LT(allocations, 50LL * cut);
}
