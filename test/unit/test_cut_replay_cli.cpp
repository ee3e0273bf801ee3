// cut_replay as a user runs it: every mesh format in and out, statistics that agree with VTK,
// and a clear error with a non-zero exit for every kind of bad input.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>

#include "replay_runner.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"

using namespace tissue_cut;
using tissue_cut::test::Outcome;
using tissue_cut::test::replay;
using tissue_cut::test::run;

namespace {

const std::string kSource = TISSUE_CUT_SOURCE_DIR;


double volumeOf(const MeshData& m) {
  TetMesh mesh(m.V, m.T);
  return mesh.restVolume();
}

}  // namespace

class ReplayRoundTrip : public testing::TestWithParam<std::string> {};

TEST_P(ReplayRoundTrip, WritesEveryFormatBackWithTheSameTetsVolumeAndVtkQuality) {
  const std::string mesh = GetParam();
  const std::string source = mesh.empty() ? "" : "--mesh " + kSource + "/meshes/" + mesh;
  const std::string stem =
      testing::TempDir() + "roundtrip_" + std::to_string(std::hash<std::string>{}(mesh));
  for (const std::string ext : {".vtk", ".node", ".msh"}) {
    // No physics: the points written are current positions, here equal to the rest shape.
    const Outcome r =
        replay(source + " --quiet --no-physics --out " + stem + ext + " --stats " + stem + ".json");
    ASSERT_EQ(r.status, 0) << r.output;
    std::ifstream js(stem + ".json");
    const nlohmann::json stats = nlohmann::json::parse(js);
    const MeshData back = readMesh(stem + ext);
    EXPECT_EQ(back.T.rows(), stats["initial"]["tetrahedra"].get<int>()) << ext;
    EXPECT_EQ(back.T.rows(), stats["mesh"]["tetrahedra"].get<int>()) << ext;
    const double volume = stats["initial"]["volume_rest"].get<double>();
    EXPECT_NEAR(volumeOf(back), volume, 1e-9 * volume) << ext;
    if (ext == std::string(".vtk")) {
      const Outcome q = run("/usr/bin/python3 " + kSource + "/test/vtk_quality.py " + stem + ext);
      ASSERT_EQ(q.status, 0) << q.output;
      int count = 0;
      double qmin = 0, qmean = 0;
      ASSERT_EQ(std::sscanf(q.output.c_str(), "%d %lf %lf", &count, &qmin, &qmean), 3) << q.output;
      EXPECT_EQ(count, back.T.rows());
      EXPECT_NEAR(stats["quality"]["min"].get<double>(), qmin, 1e-6);
      EXPECT_NEAR(stats["quality"]["mean"].get<double>(), qmean, 1e-6);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(ProjectMeshes, ReplayRoundTrip,
                         testing::Values("", "ellipsoid_v22.msh", "holed_block_v41.msh",
                                         "sphere_tetgen.node", "beam_ascii.vtk", "beam_binary.vtk",
                                         "capsule.stl", "capsule_binary.stl"));

struct BadInput {
  std::string args;
  int status;
  std::string says;  // a fragment the error must contain
};

TEST(CutReplayCli, RefusesBadInputWithAClearMessage) {
  const std::string bad = kSource + "/test/data/bad/";
  const std::string limit = testing::TempDir() + "limit.yaml";
  std::ofstream(limit) << "mesh_max_tets: 100\n";  // the ellipsoid has 1,622
  const BadInput cases[] = {
      {"--mesh /nonexistent/organ.msh", 2, "organ.msh"},
      {"--mesh " + bad + "msh22_truncated.msh", 2, "msh22_truncated.msh"},
      {"--mesh " + bad + "msh41_garbage.msh", 2, "msh41_garbage.msh"},
      {"--mesh " + bad + "vtk_nonfinite.vtk", 2, "vtk_nonfinite.vtk"},
      {"--mesh " + bad + "vtk_zero_volume.vtk", 2, "vtk_zero_volume.vtk"},
      {"--mesh " + bad + "tetgen_out_of_range.node", 2, "tetgen_out_of_range"},
      {"--mesh " + bad + "stl_open.stl", 2, "stl_open.stl"},
      {"--mesh " + bad + "mesh.xyz", 2, "mesh.xyz"},
      {"--mesh " + bad + "msh22_empty.msh", 2, "msh22_empty.msh"},
      {"--mesh " + bad + "vtk_binary_garbage.vtk", 2, "vtk_binary_garbage.vtk"},
      {"--mesh " + bad + "tetgen_nonfinite.node", 2, "tetgen_nonfinite"},
      {"--mesh " + bad + "stl_garbage.stl", 2, "stl_garbage.stl"},
      {"--config " + limit + " --mesh " + kSource + "/meshes/ellipsoid_v22.msh", 2, "limit"},
      {"--config /nonexistent/settings.yaml", 2, "settings.yaml"},
      {"--rate 0", 2, "rate"},
      {"--blade-length -0.01", 2, "cut/blade_length"},
      {"--tau 3", 2, "collapse/tau"},
      {"--rate fast", 1, "not a finite number"},
      {"--settle -1", 1, "--settle"},
      {"--frobnicate", 1, "unknown option"},
      {"--path /nonexistent/cut.csv", 2, "cut.csv"},
      {"--out /nonexistent/dir/out.vtk", 2, "out.vtk"},
      {"--out " + testing::TempDir() + "out.obj", 2, "out.obj"},
      {"--tick-log /nonexistent/dir/ticks.csv", 2, "ticks.csv"},
  };
  for (const BadInput& c : cases) {
    const Outcome r = replay(c.args);
    EXPECT_EQ(r.status, c.status) << c.args << "\n" << r.output;
    EXPECT_NE(r.output.find(c.says), std::string::npos) << c.args << "\n" << r.output;
  }
}

TEST(CutReplayCli, RefusesAMalformedPathFileNamingTheLine) {
  const std::string path = testing::TempDir() + "bad_path.csv";
  std::ofstream(path) << "t,x,y,z,qx,qy,qz,qw\n0,0,0,0.05,0,0,0,1\n0.1,0,nan,0.05,0,0,0,1\n";
  const Outcome r = replay("--path " + path);
  EXPECT_EQ(r.status, 2) << r.output;
  EXPECT_NE(r.output.find("bad_path.csv: line 3"), std::string::npos) << r.output;
}

TEST(CutReplayCli, ConfigFileOverridesDefaultsAndFlagsOverrideTheFile) {
  const std::string config = testing::TempDir() + "partial.yaml";
  std::ofstream(config) << "rate: 250\ncollapse:\n  tau: 0.2\n";
  const std::string stats = testing::TempDir() + "cfg.json";
  const std::string path = kSource + "/meshes/paths/incision_block.csv";
  Outcome r = replay("--quiet --config " + config + " --path " + path + " --stats " + stats);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream a(stats);
  const auto s1 = nlohmann::json::parse(a);
  EXPECT_EQ(s1["ticks"]["rate_hz"].get<double>(), 250.0);
  r = replay("--quiet --config " + config + " --rate 500 --path " + path + " --stats " + stats);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream b(stats);
  const auto s2 = nlohmann::json::parse(b);
  EXPECT_EQ(s2["ticks"]["rate_hz"].get<double>(), 500.0);
  EXPECT_EQ(s2["ticks"]["count"].get<int>(), 1001);  // 2 s at 500 Hz, then the lift
}

TEST(CutReplayCli, StatisticsFileHasEveryKey) {
  const std::string stats = testing::TempDir() + "keys.json";
  const Outcome r = replay("--quiet --stats " + stats);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream in(stats);
  const auto s = nlohmann::json::parse(in);
  for (const char* key : {"mesh", "initial", "volume_rest", "volume_current", "quality", "cut",
                          "collapse", "region", "physics", "ticks"})
    EXPECT_TRUE(s.contains(key)) << key;
  EXPECT_EQ(s["quality"]["histogram"].size(), 10u);
  for (const char* key : {"link", "inversion", "quality", "boundary"})
    EXPECT_TRUE(s["collapse"]["rejected"].contains(key)) << key;
  for (const char* key : {"count", "rate_hz", "p50_ms", "p99_ms", "max_ms", "deadline_misses"})
    EXPECT_TRUE(s["ticks"].contains(key)) << key;
}

// The tick log: one row a tick, whose columns add up to the statistics' totals, and each tick's
// parts within its own time.
TEST(CutReplayCli, TickLogHasARowATickThatAddsUpToTheStatistics) {
  const std::string stats = testing::TempDir() + "log.json";
  const std::string log = testing::TempDir() + "ticks.csv";
  const std::string path = kSource + "/meshes/paths/incision_block.csv";
  const Outcome r =
      replay("--quiet --rate 250 --path " + path + " --stats " + stats + " --tick-log " + log);
  ASSERT_EQ(r.status, 0) << r.output;
  std::ifstream sf(stats);
  const auto s = nlohmann::json::parse(sf);
  std::ifstream in(log);
  std::string line;
  ASSERT_TRUE(std::getline(in, line));
  EXPECT_EQ(line,
            "tick,t,wall_ms,cpu_ms,cut_ms,collapse_ms,physics_ms,cg_iterations,cut_tets,collapses,"
            "allocations");
  long long count = 0, cg = 0, cut_tets = 0, collapses = 0;
  long long allocations = 0, allocating = 0, most = 0;
  double cut_ms = 0, collapse_ms = 0, physics_ms = 0, max_wall = 0;
  while (std::getline(in, line)) {
    long long tick, iterations, heap;
    double t, wall, cpu, cut, collapse, physics;
    int tets, edges;
    ASSERT_EQ(std::sscanf(line.c_str(), "%lld,%lf,%lf,%lf,%lf,%lf,%lf,%lld,%d,%d,%lld", &tick, &t,
                          &wall, &cpu, &cut, &collapse, &physics, &iterations, &tets, &edges,
                          &heap),
              11)
        << line;
    EXPECT_GE(heap, 0) << line;
    allocations += heap;
    allocating += heap > 0 ? 1 : 0;
    most = std::max(most, heap);
    ++count;
    EXPECT_EQ(tick, count) << line;
    EXPECT_NEAR(t, tick / 250.0, 1e-9) << line;
    EXPECT_GE(cut, 0.0) << line;
    EXPECT_GE(collapse, 0.0) << line;
    EXPECT_GE(physics, 0.0) << line;
    EXPECT_LE(cut + collapse + physics, wall + 1e-5) << line;  // the parts are inside the tick
    cg += iterations;
    cut_tets += tets;
    collapses += edges;
    cut_ms += cut;
    collapse_ms += collapse;
    physics_ms += physics;
    max_wall = std::max(max_wall, wall);
  }
  EXPECT_EQ(count, s["ticks"]["count"].get<long long>());
  EXPECT_EQ(count, 501);  // 2 s at 250 Hz, then the lift
  // The heap allocations the ticks made: the cuts allocate (new tets, points, lists), the
  // stretches of the stroke that cut nothing do not (see test_allocations).
  EXPECT_EQ(allocations, s["ticks"]["allocations"]["total"].get<long long>());
  EXPECT_EQ(allocating, s["ticks"]["allocations"]["ticks_allocating"].get<long long>());
  EXPECT_EQ(most, s["ticks"]["allocations"]["max_per_tick"].get<long long>());
  EXPECT_GT(allocations, 0);
  EXPECT_LT(allocating, count);
  EXPECT_GT(cut_tets, 0);
  EXPECT_EQ(cut_tets, s["cut"]["cut_tetrahedra"].get<long long>());
  EXPECT_GT(collapses, 0);
  EXPECT_EQ(collapses, s["collapse"]["collapsed_edges"].get<long long>());
  EXPECT_EQ(cg, std::llround(s["physics"]["cg_iterations_mean"].get<double>() *
                             s["physics"]["steps"].get<double>()));
  EXPECT_NEAR(cut_ms, s["cut"]["time_ms"].get<double>(), 1e-3);
  EXPECT_NEAR(collapse_ms, s["collapse"]["time_ms"].get<double>(), 1e-3);
  EXPECT_NEAR(physics_ms, s["physics"]["time_ms"].get<double>(), 1e-3);
  EXPECT_NEAR(max_wall, s["ticks"]["max_ms"].get<double>(), 1e-5);
}
