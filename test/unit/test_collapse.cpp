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

// Replays at 1 kHz, validating every tick, then lifts the blade and runs `settle_ticks` more;
// `after_tick` (if given) looks at the tissue after each tick.
std::string replay(Tissue& tissue, const ScalpelPath& path, int settle_ticks = 0,
                   const std::function<void()>& after_tick = nullptr) {
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
    if (after_tick) after_tick();
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

// collapse/flips and collapse/smoothing (our extensions, on by default) follow the config, live
// too. Both off, the queue only collapses edges, as the paper's does: no flip and no smoothing
// move, and the severed block keeps the topology and volume it has without collapse. Turned on
// halfway through the incision, they work on from there.
TEST(Collapse, FlipsAndSmoothingFollowTheirKeysLive) {
  using CollapseStats = decltype(Statistics::collapse);
  const ScalpelPath path = line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.6);
  const Outcome plain = run(false, path, 0.06);
  Config c = withCollapse(true, 0.06);
  c.collapse.flips = false;
  c.collapse.smoothing = false;
  Tissue papers(c, makeBlock());
  ASSERT_EQ(replay(papers, path), "");
  const CollapseStats alone = papers.statistics().collapse;
  EXPECT_EQ(alone.flips, 0);
  EXPECT_EQ(alone.smoothed_vertices, 0);
  EXPECT_GT(alone.collapsed_edges, 20);
  EXPECT_EQ(countPieces(papers.mesh()), plain.pieces);
  EXPECT_EQ(boundaryEulerCharacteristic(papers.mesh()), plain.euler);
  EXPECT_NEAR(papers.mesh().restVolume(), plain.volume, 1e-3 * plain.volume);

  Tissue switched(c, makeBlock());
  int tick = 0;
  CollapseStats at_switch;
  ASSERT_EQ(replay(switched, path, 0,
                   [&] {
                     if (++tick != 300) return;
                     at_switch = switched.statistics().collapse;
                     Config on = switched.config();
                     on.collapse.flips = true;
                     on.collapse.smoothing = true;
                     ASSERT_EQ(switched.reconfigure(on), "");
                   }),
            "");
  const CollapseStats after = switched.statistics().collapse;
  std::printf("both off: %d collapses; switched on at tick 300: %d collapses, %d flips, "
              "%d smoothing moves before, %d, %d, %d at the end\n",
              alone.collapsed_edges, at_switch.collapsed_edges, at_switch.flips,
              at_switch.smoothed_vertices, after.collapsed_edges, after.flips,
              after.smoothed_vertices);
  EXPECT_GT(at_switch.collapsed_edges, 0);
  EXPECT_EQ(at_switch.flips + at_switch.smoothed_vertices, 0);
  EXPECT_GT(after.flips + after.smoothed_vertices, 0);
  EXPECT_EQ(countPieces(switched.mesh()), plain.pieces);
}

TEST(Collapse, ABudgetLeavesWorkQueuedForLaterTicks) {
  const ScalpelPath path = line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.3);
  // 20 us a tick is far less than the cut queues while the blade runs. The tissue's clock
  // advances 10 us a reading, so the work a tick does is the same on any machine and build: on
  // the steady clock, an ASan build running beside another test drained the queue more slowly
  // than 3,000 settling ticks (Release: about 1,900). On this clock 3,349 entries are queued
  // when the blade lifts and 2,160 ticks drain them, one worked tet a tick (stale entries are
  // dropped free).
  Tissue tissue(withCollapse(true, 0.06, 20.0), makeBlock());
  double clock = 0.0;
  tissue.setClock([&] { return clock += 10.0; });
  ASSERT_EQ(replay(tissue, path), "");
  const int queued = tissue.statistics().collapse.pending;
  EXPECT_GT(queued, 1000);
  int ticks = 0;
  for (; ticks < 10000 && tissue.statistics().collapse.pending > 0; ++ticks)
    tissue.step(std::nullopt, 1e-3);  // settling: the queue is worked off
  ASSERT_EQ(tissue.validate(), "");
  EXPECT_EQ(tissue.statistics().collapse.pending, 0);
  // Work left for later ticks: many settling ticks, none more than the entries queued.
  EXPECT_GT(ticks, 1000);
  EXPECT_LE(ticks, queued);
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

namespace {

bool everyTet(int) { return true; }
bool noneBusy(int) { return false; }

// The block cut straight through (no collapse); every live tet listed as if the cut had made it.
ChangeRecord cutThroughWithEveryTetNew(Tissue* tissue) {
  EXPECT_EQ(replay(*tissue, line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.3)), "");
  ChangeRecord all;
  for (int t = 0; t < tissue->mesh().tetSlots(); ++t)
    if (tissue->mesh().tetAlive(t)) all.added_tets.push_back(t);
  return all;
}

// Every tet of a cut block queued as if the cut had just made it, worked off at once and in
// calls of process() with `budget_us` (or `call_budget_us` given to each call, if positive) and a
// limit of `limit_us` a call (-1: none), the budget measured on a clock that advances 10 us a
// reading, so that it ends inside tets' work at known places: both must end with the same mesh.
// The ticked queue's counts.
CollapseCounts workedOffAtOnceAndInTicks(double budget_us, double limit_us,
                                         double call_budget_us = 0.0,
                                         double follow_us_per_tet = 0.0) {
  Tissue tissue(withCollapse(false, 0.06), makeBlock());
  const ChangeRecord all = cutThroughWithEveryTetNew(&tissue);
  const double tau = tissue.config().collapse.tau;

  TetMesh at_once = tissue.mesh(), in_ticks = tissue.mesh();
  CollapseQueue once(&at_once, tau, 0.0);
  once.queueFrom(all, everyTet);
  ChangeRecord change;
  once.process(noneBusy, everyTet, &change);
  EXPECT_EQ(once.pending(), 0);

  CollapseQueue ticks(&in_ticks, tau, budget_us);
  double clock = 0.0;
  ticks.setBudgetClock([&] { return clock += 10.0; });
  ticks.setFollowCost(follow_us_per_tet);
  ticks.queueFrom(all, everyTet);
  int calls = 0;
  for (; calls < 100000 && ticks.pending() > 0; ++calls) {
    ChangeRecord step;
    ticks.process(noneBusy, everyTet, &step, true, limit_us, call_budget_us);
  }
  std::printf("%d collapses, %d flips, %d smoothing moves; in %d ticks, %d tets stopped\n",
              once.counts().collapsed_edges, once.counts().flips, once.counts().smoothed_vertices,
              calls, ticks.counts().stopped);
  EXPECT_EQ(ticks.pending(), 0);
  EXPECT_GT(once.counts().collapsed_edges + once.counts().smoothed_vertices, 20);
  EXPECT_EQ(ticks.counts().collapsed_edges, once.counts().collapsed_edges);
  EXPECT_EQ(ticks.counts().flips, once.counts().flips);
  EXPECT_EQ(ticks.counts().smoothed_vertices, once.counts().smoothed_vertices);
  EXPECT_EQ(in_ticks.validate(), "");
  EXPECT_EQ(in_ticks.tetSlots(), at_once.tetSlots());
  for (int t = 0; t < std::min(at_once.tetSlots(), in_ticks.tetSlots()); ++t) {
    EXPECT_EQ(in_ticks.tetAlive(t), at_once.tetAlive(t)) << "tet " << t;
    if (at_once.tetAlive(t) && in_ticks.tetAlive(t) && in_ticks.tet(t) != at_once.tet(t)) {
      ADD_FAILURE() << "tet " << t;
      break;
    }
  }
  EXPECT_EQ(in_ticks.vertexSlots(), at_once.vertexSlots());
  for (int v = 0; v < std::min(at_once.vertexSlots(), in_ticks.vertexSlots()); ++v)
    if (at_once.vertexAlive(v) && in_ticks.rest(v) != at_once.rest(v)) {
      ADD_FAILURE() << "vertex " << v;
      break;
    }
  return ticks.counts();
}

}  // namespace

// prepare() sizes the queue's state for the mesh ahead (Tissue does it at a load or a reset, so
// that the first tick does not pay for it): the cut block's queue worked off with and without it
// makes the same mesh, tet for tet, with the same collapses, flips and smoothing moves.
TEST(Collapse, PreparingAheadChangesNothingTheQueueDoes) {
  Tissue tissue(withCollapse(false, 0.06), makeBlock());
  const ChangeRecord all = cutThroughWithEveryTetNew(&tissue);
  auto workedOff = [&](bool prepared) {
    TetMesh mesh = tissue.mesh();
    CollapseQueue queue(&mesh, tissue.config().collapse.tau, 0.0);
    if (prepared) queue.prepare();
    queue.queueFrom(all, everyTet);
    ChangeRecord change;
    queue.process(noneBusy, everyTet, &change);
    EXPECT_EQ(mesh.validate(), "");
    std::vector<TetVerts> tets;
    for (int t = 0; t < mesh.tetSlots(); ++t)
      tets.push_back(mesh.tetAlive(t) ? mesh.tet(t) : TetVerts{-1, -1, -1, -1});
    const CollapseCounts& c = queue.counts();
    return std::make_pair(tets, std::vector<int>{c.collapsed_edges, c.flips, c.smoothed_vertices});
  };
  const auto cold = workedOff(false), warm = workedOff(true);
  EXPECT_GT(cold.second[0], 20);
  EXPECT_GT(cold.second[2], 0);
  EXPECT_EQ(warm.second, cold.second);
  EXPECT_TRUE(warm.first == cold.first) << "a prepared queue changed other tets";
}

// A tet's work (collapse checks, flips, smoothing) can outlast the budget. Past it, a tet other
// than the tick's first stops between steps and goes back to the queue, the next tick's first
// to be worked: worked off over many ticks, the queue must end exactly where one worked off at
// once ends.
TEST(Collapse, ATetStoppedAtTheBudgetFinishesLaterAsIfUninterrupted) {
  EXPECT_GT(workedOffAtOnceAndInTicks(35.0, -1.0).stopped, 20);
}

// A call's limit (the tick's deadline) stops even the call's first tet between its steps; it
// resumes at the step where it stopped, so that calls of 25 us (two steps at most) still work
// everything off, and as if uninterrupted. (With the first tet exempt, as from the budget, the
// limit would stop next to none.)
TEST(Collapse, ACallsLimitStopsItsFirstTetTooAndTheWorkEndsAsIfUninterrupted) {
  EXPECT_GT(workedOffAtOnceAndInTicks(1000.0, 25.0).stopped, 100);
}

// A call's own budget (the deadline's chunk) stands for the queue's: 35 us a call stops tets as
// a queue of 35 us does (with the queue's 1,000 us, next to none would stop).
TEST(Collapse, ACallsOwnBudgetStandsForTheQueues) {
  EXPECT_GT(workedOffAtOnceAndInTicks(1000.0, -1.0, 35.0).stopped, 20);
}

// Under a limit, what following a call's changes will cost its caller counts against the limit
// (setFollowCost, per tet changed): a call stops once its time plus that reaches the limit, so
// that the tick ends by its deadline. A call of 2 ms on a clock of 10 us a reading, without and
// with a follow cost of 20 us a tet; then the same work in calls of 200 us with that cost ends
// as if uninterrupted.
TEST(Collapse, UnderALimitTheCostOfFollowingTheChangesCountsToo) {
  Tissue tissue(withCollapse(false, 0.06), makeBlock());
  const ChangeRecord all = cutThroughWithEveryTetNew(&tissue);
  auto changedInOneCall = [&](double follow_us_per_tet) {
    TetMesh mesh = tissue.mesh();
    CollapseQueue queue(&mesh, tissue.config().collapse.tau, 0.0);
    double clock = 0.0;
    queue.setBudgetClock([&] { return clock += 10.0; });
    queue.setFollowCost(follow_us_per_tet);
    queue.queueFrom(all, everyTet);
    ChangeRecord change;
    queue.process(noneBusy, everyTet, &change, true, 2000.0);
    EXPECT_EQ(mesh.validate(), "");
    return static_cast<int>(change.added_tets.size() + change.removed_tets.size());
  };
  const int free = changedInOneCall(0.0), costed = changedInOneCall(20.0);
  std::printf("tets changed in 2 ms: %d without a follow cost, %d at 20 us a tet\n", free, costed);
  EXPECT_GT(free * 20.0, 2000.0);  // the cost binds: without it the call changes more
  EXPECT_LT(costed, free);
  EXPECT_GT(costed, 0);
  // It stops at the first check past the limit: within one step's changes of it (a collapse
  // changes the tets around one edge, a few dozen at most).
  EXPECT_LT(costed * 20.0, 2000.0 + 60 * 20.0);
  EXPECT_GT(workedOffAtOnceAndInTicks(1000.0, 200.0, 0.0, 20.0).stopped, 5);
}

// Under a limit, a step after a call's first is taken only where the time a step is likely to
// take (the 99th percentile of those measured lately, their changes' follow cost included) still
// fits before the limit: a call stops before it, not at the first check past it, so that a tick
// ends by its deadline. The cut block's queue worked off in calls of 2 ms on a clock of 10 us a
// reading and a follow cost of 20 us a tet: of the calls the limit stopped, next to none end past
// it (only where a step took longer than all but the longest lately: 9 of 1,288). With the
// reserve taken as 0 (each call stopping at the first check past the limit), 478 of 630 did;
// at the 90th percentile, 110 of 971.
TEST(Collapse, UnderALimitAStepIsTakenOnlyWhereItLikelyEndsBeforeIt) {
  Tissue tissue(withCollapse(false, 0.06), makeBlock());
  const ChangeRecord all = cutThroughWithEveryTetNew(&tissue);
  TetMesh mesh = tissue.mesh();
  CollapseQueue queue(&mesh, tissue.config().collapse.tau, 0.0);
  double clock = 0.0;
  queue.setBudgetClock([&] { return clock += 10.0; });
  const double follow_us_per_tet = 20.0, limit_us = 2000.0;
  queue.setFollowCost(follow_us_per_tet);
  queue.queueFrom(all, everyTet);
  int stopped_calls = 0, late_calls = 0;
  double latest = 0.0;
  for (int calls = 0; calls < 10000 && queue.pending() > 0; ++calls) {
    ChangeRecord change;
    const double before = clock;
    queue.process(noneBusy, everyTet, &change, true, limit_us);
    if (queue.pending() == 0) break;  // ran out of work, not of time
    const std::size_t changed = change.added_tets.size() + change.removed_tets.size();
    // The call's time on the clock, less its reading before its first check, and the follow.
    const double used = clock - before - 10.0 + follow_us_per_tet * static_cast<double>(changed);
    ++stopped_calls;
    if (used > limit_us) ++late_calls;
    latest = std::max(latest, used - limit_us);
  }
  std::printf("%d calls stopped by the limit, %d of them past it (by %.0f us at most); reserve "
              "%.0f us\n", stopped_calls, late_calls, latest, queue.stepReserve());
  EXPECT_EQ(queue.pending(), 0);
  EXPECT_EQ(mesh.validate(), "");
  EXPECT_GT(stopped_calls, 20);
  EXPECT_GT(queue.stepReserve(), 0.0);
  EXPECT_LE(late_calls, stopped_calls / 50);
}

namespace {

// The block cut straight through with physics on (no gravity: it stays where it is) and the
// default budget, the tissue's clock advancing `step_us` a reading: a tick reads it at its start,
// around the physics step (which so takes step_us) and at the deadline's check after it (3 x
// step_us into the tick), and the queue's work is measured on it too. `ticks` (if given) gets a
// letter a tick: 'w' the queue worked (its time grew), 'd' it was deferred with tets queued, '-'
// neither.
Statistics cutOnAClock(double deadline, double step_us, std::string* ticks = nullptr) {
  Config c = withCollapse(true, 0.06, 300.0);
  c.physics.enabled = true;
  c.physics.gravity = Vec3::Zero();
  c.collapse.deadline = deadline;
  Tissue tissue(c, makeBlock());
  double clock = 0.0;
  tissue.setClock([&] { return clock += step_us; });
  Statistics last = tissue.statistics();
  auto look = [&] {
    const Statistics now = tissue.statistics();
    if (ticks)
      *ticks += now.collapse.time_ms > last.collapse.time_ms                  ? 'w'
                : now.collapse.deferred_ticks > last.collapse.deferred_ticks ? 'd'
                                                                             : '-';
    last = now;
  };
  EXPECT_EQ(replay(tissue, line({-0.07, 0.0013, 0.045}, {0.07, 0.0013, 0.045}, 0.3), 0, look),
            "");
  return tissue.statistics();
}

int work(const Statistics& s) {
  return s.collapse.collapsed_edges + s.collapse.flips + s.collapse.smoothed_vertices;
}

}  // namespace

// collapse/deadline: the queue works after the physics step, only while the tick is within its
// deadline (0.9 of the 1 ms period), and starts only with 100 us left; where the physics alone
// (the 75th percentile of its last steps) leaves no 100 us, it gets 100 us of budget every
// fourth tick (the three between stay on time), and where the physics alone takes the period,
// its whole budget every tick.
TEST(Collapse, TheTicksDeadlineLeavesTheQueueOnlyTheTimeTheTickHasLeft) {
  // 400 us a reading: the check comes 1.2 ms into the tick, past its deadline: no work, every
  // tick with tets queued counted as deferred.
  const Statistics late = cutOnAClock(0.9, 400.0);
  EXPECT_EQ(work(late), 0);
  EXPECT_GT(late.collapse.pending, 0);
  EXPECT_GT(late.collapse.deferred_ticks, 100);
  std::printf("deadline passed: work (collapses, flips, moves) %d\n", work(late));
  // The queue works, deferring no tick: without a deadline (the budget alone, one tet a tick,
  // the budget's first), where a physics step of 1.1 ms takes the period (no tick keeps pace:
  // the budget alone), and with time to spare (50 us a reading: 0.75 ms left at the check, more
  // than the budget).
  const struct {
    double deadline, step_us;
    const char* what;
  } working[] = {{0.0, 400.0, "no deadline"},
                 {0.9, 1100.0, "physics over the period"},
                 {0.9, 50.0, "time to spare"}};
  for (const auto& c : working) {
    std::string ticks;
    const Statistics s = cutOnAClock(c.deadline, c.step_us, &ticks);
    EXPECT_GT(s.collapse.collapsed_edges, 10) << c.what;
    EXPECT_EQ(s.collapse.deferred_ticks, 0) << c.what;
    EXPECT_EQ(ticks.find('d'), std::string::npos) << c.what;
    std::printf("%s: work %d\n", c.what, work(s));
  }
  // A physics step of 0.85 ms leaves no 100 us: the queue gets a chunk of budget every fourth
  // tick, and it still works; three ticks in four stay within the deadline.
  std::string ticks;
  const Statistics s = cutOnAClock(0.9, 850.0, &ticks);
  EXPECT_GT(s.collapse.collapsed_edges, 10);
  const std::size_t first = ticks.find('w'), last = ticks.rfind('w');
  ASSERT_NE(first, std::string::npos);
  const std::string worked = ticks.substr(first, last + 1 - first);
  EXPECT_EQ(worked.find("ww"), std::string::npos) << ticks;  // never two ticks running
  EXPECT_EQ(worked.find("dddd"), std::string::npos) << ticks;  // never four deferred
  int works = 0;
  for (std::size_t i = 0; i < worked.size(); ++i)
    if (worked[i] == 'w') {
      EXPECT_EQ(i % 4, 0u) << ticks;  // every fourth tick, whether tets wait or not
      ++works;
    }
  EXPECT_GT(works, 10);
  EXPECT_GT(s.collapse.deferred_ticks, 2 * works);
  std::printf("physics leaving no chunk: work %d, ticks the queue worked %d, deferred %d\n",
              work(s), works, s.collapse.deferred_ticks);
}

TEST(Collapse, SoundTetIsVolumeOverTheLongestEdgeCubedAtEveryScale) {
  // isSoundTet compares squares; it must answer as vol > kMinCollapseRelativeVolume * L^3 taken
  // from the definition: tets just above and just below the threshold, flipped, flat or
  // undefined, at scales from a micrometre to a metre.
  const Vec3 a(0, 0, 0), b(1, 0, 0), c(0, 1, 0);
  const double longest = std::sqrt(2.0);  // bc, while the apex stays low over the corner a
  const double height = 6.0 * kMinCollapseRelativeVolume * std::pow(longest, 3);  // vol = h / 6
  int sound = 0, unsound = 0;
  for (int i = 0; i < 6; ++i) {
    const double scale = std::pow(10.0, -i);
    for (double factor : {1.001, 1.1, 10.0, 0.999, 0.9, 0.0, -1.1}) {
      const Vec3 d(0.2, 0.2, factor * height);
      const double vol = signedVolume(a, b, c, d);
      const bool expected = vol > kMinCollapseRelativeVolume * std::pow(longest, 3);
      EXPECT_EQ(isSoundTet(a * scale, b * scale, c * scale, d * scale), expected)
          << "scale " << scale << " factor " << factor;
      const bool flipped = -vol > kMinCollapseRelativeVolume * std::pow(longest, 3);
      EXPECT_EQ(isSoundTet(a * scale, c * scale, b * scale, d * scale), flipped)
          << "flipped, scale " << scale << " factor " << factor;
      (expected ? sound : unsound) += 1;
      (flipped ? sound : unsound) += 1;
    }
  }
  EXPECT_EQ(sound, 24);  // 1.001, 1.1 and 10 the right way round, -1.1 flipped
  EXPECT_EQ(unsound, 60);
  EXPECT_FALSE(isSoundTet(a, b, c, Vec3(std::nan(""), 0, 1)));
  EXPECT_FALSE(isSoundTet(a, b, c, Vec3(0, 0, HUGE_VAL)));
}
