// Micro-benchmarks of the core's hot paths (Google Benchmark). Not a test: run by hand or by
// scripts/bench_table.py, e.g.  build/devel/lib/tissue_cut/bench_core --benchmark_repetitions=5
// Mesh sizes are the built-in block at 5k, 20k and 80k tets, so nothing is read from disk.
#include <benchmark/benchmark.h>

#include <chrono>
#include <cmath>
#include <memory>

#include "tissue_cut/cut/split_table.hpp"
#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/mesh/surface.hpp"
#include "tissue_cut/mesh/tet_grid.hpp"
#include "tissue_cut/physics/mass_spring.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"
#include "tissue_cut/remesh/link_condition.hpp"
#include "tissue_cut/tissue.hpp"

using namespace tissue_cut;

namespace {

// Cell edge [m] of the block with about `tets` tetrahedra (0.006 m gives 5,100).
double cellFor(int tets) { return 0.006 * std::cbrt(5100.0 / tets); }

MeshData blockOf(int tets) {
  BlockSpec spec;
  spec.cell_size = cellFor(tets);
  return makeBlock(spec);
}

// Q = 3 r_in / r_circ of one tet from its four corners (what a collapse check or a smoothing
// trial pays for each tet it moves).
void BM_TetQuality(benchmark::State& state) {
  const MeshData block = blockOf(5100);
  const TetMesh mesh(block.V, block.T);
  int t = 0;
  for (auto _ : state) {
    const TetVerts& tv = mesh.tet(t);
    benchmark::DoNotOptimize(
        tetQuality(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3])));
    t = (t + 1) % mesh.tetSlots();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_TetQuality);

// A tet's rest Q as TetMesh keeps it (measured when the tet is made or a vertex of it moves).
void BM_RestQualityKept(benchmark::State& state) {
  const MeshData block = blockOf(5100);
  const TetMesh mesh(block.V, block.T);
  int t = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(restQuality(mesh, t));
    t = (t + 1) % mesh.tetSlots();
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_RestQualityKept);

// The sweep's candidate search: tets near one tick's swept quad (a 3 cm blade moved 0.1 mm).
void BM_GridQuery(benchmark::State& state) {
  const MeshData block = blockOf(static_cast<int>(state.range(0)));
  const TetMesh mesh(block.V, block.T);
  const double cell = cellFor(static_cast<int>(state.range(0)));
  TetGrid grid;
  grid.build(mesh, 2.0 * cell, cell);
  double x = -0.04;
  std::size_t found = 0;
  for (auto _ : state) {
    const Vec3 lo(x, -0.0005, 0.0), hi(x + 1e-4, 0.0005, 0.03);
    const std::vector<int> near = grid.query(mesh, lo, hi);
    found += near.size();
    x = x < 0.04 ? x + 1e-4 : -0.04;
  }
  state.counters["tets_per_query"] =
      benchmark::Counter(static_cast<double>(found) / state.iterations());
}
BENCHMARK(BM_GridQuery)->Arg(5100)->Arg(20000)->Arg(80000);

// Rebuilding the grid (when the tissue drifted half a mean edge since it was built).
void BM_GridBuild(benchmark::State& state) {
  const MeshData block = blockOf(static_cast<int>(state.range(0)));
  const TetMesh mesh(block.V, block.T);
  const double cell = cellFor(static_cast<int>(state.range(0)));
  TetGrid grid;
  for (auto _ : state) grid.build(mesh, 2.0 * cell, cell);
}
BENCHMARK(BM_GridBuild)->Arg(5100)->Arg(20000)->Arg(80000)->Unit(benchmark::kMicrosecond);

// One cut tet through the split table: 3 edge points around a corner (complete, 4 tets) and 4
// edge points (complete, 6 tets).
void splitBench(benchmark::State& state, const std::array<int, 6>& cut_edges) {
  std::vector<Vec3> x = {Vec3(0, 0, 0), Vec3(1, 0, 0), Vec3(0, 1, 0), Vec3(0, 0, 1)};
  TetCut cut;
  cut.corner = {0, 1, 2, 3};
  for (int e = 0; e < 6; ++e) {
    if (!cut_edges[e]) continue;
    cut.edge_point[e] = static_cast<int>(x.size());
    x.push_back(0.45 * x[kTetEdge[e][0]] + 0.55 * x[kTetEdge[e][1]]);
  }
  const PositionFn at = [&x](int v) { return x[v]; };
  std::size_t made = 0;
  for (auto _ : state) {
    const TetSplit split = splitTet(cut, at, at, -1);
    made += split.tets.size();
  }
  state.counters["tets_made"] = benchmark::Counter(static_cast<double>(made) / state.iterations());
}
void BM_SplitThreeEdges(benchmark::State& state) { splitBench(state, {1, 1, 1, 0, 0, 0}); }
void BM_SplitFourEdges(benchmark::State& state) { splitBench(state, {0, 1, 1, 1, 1, 0}); }
BENCHMARK(BM_SplitThreeEdges);
BENCHMARK(BM_SplitFourEdges);

// The checks before one collapse (link condition, inversion, quality) on interior edges of the
// block; nothing is collapsed, so every iteration sees the same mesh.
void BM_CollapseCheck(benchmark::State& state) {
  const MeshData block = blockOf(5100);
  const TetMesh mesh(block.V, block.T);
  const auto edges = mesh.edges();
  std::size_t i = edges.size() / 2;
  for (auto _ : state) {
    benchmark::DoNotOptimize(checkCollapse(mesh, edges[i].first, edges[i].second));
    i = i + 1 < edges.size() ? i + 1 : 0;
  }
}
BENCHMARK(BM_CollapseCheck);

void BM_LinkCondition(benchmark::State& state) {
  const MeshData block = blockOf(5100);
  const TetMesh mesh(block.V, block.T);
  const auto edges = mesh.edges();
  std::size_t i = edges.size() / 2;
  for (auto _ : state) {
    benchmark::DoNotOptimize(linkConditionHolds(mesh, edges[i].first, edges[i].second));
    i = i + 1 < edges.size() ? i + 1 : 0;
  }
}
BENCHMARK(BM_LinkCondition);

// One cutting tick (sweep, point registration, replacement of the tets the blade left,
// separation) of a straight incision along the block, no physics, no collapse. The blade moves
// 0.1 mm a tick; at the end of the block the tissue is reset (not timed).
void BM_CutTick(benchmark::State& state) {
  Config config;
  config.physics.enabled = false;
  config.collapse.enabled = false;
  config.block_cell_size = cellFor(static_cast<int>(state.range(0)));
  config.cut.blade_length = 0.03;
  Tissue tissue(config, loadTissueMesh(config));
  double x = -0.06;
  for (auto _ : state) {
    const BladeSegment blade{Vec3(x, 0.0013, 0.045), Vec3(x, 0.0013, 0.015)};
    tissue.step(blade, 1e-3);
    x += 1e-4;
    if (x > 0.06) {
      state.PauseTiming();
      tissue.step(std::nullopt, 1e-3);
      tissue.reset();
      x = -0.06;
      state.ResumeTiming();
    }
  }
  state.counters["cut_tets"] = tissue.cutter().counts().cut_tetrahedra;
}
BENCHMARK(BM_CutTick)->Arg(5100)->Arg(20000)->Arg(80000)->Unit(benchmark::kMicrosecond);

// One implicit step (backward Euler, CG with default tolerance) of the block at rest under
// gravity after 50 settling steps; reports CG iterations and ns per spring per CG iteration.
// One implicit step at rest; the second argument is physics/threads (wall time: the helpers'
// work counts).
void BM_PhysicsStep(benchmark::State& state) {
  const MeshData block = blockOf(static_cast<int>(state.range(0)));
  TetMesh mesh(block.V, block.T);
  MassSpringParams params;
  params.threads = static_cast<int>(state.range(1));
  MassSpring physics(&mesh, params);
  for (int k = 0; k < 50; ++k) physics.step(1e-3);
  const long long it0 = physics.totalIterations();
  for (auto _ : state) physics.step(1e-3);
  const double iterations = static_cast<double>(physics.totalIterations() - it0);
  state.counters["springs"] = physics.numSprings();
  state.counters["threads"] = physics.numThreads();
  state.counters["cg_iterations"] = benchmark::Counter(iterations / state.iterations());
  // Time per spring per iteration: the step's time over (springs x iterations), in ns.
  state.counters["ns_per_spring_iteration"] = benchmark::Counter(
      iterations * physics.numSprings(), benchmark::Counter::kIsRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_PhysicsStep)
    ->ArgsProduct({{5100, 20000, 80000}, {1, 2}})
    ->UseRealTime()
    ->Unit(benchmark::kMicrosecond);

// What the CG tolerance costs: the 20k block with relative tolerance 1e-6, 1e-4, 1e-3 (default
// 1e-5; one thread).
void BM_PhysicsStepTolerance(benchmark::State& state) {
  const MeshData block = blockOf(20000);
  TetMesh mesh(block.V, block.T);
  MassSpringParams params;
  params.cg_tolerance = std::pow(10.0, -static_cast<double>(state.range(0)));
  MassSpring physics(&mesh, params);
  for (int k = 0; k < 50; ++k) physics.step(1e-3);
  const long long it0 = physics.totalIterations();
  for (auto _ : state) physics.step(1e-3);
  state.counters["cg_iterations"] =
      benchmark::Counter(static_cast<double>(physics.totalIterations() - it0) / state.iterations());
}
BENCHMARK(BM_PhysicsStepTolerance)->Arg(6)->Arg(4)->Arg(3)->Unit(benchmark::kMicrosecond);

// Surface triangles with normals and colours into reused float buffers (markers at 30 Hz).
void BM_SurfaceBuffers(benchmark::State& state) {
  const MeshData block = blockOf(static_cast<int>(state.range(0)));
  const TetMesh mesh(block.V, block.T);
  SurfaceBuffers buffers;
  const auto start = std::chrono::steady_clock::now();
  for (auto _ : state) buildSurfaceBuffers(mesh, &buffers);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  state.counters["triangles"] = buffers.triangles;
  // Per cent of one core at 30 Hz (wall time): 100 x 30 builds a second x the time of one.
  state.counters["percent_core_at_30Hz"] = 3000.0 * seconds / state.iterations();
}
BENCHMARK(BM_SurfaceBuffers)->Arg(5100)->Arg(20000)->Arg(80000)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
