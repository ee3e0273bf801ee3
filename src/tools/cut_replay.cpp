// cut_replay: replays a scalpel path over a tissue mesh offline, through the same Tissue::step as
// the node, and reports the mesh and its statistics.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <iostream>
#include <optional>
#include <string>
#include <vector>

#include "tissue_cut/config.hpp"
#include "bag_path.hpp"
#include "heap_count.hpp"
#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"
#include "tissue_cut/tissue.hpp"

#if defined(__SANITIZE_ADDRESS__)
// Gmsh 4.8 keeps a few KB per STL tetrahedralisation inside libgmsh until exit.
extern "C" const char* __lsan_default_suppressions() { return "leak:libgmsh.so\n"; }
#endif

namespace {

// CPU time of this thread [ms]: a tick's own cost, without time spent waiting for a core.
double threadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

constexpr int kExitUsage = 1;
constexpr int kExitInput = 2;
constexpr int kExitInvalid = 3;

const char* kUsage = R"(usage: cut_replay [options]
Replays a scalpel path over a tissue mesh, offline, with the node's own Tissue::step.
  --mesh FILE          mesh (.msh .node .ele .vtk .stl); default: the built-in block
  --config FILE.yaml   configuration keys (see config/tissue.yaml); flags override it
  --path FILE.csv      scalpel path, header t,x,y,z,qx,qy,qz,qw (mesh frame, seconds)
  --bag FILE.bag       scalpel path from a rosbag of geometry_msgs/PoseStamped (with --topic)
  --topic NAME         the bag's pose topic, e.g. /tissue/scalpel_pose
  --blade-length L     blade length [m] (cut/blade_length)
  --rate HZ            ticks per second (rate), default 1000
  --settle SECONDS     keep simulating this long after the path ends (blade stays put);
                       then one tick lifts the blade out, and up to as long again
                       works off the collapse queue (blade away)
  --no-physics         physics/enabled = false
  --no-collapse        collapse/enabled = false (edge collapse behind the cut is on by default)
  --tau T              collapse/tau
  --check              run TetMesh::validate() after every tick; stop at the first violation
  --out FILE           write the final mesh (.vtk .node .msh)
  --stats FILE.json    write the statistics as JSON
  --tick-log FILE.csv  write one row a tick: its wall and CPU time and what it spent them on
                       (cutter, collapse queue, physics [ms]), CG iterations, tets cut, edges
                       collapsed
  --quiet              print nothing but errors
exit status: 0 done, 1 bad usage, 2 unusable input (mesh, config, path, output), 3 --check failed
)";

struct Options {
  std::string mesh, config, path, out, stats, bag, topic, tick_log;
  std::optional<double> blade_length, rate, tau;
  double settle = 0.0;
  bool no_physics = false, no_collapse = false, check = false, quiet = false;
  bool mesh_given = false;
};

bool parseNumber(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size() && std::isfinite(*value);
}

// Returns an error message, or "" when the arguments parse.
std::string parseArgs(int argc, char** argv, Options* o) {
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    auto value = [&](std::string* into) -> std::string {
      if (i + 1 >= argc) return a + " needs a value";
      *into = argv[++i];
      return "";
    };
    auto number = [&](std::optional<double>* into) -> std::string {
      std::string text;
      std::string err = value(&text);
      if (!err.empty()) return err;
      double x;
      if (!parseNumber(text, &x)) return a + ": '" + text + "' is not a finite number";
      *into = x;
      return "";
    };
    std::string err;
    if (a == "--mesh") {
      err = value(&o->mesh);
      o->mesh_given = true;
    } else if (a == "--config") {
      err = value(&o->config);
    } else if (a == "--path") {
      err = value(&o->path);
    } else if (a == "--bag") {
      err = value(&o->bag);
    } else if (a == "--topic") {
      err = value(&o->topic);
    } else if (a == "--out") {
      err = value(&o->out);
    } else if (a == "--stats") {
      err = value(&o->stats);
    } else if (a == "--tick-log") {
      err = value(&o->tick_log);
    } else if (a == "--blade-length") {
      err = number(&o->blade_length);
    } else if (a == "--rate") {
      err = number(&o->rate);
    } else if (a == "--tau") {
      err = number(&o->tau);
    } else if (a == "--settle") {
      std::optional<double> s;
      err = number(&s);
      if (err.empty() && *s < 0) err = "--settle must not be negative";
      if (err.empty()) o->settle = *s;
    } else if (a == "--no-physics") {
      o->no_physics = true;
    } else if (a == "--no-collapse") {
      o->no_collapse = true;
    } else if (a == "--check") {
      o->check = true;
    } else if (a == "--quiet") {
      o->quiet = true;
    } else if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      std::exit(0);
    } else {
      err = "unknown option '" + a + "'";
    }
    if (!err.empty()) return err;
  }
  if (!o->bag.empty() && o->topic.empty()) return "--bag needs --topic";
  if (o->bag.empty() && !o->topic.empty()) return "--topic goes with --bag";
  if (!o->bag.empty() && !o->path.empty()) return "give --path or --bag, not both";
  return "";
}

void printSummary(const tissue_cut::Statistics& s) {
  std::printf("mesh        %d vertices, %d tetrahedra, %d surface triangles\n", s.vertices,
              s.tetrahedra, s.surface_triangles);
  std::printf("initial     %d vertices, %d tetrahedra, rest volume %.9g m^3\n", s.initial_vertices,
              s.initial_tetrahedra, s.initial_volume_rest);
  std::printf("volume      rest %.9g m^3, current %.9g m^3\n", s.volume_rest, s.volume_current);
  std::printf("quality     min %.6f, mean %.6f (rest mesh, Q = 3 r_in / R_circ)\n", s.quality.min,
              s.quality.mean);
  std::printf("cut         %d cut tets, %d created tets, %.3f ms, %d replacements refused\n",
              s.cut.cut_tetrahedra, s.cut.created_tetrahedra, s.cut.time_ms, s.cut.refused);
  std::printf(
      "collapse    %d edges, %d tets removed, %d pending, %.3f ms; refused: link %d, inversion %d, "
      "quality %d, boundary %d; %d smoothing moves, %d flips; %d ticks deferred\n",
      s.collapse.collapsed_edges, s.collapse.removed_tetrahedra, s.collapse.pending,
      s.collapse.time_ms, s.collapse.rejected_link, s.collapse.rejected_inversion,
      s.collapse.rejected_quality, s.collapse.rejected_boundary, s.collapse.smoothed_vertices,
      s.collapse.flips, s.collapse.deferred_ticks);
  std::printf("region      %d tets, quality mean %.4f, min %.4f, %d below tau\n",
              s.region.tetrahedra, s.region.quality_mean, s.region.quality_min, s.region.below_tau);
  std::printf("physics     mass %.6g kg, kinetic energy %.3g J, %d instabilities\n",
              s.physics.mass_total, s.physics.kinetic_energy, s.physics.instabilities);
  if (s.physics.steps > 0)
    std::printf(
        "            %lld steps, %.3f ms a step, %.1f CG iterations a step, %d springs, %.2f ns "
        "per "
        "spring per CG iteration\n",
        static_cast<long long>(s.physics.steps), s.physics.time_ms / s.physics.steps,
        s.physics.cg_iterations_mean, s.physics.springs, s.physics.ns_per_spring_iteration);
  std::printf("ticks       %lld at %.0f Hz: p50 %.4f ms, p99 %.4f ms, max %.4f ms, %lld misses\n",
              static_cast<long long>(s.ticks.count), s.ticks.rate_hz, s.ticks.p50_ms,
              s.ticks.p99_ms, s.ticks.max_ms, static_cast<long long>(s.ticks.deadline_misses));
  std::printf("            thread CPU time: p50 %.4f ms, p99 %.4f ms, max %.4f ms, all %.3f ms\n",
              s.ticks.cpu_p50_ms, s.ticks.cpu_p99_ms, s.ticks.cpu_max_ms, s.ticks.cpu_total_ms);
}

}  // namespace

int main(int argc, char** argv) {
  using namespace tissue_cut;
  Options opt;
  const std::string usage_error = parseArgs(argc, argv, &opt);
  if (!usage_error.empty()) {
    std::cerr << "cut_replay: " << usage_error << "\n" << kUsage;
    return kExitUsage;
  }

  Config config;
  std::optional<ScalpelPath> path;
  std::optional<Tissue> tissue;
  try {
    if (!opt.config.empty()) config = loadConfigFile(opt.config, config);
    if (opt.mesh_given) config.mesh = opt.mesh;
    if (opt.blade_length) config.cut.blade_length = *opt.blade_length;
    if (opt.rate) config.rate = *opt.rate;
    if (opt.tau) config.collapse.tau = *opt.tau;
    if (opt.no_physics) config.physics.enabled = false;
    if (opt.no_collapse) config.collapse.enabled = false;
    const std::string bad = config.check();
    if (!bad.empty()) throw ConfigError(bad);
    if (!opt.path.empty()) path = ScalpelPath::read(opt.path);
    if (!opt.bag.empty()) path = readBagPath(opt.bag, opt.topic, config.frame_id);
    tissue.emplace(config, loadTissueMesh(config));
  } catch (const std::exception& e) {
    std::cerr << "cut_replay: " << e.what() << "\n";
    return kExitInput;
  }
  // Opened before the replay, so that an unwritable name costs nothing; the rows are kept in
  // memory and written after it, so that the file does not share the ticks' time.
  std::ofstream tick_log;
  if (!opt.tick_log.empty()) {
    tick_log.open(opt.tick_log);
    if (!tick_log) {
      std::cerr << "cut_replay: " << opt.tick_log << ": cannot write the tick log\n";
      return kExitInput;
    }
  }
  struct TickRow {
    long long k;
    double wall_ms, cpu_ms, cut_ms, collapse_ms, physics_ms;
    long long cg_iterations;
    int cut_tets, collapses;
    long long allocations;
  };
  std::vector<TickRow> rows;
  if (opt.check) {
    const std::string err = tissue->validate();
    if (!err.empty()) {
      std::cerr << "cut_replay: the mesh as loaded is invalid: " << err << "\n";
      return kExitInvalid;
    }
  }

  // Ticks at `rate` over the path, then `settle` seconds more with the blade where it ended.
  const double dt = 1.0 / config.rate;
  const double t0 = path ? path->startTime() : 0.0;
  const double t_path = path ? path->endTime() : 0.0;
  const auto ticks = static_cast<long long>(std::ceil((t_path - t0 + opt.settle) / dt - 1e-9));
  const double deadline_ms = 1000.0 * dt;
  const auto wall_start = std::chrono::steady_clock::now();
  TickTimes cpu_times;
  double cpu_total_ms = 0.0;
  // Heap allocations made during the ticks (any thread): in all, on how many ticks, the most.
  long long allocations = 0, allocating_ticks = 0, allocations_max = 0;
  // The last tick takes the blade away (lifted out of the tissue), so the cut it made is finished:
  // every tet it was still inside is replaced and opened. With --settle, the ticks after it (up to
  // `settle` seconds more, blade away) work off what the collapse queue still holds: a path that
  // ends inside the tissue leaves the tets around the blade busy until it is lifted.
  auto tick = [&](long long k, const std::optional<BladeSegment>& blade) {
    // What the parts have spent so far (their counters only add up), for the tick log.
    const CutCounts cut0 = tissue->cutter().counts();
    const CollapseCounts collapse0 = tissue->collapse().counts();
    const double physics0 = tissue->physics().timeMs();
    const long long cg0 = tissue->physics().totalIterations();
    const auto start = std::chrono::steady_clock::now();
    const double cpu_start = threadCpuMs();
    const long long heap0 = heapAllocations();
    const std::string warning = tissue->step(blade, dt);
    const long long heap = heapAllocations() - heap0;
    const double cpu_ms = threadCpuMs() - cpu_start;
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    allocations += heap;
    allocating_ticks += heap > 0 ? 1 : 0;
    allocations_max = std::max(allocations_max, heap);
    if (tick_log.is_open()) {
      const CutCounts& cut = tissue->cutter().counts();
      const CollapseCounts& collapse = tissue->collapse().counts();
      rows.push_back({k, ms, cpu_ms, cut.time_ms - cut0.time_ms,
                      collapse.time_ms - collapse0.time_ms,
                      tissue->physics().timeMs() - physics0,
                      tissue->physics().totalIterations() - cg0,
                      cut.cut_tetrahedra - cut0.cut_tetrahedra,
                      collapse.collapsed_edges - collapse0.collapsed_edges, heap});
    }
    if (!warning.empty() && !opt.quiet)
      std::cerr << "cut_replay: tick " << k << ": " << warning << "\n";
    tissue->tickTimes().record(ms, deadline_ms);
    cpu_times.record(cpu_ms, deadline_ms);
    cpu_total_ms += cpu_ms;
    if (opt.check) {
      const std::string err = tissue->validate();
      if (!err.empty()) {
        std::cerr << "cut_replay: tick " << k << " (t = " << t0 + k * dt
                  << " s): invalid mesh: " << err << "\n";
        return false;
      }
    }
    return true;
  };
  long long k = 1;
  for (; k <= ticks + 1; ++k) {
    std::optional<BladeSegment> blade;
    if (path && k <= ticks) {
      const ToolPose pose = path->at(std::min(t0 + k * dt, t_path));
      blade = bladeFromPose(pose.position, pose.orientation, config.cut.blade_length);
    }
    if (!tick(k, blade)) return kExitInvalid;
  }
  const auto after = static_cast<long long>(std::ceil(opt.settle / dt - 1e-9));
  for (long long i = 0; i < after && config.collapse.enabled && tissue->collapse().pending() > 0;
       ++i, ++k)
    if (!tick(k, std::nullopt)) return kExitInvalid;
  const double wall_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();

  Statistics stats = tissue->statistics();
  stats.ticks.rate_hz = config.rate;
  stats.ticks.wall_s = wall_s;
  stats.ticks.cpu_p50_ms = cpu_times.percentile(50);
  stats.ticks.cpu_p99_ms = cpu_times.percentile(99);
  stats.ticks.cpu_max_ms = cpu_times.max();
  stats.ticks.cpu_total_ms = cpu_total_ms;
  stats.ticks.real_time_factor = wall_s > 0 ? cpu_times.count() * dt / wall_s : 0.0;
  try {
    if (tick_log.is_open()) {
      tick_log << "tick,t,wall_ms,cpu_ms,cut_ms,collapse_ms,physics_ms,cg_iterations,cut_tets,"
                  "collapses,allocations\n";
      char line[256];
      for (const TickRow& r : rows) {
        std::snprintf(line, sizeof(line), "%lld,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%lld,%d,%d,%lld\n",
                      r.k, t0 + r.k * dt, r.wall_ms, r.cpu_ms, r.cut_ms, r.collapse_ms,
                      r.physics_ms, r.cg_iterations, r.cut_tets, r.collapses, r.allocations);
        tick_log << line;
      }
      tick_log.close();
      if (!tick_log) throw std::runtime_error(opt.tick_log + ": writing the tick log failed");
    }
    if (!opt.out.empty()) writeMesh(opt.out, tissue->exportMesh());
    if (!opt.stats.empty()) {
      std::ofstream f(opt.stats);
      if (!f) throw std::runtime_error(opt.stats + ": cannot write the statistics file");
      nlohmann::json j = stats.toJson();
      j["ticks"]["allocations"] = {{"total", allocations},
                                   {"ticks_allocating", allocating_ticks},
                                   {"max_per_tick", allocations_max}};
      f << j.dump(2) << "\n";
      if (!f) throw std::runtime_error(opt.stats + ": writing the statistics failed");
    }
  } catch (const std::exception& e) {
    std::cerr << "cut_replay: " << e.what() << "\n";
    return kExitInput;
  }
  if (!opt.quiet) {
    printSummary(stats);
    const auto& kinds = tissue->cutter().counts().by_kind;
    std::printf("splits      ");
    for (int k = 0; k < static_cast<int>(kinds.size()); ++k)
      if (kinds[k]) std::printf("%s %d  ", splitKindName(static_cast<SplitKind>(k)), kinds[k]);
    std::printf(" separated vertices %d, vertices waiting to separate %d (%lld splits simulated)\n",
                tissue->cutter().counts().separated_vertices, tissue->cutter().numDeferred(),
                tissue->cutter().counts().separation_tries);
    std::printf("replay      %lld ticks (%.3f simulated s) in %.3f s wall: real-time factor %.2f\n",
                ticks + 1, (ticks + 1) * dt, wall_s, stats.ticks.real_time_factor);
    std::printf("heap        %lld allocations during the ticks, on %lld of them (at most %lld in "
                "one)\n",
                allocations, allocating_ticks, allocations_max);
  }
  return 0;
}
