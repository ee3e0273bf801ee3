// One Config for the whole model, read from YAML (cut_replay --config) or, in the node, from the
// parameter server. Keys nest with '/' (cut/blade_length) exactly as in config/tissue.yaml.
#pragma once

#include <stdexcept>
#include <string>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace YAML {
class Node;
}

namespace tissue_cut {

/// A configuration value or file that cannot be used; what() names the key or file.
class ConfigError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Every setting of the model. Defaults equal config/tissue.yaml (a test holds them together).
struct Config {
  double rate = 1000.0;                 ///< simulation ticks per second [Hz]
  double publish_rate = 30.0;           ///< markers and statistics per second [Hz]
  std::string frame_id = "world";       ///< the mesh frame
  std::string mesh;                     ///< mesh file; empty = the built-in block
  std::size_t mesh_max_tets = 2000000;  ///< larger mesh files are refused [count]
  /// "spatial": a mesh file's vertices and tets renumbered along a space-filling curve for
  /// memory locality (see spatiallyOrdered()); "file": numbered as in the file.
  std::string mesh_order = "spatial";
  double block_cell_size = 0.006;       ///< built-in block's cell edge [m]

  struct Cut {
    double blade_length = 0.03;  ///< along the tool's -z from its origin [m]
    double max_jump = 0.02;      ///< a longer move in one tick lifts the blade [m]
    /// The blade's path smoothed before cutting (BladeFilter, for trembling tools and noisy
    /// trackers): a still blade's cutoff [Hz], 0 = off; and how fast the cutoff rises with the
    /// blade's speed [1/m] (a steady blade trails the tool by about sqrt(v / (2 pi beta rate))).
    double filter_min_cutoff = 0.0;
    double filter_beta = 20.0;
  } cut;

  struct Collapse {
    bool enabled = true;
    double tau = 0.6;          ///< created tets with Q below it queue their edges and vertices
    double budget_us = 300.0;  ///< collapse work per tick [us]; 0 = unbounded
    /// The tick's deadline, a fraction of its period (1 / rate): the queue works after the
    /// physics step, starts only with 100 us left before the deadline and stops there or at its
    /// budget, whichever comes first: collapses wait for ticks with time to spare. Where the
    /// physics step (the 75th percentile of its last 128) leaves no 100 us, the queue gets 100 us
    /// of budget every fourth such tick; where it takes the whole period, its budget every tick.
    /// 0: the budget alone, before the physics step, as also while budget_us is 0 (unbounded).
    double deadline = 0.9;
    /// Our extensions to the paper's collapse, each on by default: when no edge of a queued tet
    /// may collapse, the best flip among tets made by cuts (2-3, edge removal, 2-2), and else a
    /// move of one of its vertices. Both off: the paper's collapse alone (less work per tet,
    /// lower quality behind the cut).
    bool flips = true;
    bool smoothing = true;
  } collapse;

  struct Physics {
    bool enabled = true;
    std::string integrator = "implicit";  ///< "implicit" (backward Euler + CG) or "semi_implicit"
    double density = 1000.0;              ///< [kg/m^3]
    double young_modulus = 5000.0;        ///< [Pa]
    double damping = 2.0;                 ///< mass-proportional damping [1/s]
    Vec3 gravity{0.0, 0.0, -9.81};        ///< [m/s^2]
    std::string fixed_axis = "z";         ///< x, y or z
    std::string fixed_side = "min";       ///< min or max
    double fixed_band = 0.001;            ///< vertices this close to that side are fixed [m]
    int threads = 2;  ///< threads of the implicit step (at most the machine's hardware threads)
    /// Precondition the cut's stiff, light vertex clusters whole (see
    /// MassSpringParams::cluster_preconditioner); false: block-Jacobi alone.
    bool cluster_preconditioner = true;
    /// Solve where a cut or a collapse just changed the springs first, then CG on the whole
    /// mesh (see MassSpringParams::local_presolve).
    bool local_presolve = true;
    /// The local solve takes in the neighbours of the vertices it picks (see
    /// MassSpringParams::local_presolve_neighbours); false: those vertices alone.
    bool local_presolve_neighbours = true;
    /// Warm start extrapolated quadratically where that guessed the last step closer (see
    /// MassSpringParams::quadratic_warm_start); false: always linearly.
    bool quadratic_warm_start = true;
  } physics;

  /// The first invalid value as "key: why", or "" when all are usable.
  std::string check() const;
  /// The fixed axis as 0, 1 or 2.
  int fixedAxisIndex() const;
};

/// Overrides `base` with the keys present in a YAML file. Unknown keys, wrong types and values
/// that fail Config::check() throw ConfigError naming the file and key.
Config loadConfigFile(const std::string& path, const Config& base = Config{});

/// Every key of Config as it is spelled in YAML and on the parameter server.
std::vector<std::string> configKeys();

/// Sets one key (as spelled in configKeys()) from a YAML value; `source` names where it came
/// from in errors. Throws ConfigError for an unknown key or a value of the wrong type; the value
/// itself is checked later by Config::check().
void setConfigValue(const std::string& key, const YAML::Node& value, const std::string& source,
                    Config* config);

}  // namespace tissue_cut
