// Configuration: defaults equal config/tissue.yaml; partial files; loud errors naming the key.
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>

#include "tissue_cut/config.hpp"

using namespace tissue_cut;

namespace {

std::string writeTemp(const std::string& name, const std::string& text) {
  const std::string path = testing::TempDir() + name;
  std::ofstream(path) << text;
  return path;
}

}  // namespace

TEST(Config, DefaultsEqualTheShippedYaml) {
  const Config d;
  // Start from deliberately different values so every key must come from the file.
  Config other;
  other.rate = 1;
  other.publish_rate = 0.5;
  other.frame_id = "x";
  other.mesh = "m";
  other.mesh_max_tets = 5;
  other.mesh_order = "file";
  other.block_cell_size = 0.01;
  other.cut.blade_length = 0.5;
  other.cut.max_jump = 0.5;
  other.cut.filter_min_cutoff = 3.0;
  other.cut.filter_beta = 1.0;
  other.collapse.enabled = !d.collapse.enabled;
  other.collapse.tau = 0.9;
  other.collapse.budget_us = 7;
  other.collapse.deadline = 0.25;
  other.collapse.flips = !d.collapse.flips;
  other.collapse.smoothing = !d.collapse.smoothing;
  other.physics.enabled = !d.physics.enabled;
  other.physics.integrator = "semi_implicit";
  other.physics.density = 1;
  other.physics.young_modulus = 1;
  other.physics.damping = 0;
  other.physics.gravity = Vec3(1, 2, 3);
  other.physics.fixed_axis = "x";
  other.physics.fixed_side = "max";
  other.physics.fixed_band = 0.5;
  other.physics.threads = 7;
  other.physics.cluster_preconditioner = !d.physics.cluster_preconditioner;
  other.physics.local_presolve = !d.physics.local_presolve;
  other.physics.local_presolve_neighbours = !d.physics.local_presolve_neighbours;
  other.physics.quadratic_warm_start = !d.physics.quadratic_warm_start;
  const Config f =
      loadConfigFile(std::string(TISSUE_CUT_SOURCE_DIR) + "/config/tissue.yaml", other);
  EXPECT_EQ(f.rate, d.rate);
  EXPECT_EQ(f.publish_rate, d.publish_rate);
  EXPECT_EQ(f.frame_id, d.frame_id);
  EXPECT_EQ(f.mesh, d.mesh);
  EXPECT_EQ(f.mesh_max_tets, d.mesh_max_tets);
  EXPECT_EQ(f.mesh_order, d.mesh_order);
  EXPECT_EQ(f.block_cell_size, d.block_cell_size);
  EXPECT_EQ(f.cut.blade_length, d.cut.blade_length);
  EXPECT_EQ(f.cut.max_jump, d.cut.max_jump);
  EXPECT_EQ(f.cut.filter_min_cutoff, d.cut.filter_min_cutoff);
  EXPECT_EQ(f.cut.filter_beta, d.cut.filter_beta);
  EXPECT_EQ(f.collapse.enabled, d.collapse.enabled);
  EXPECT_EQ(f.collapse.tau, d.collapse.tau);
  EXPECT_EQ(f.collapse.budget_us, d.collapse.budget_us);
  EXPECT_EQ(f.collapse.deadline, d.collapse.deadline);
  EXPECT_EQ(f.collapse.flips, d.collapse.flips);
  EXPECT_EQ(f.collapse.smoothing, d.collapse.smoothing);
  EXPECT_EQ(f.physics.enabled, d.physics.enabled);
  EXPECT_EQ(f.physics.integrator, d.physics.integrator);
  EXPECT_EQ(f.physics.density, d.physics.density);
  EXPECT_EQ(f.physics.young_modulus, d.physics.young_modulus);
  EXPECT_EQ(f.physics.damping, d.physics.damping);
  EXPECT_EQ(f.physics.gravity, d.physics.gravity);
  EXPECT_EQ(f.physics.fixed_axis, d.physics.fixed_axis);
  EXPECT_EQ(f.physics.fixed_side, d.physics.fixed_side);
  EXPECT_EQ(f.physics.fixed_band, d.physics.fixed_band);
  EXPECT_EQ(f.physics.threads, d.physics.threads);
  EXPECT_EQ(f.physics.cluster_preconditioner, d.physics.cluster_preconditioner);
  EXPECT_EQ(f.physics.local_presolve, d.physics.local_presolve);
  EXPECT_EQ(f.physics.local_presolve_neighbours, d.physics.local_presolve_neighbours);
  EXPECT_EQ(f.physics.quadratic_warm_start, d.physics.quadratic_warm_start);
  EXPECT_EQ(configKeys().size(), 31u) << "a key was added: extend this test and tissue.yaml";
}

TEST(Config, PartialFileOverridesOnlyItsKeys) {
  const Config c = loadConfigFile(writeTemp("partial.yaml", "collapse:\n  tau: 0.2\nrate: 500\n"));
  EXPECT_EQ(c.collapse.tau, 0.2);
  EXPECT_EQ(c.rate, 500.0);
  EXPECT_EQ(c.cut.blade_length, Config{}.cut.blade_length);
}

TEST(Config, UnknownKeyIsNamed) {
  try {
    loadConfigFile(writeTemp("unknown.yaml", "physics:\n  youngs: 3\n"));
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("physics/youngs"), std::string::npos) << e.what();
  }
}

TEST(Config, AbsurdValuesAreNamed) {
  const std::pair<std::string, std::string> cases[] = {
      {"rate: 0\n", "rate"},
      {"cut:\n  blade_length: -1\n", "cut/blade_length"},
      {"cut:\n  filter_min_cutoff: -1\n", "cut/filter_min_cutoff"},
      {"cut:\n  filter_min_cutoff: 501\n", "cut/filter_min_cutoff"},
      {"cut:\n  filter_beta: -2\n", "cut/filter_beta"},
      {"cut:\n  filter_beta: smooth\n", "cut/filter_beta"},
      {"collapse:\n  tau: 2\n", "collapse/tau"},
      {"collapse:\n  deadline: 1.5\n", "collapse/deadline"},
      {"collapse:\n  deadline: -0.1\n", "collapse/deadline"},
      {"collapse:\n  flips: sometimes\n", "collapse/flips"},
      {"collapse:\n  smoothing: 0.5\n", "collapse/smoothing"},
      {"physics:\n  integrator: rk4\n", "physics/integrator"},
      {"physics:\n  density: .nan\n", "physics/density"},
      {"physics:\n  gravity: [0, 1]\n", "physics/gravity"},
      {"physics:\n  threads: 0\n", "physics/threads"},
      {"physics:\n  threads: 1000\n", "physics/threads"},
      {"physics:\n  threads: 1.5\n", "physics/threads"},
      {"physics:\n  cluster_preconditioner: maybe\n", "physics/cluster_preconditioner"},
      {"physics:\n  local_presolve: 2\n", "physics/local_presolve"},
      {"physics:\n  local_presolve_neighbours: 3\n", "physics/local_presolve_neighbours"},
      {"physics:\n  quadratic_warm_start: often\n", "physics/quadratic_warm_start"},
      {"mesh_order: random\n", "mesh_order"},
      {"rate: fast\n", "rate"},
  };
  for (const auto& [text, key] : cases) {
    try {
      loadConfigFile(writeTemp("bad.yaml", text));
      ADD_FAILURE() << "no error for " << text;
    } catch (const ConfigError& e) {
      EXPECT_NE(std::string(e.what()).find(key), std::string::npos) << e.what();
    }
  }
}

TEST(Config, MissingFileIsNamed) {
  try {
    loadConfigFile("/nonexistent/tissue.yaml");
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("/nonexistent/tissue.yaml"), std::string::npos);
  }
}
