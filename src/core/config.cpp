#include "tissue_cut/config.hpp"

#include <yaml-cpp/yaml.h>

#include <cmath>
#include <functional>
#include <map>
#include <sstream>

namespace tissue_cut {

namespace {

bool finitePositive(double x) { return std::isfinite(x) && x > 0; }

// One setter per key: reads a YAML node into the Config, throwing YAML exceptions on bad types.
using Setter = std::function<void(const YAML::Node&, Config&)>;

const std::map<std::string, Setter>& setters() {
  static const std::map<std::string, Setter> table = {
      {"rate", [](const YAML::Node& n, Config& c) { c.rate = n.as<double>(); }},
      {"publish_rate", [](const YAML::Node& n, Config& c) { c.publish_rate = n.as<double>(); }},
      {"frame_id", [](const YAML::Node& n, Config& c) { c.frame_id = n.as<std::string>(); }},
      {"mesh",
       [](const YAML::Node& n, Config& c) { c.mesh = n.IsNull() ? "" : n.as<std::string>(); }},
      {"mesh_max_tets",
       [](const YAML::Node& n, Config& c) { c.mesh_max_tets = n.as<std::size_t>(); }},
      {"mesh_order", [](const YAML::Node& n, Config& c) { c.mesh_order = n.as<std::string>(); }},
      {"block_cell_size",
       [](const YAML::Node& n, Config& c) { c.block_cell_size = n.as<double>(); }},
      {"cut/blade_length",
       [](const YAML::Node& n, Config& c) { c.cut.blade_length = n.as<double>(); }},
      {"cut/max_jump", [](const YAML::Node& n, Config& c) { c.cut.max_jump = n.as<double>(); }},
      {"cut/filter_min_cutoff",
       [](const YAML::Node& n, Config& c) { c.cut.filter_min_cutoff = n.as<double>(); }},
      {"cut/filter_beta",
       [](const YAML::Node& n, Config& c) { c.cut.filter_beta = n.as<double>(); }},
      {"collapse/enabled",
       [](const YAML::Node& n, Config& c) { c.collapse.enabled = n.as<bool>(); }},
      {"collapse/tau", [](const YAML::Node& n, Config& c) { c.collapse.tau = n.as<double>(); }},
      {"collapse/budget_us",
       [](const YAML::Node& n, Config& c) { c.collapse.budget_us = n.as<double>(); }},
      {"collapse/deadline",
       [](const YAML::Node& n, Config& c) { c.collapse.deadline = n.as<double>(); }},
      {"collapse/flips", [](const YAML::Node& n, Config& c) { c.collapse.flips = n.as<bool>(); }},
      {"collapse/smoothing",
       [](const YAML::Node& n, Config& c) { c.collapse.smoothing = n.as<bool>(); }},
      {"physics/enabled", [](const YAML::Node& n, Config& c) { c.physics.enabled = n.as<bool>(); }},
      {"physics/integrator",
       [](const YAML::Node& n, Config& c) { c.physics.integrator = n.as<std::string>(); }},
      {"physics/density",
       [](const YAML::Node& n, Config& c) { c.physics.density = n.as<double>(); }},
      {"physics/young_modulus",
       [](const YAML::Node& n, Config& c) { c.physics.young_modulus = n.as<double>(); }},
      {"physics/damping",
       [](const YAML::Node& n, Config& c) { c.physics.damping = n.as<double>(); }},
      {"physics/gravity",
       [](const YAML::Node& n, Config& c) {
         auto g = n.as<std::vector<double>>();
         if (g.size() != 3) throw YAML::Exception(n.Mark(), "gravity needs 3 components");
         c.physics.gravity = Vec3(g[0], g[1], g[2]);
       }},
      {"physics/fixed_axis",
       [](const YAML::Node& n, Config& c) { c.physics.fixed_axis = n.as<std::string>(); }},
      {"physics/fixed_side",
       [](const YAML::Node& n, Config& c) { c.physics.fixed_side = n.as<std::string>(); }},
      {"physics/fixed_band",
       [](const YAML::Node& n, Config& c) { c.physics.fixed_band = n.as<double>(); }},
      {"physics/threads", [](const YAML::Node& n, Config& c) { c.physics.threads = n.as<int>(); }},
      {"physics/cluster_preconditioner",
       [](const YAML::Node& n, Config& c) { c.physics.cluster_preconditioner = n.as<bool>(); }},
      {"physics/local_presolve",
       [](const YAML::Node& n, Config& c) { c.physics.local_presolve = n.as<bool>(); }},
      {"physics/local_presolve_neighbours",
       [](const YAML::Node& n, Config& c) { c.physics.local_presolve_neighbours = n.as<bool>(); }},
      {"physics/quadratic_warm_start",
       [](const YAML::Node& n, Config& c) { c.physics.quadratic_warm_start = n.as<bool>(); }},
  };
  return table;
}

void readNode(const YAML::Node& node, const std::string& prefix, const std::string& path,
              Config& c) {
  if (!node.IsMap()) throw ConfigError(path + ": expected a map of keys at '" + prefix + "'");
  for (const auto& kv : node) {
    const std::string key = prefix + kv.first.as<std::string>();
    if (kv.second.IsMap()) {
      readNode(kv.second, key + "/", path, c);
      continue;
    }
    setConfigValue(key, kv.second, path, &c);
  }
}

}  // namespace

void setConfigValue(const std::string& key, const YAML::Node& value, const std::string& source,
                    Config* config) {
  auto it = setters().find(key);
  if (it == setters().end()) throw ConfigError(source + ": unknown key '" + key + "'");
  try {
    it->second(value, *config);
  } catch (const YAML::Exception& e) {
    const int line = value.Mark().line;
    throw ConfigError(source + ": key '" + key + "' has a value of the wrong type" +
                      (line >= 0 ? " (line " + std::to_string(line + 1) + ")" : ""));
  }
}

std::vector<std::string> configKeys() {
  std::vector<std::string> keys;
  for (const auto& kv : setters()) keys.push_back(kv.first);
  return keys;
}

int Config::fixedAxisIndex() const {
  if (physics.fixed_axis == "x") return 0;
  if (physics.fixed_axis == "y") return 1;
  return 2;
}

std::string Config::check() const {
  std::ostringstream err;
  if (!finitePositive(rate) || rate > 100000) return "rate: must be in (0, 100000] Hz";
  if (!finitePositive(publish_rate) || publish_rate > rate)
    return "publish_rate: must be positive and at most rate";
  if (frame_id.empty()) return "frame_id: must not be empty";
  if (mesh_max_tets == 0) return "mesh_max_tets: must be positive";
  if (mesh_order != "spatial" && mesh_order != "file")
    return "mesh_order: must be 'spatial' or 'file'";
  if (!finitePositive(block_cell_size) || block_cell_size < 5e-4)
    return "block_cell_size: must be at least 0.0005 m";
  if (!finitePositive(cut.blade_length) || cut.blade_length > 1.0)
    return "cut/blade_length: must be in (0, 1] m";
  if (!finitePositive(cut.max_jump)) return "cut/max_jump: must be positive";
  if (!std::isfinite(cut.filter_min_cutoff) || cut.filter_min_cutoff < 0 ||
      cut.filter_min_cutoff > 0.5 * rate)
    return "cut/filter_min_cutoff: must be 0 (off) or positive, at most rate / 2 [Hz]";
  if (!std::isfinite(cut.filter_beta) || cut.filter_beta < 0)
    return "cut/filter_beta: must be non-negative [1/m]";
  if (!std::isfinite(collapse.tau) || collapse.tau < 0 || collapse.tau > 1)
    return "collapse/tau: must be in [0, 1]";
  if (!std::isfinite(collapse.budget_us) || collapse.budget_us < 0)
    return "collapse/budget_us: must be 0 (unbounded) or positive";
  if (!std::isfinite(collapse.deadline) || collapse.deadline < 0 || collapse.deadline > 1)
    return "collapse/deadline: must be in [0, 1] (a fraction of the tick; 0 = none)";
  if (physics.integrator != "implicit" && physics.integrator != "semi_implicit")
    return "physics/integrator: must be 'implicit' or 'semi_implicit'";
  if (!finitePositive(physics.density)) return "physics/density: must be positive";
  if (!finitePositive(physics.young_modulus)) return "physics/young_modulus: must be positive";
  if (!std::isfinite(physics.damping) || physics.damping < 0)
    return "physics/damping: must be non-negative";
  if (!physics.gravity.allFinite()) return "physics/gravity: must be finite";
  if (physics.fixed_axis != "x" && physics.fixed_axis != "y" && physics.fixed_axis != "z")
    return "physics/fixed_axis: must be x, y or z";
  if (physics.fixed_side != "min" && physics.fixed_side != "max")
    return "physics/fixed_side: must be min or max";
  if (!std::isfinite(physics.fixed_band) || physics.fixed_band < 0)
    return "physics/fixed_band: must be non-negative";
  if (physics.threads < 1 || physics.threads > 64) return "physics/threads: must be in [1, 64]";
  return "";
}

Config loadConfigFile(const std::string& path, const Config& base) {
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    throw ConfigError(path + ": cannot open the configuration file");
  } catch (const YAML::Exception& e) {
    throw ConfigError(path + ": not valid YAML (line " + std::to_string(e.mark.line + 1) + ")");
  }
  Config c = base;
  if (!root.IsNull()) readNode(root, "", path, c);
  const std::string bad = c.check();
  if (!bad.empty()) throw ConfigError(path + ": " + bad);
  return c;
}

}  // namespace tissue_cut
