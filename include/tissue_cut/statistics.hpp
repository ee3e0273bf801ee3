// The model's figures: the paper's counts (#CuT, #CrT, #RmT), times, quality and tick timing.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <vector>

#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

/// The percent-th percentile of the first min(count, N) entries of a ring of the last N values
/// (count: how many were ever written into it).
template <std::size_t N>
double ringPercentile(const std::array<double, N>& ring, long long count, int percent) {
  const auto n = static_cast<std::ptrdiff_t>(std::min<long long>(count, N));
  std::array<double, N> sorted = ring;
  const auto at = sorted.begin() + n * percent / 100;
  std::nth_element(sorted.begin(), at, sorted.begin() + n);
  return *at;
}

/// Tick durations: percentiles over every recorded tick, or over the most recent ones.
class TickTimes {
 public:
  /// Records one tick that took `ms` [ms] against a deadline of `deadline_ms` [ms].
  void record(double ms, double deadline_ms);
  std::int64_t count() const { return count_; }
  std::int64_t deadlineMisses() const { return misses_; }
  /// Percentile p in [0, 100] of the ticks kept (all of them, or the last `window`).
  double percentile(double p) const;
  double max() const;
  /// Keep only the last n ticks for percentiles (0 = keep all).
  void setWindow(std::size_t n) { window_ = n; }
  void clear();

 private:
  std::vector<double> ms_;
  std::size_t window_ = 0, next_ = 0;
  std::int64_t count_ = 0, misses_ = 0;
};

struct Statistics {
  int vertices = 0, tetrahedra = 0, surface_triangles = 0;
  int initial_vertices = 0, initial_tetrahedra = 0;
  double initial_volume_rest = 0.0;
  double volume_rest = 0.0, volume_current = 0.0;
  QualitySummary quality;  ///< of the rest mesh (the material), as in the paper

  struct {
    int cut_tetrahedra = 0;      ///< tets replaced by cuts (#CuT)
    int created_tetrahedra = 0;  ///< tets made by those replacements (#CrT)
    double time_ms = 0.0;        ///< time spent in replacement (t.Repl)
    int refused = 0;             ///< replacements the mesh refused (cut left closed there)
    long long quiet_ticks = 0;   ///< ticks the blade moved on that needed no sweep (skip_quiet)
    long long quiet_refreshes = 0;  ///< ticks its quiet reach ran out and was taken anew, unswept
    long long feature_ticks = 0;  ///< ticks that tested only the kept features they reached
  } cut;
  struct {
    int collapsed_edges = 0, removed_tetrahedra = 0, pending = 0;  ///< #RmT = removed_tetrahedra
    int rejected_link = 0, rejected_inversion = 0, rejected_quality = 0, rejected_boundary = 0;
    int smoothed_vertices = 0;  ///< smoothing moves (our extension, see vertex_smoothing.hpp)
    int flips = 0;              ///< 2-3, edge removal and 2-2 flips (our extension, flips.hpp)
    int deferred_ticks = 0;     ///< ticks whose deadline left the queue no time while it held tets
    double time_ms = 0.0;       ///< t.EC
  } collapse;
  struct {
    int tetrahedra = 0;  ///< tets made by cuts that remain
    double quality_mean = 0.0, quality_min = 0.0;
    int below_tau = 0;
  } region;
  struct {
    double mass_total = 0.0, kinetic_energy = 0.0;
    int instabilities = 0;
    int springs = 0;
    std::int64_t steps = 0;
    double time_ms = 0.0;             ///< in all steps
    double cg_iterations_mean = 0.0;  ///< per implicit step
    /// Step time over (springs x CG iterations) [ns]: the cost of one spring in one iteration,
    /// the set-up of the step included.
    double ns_per_spring_iteration = 0.0;
    /// Inertia the implicit step's floor adds to the lightest vertices, over the total mass
    /// (last step).
    double inertia_added = 0.0;
    int threads = 1;  ///< threads of the implicit step
    /// Vertex clusters the implicit step's preconditioner inverts whole (last step; see
    /// MassSpringParams::cluster_preconditioner).
    int clusters = 0;
  } physics;
  struct {
    std::int64_t count = 0;
    double rate_hz = 0.0, p50_ms = 0.0, p99_ms = 0.0, max_ms = 0.0;
    std::int64_t deadline_misses = 0;
    /// The same percentiles in the thread's CPU time (what the tick cost, without the time the
    /// thread waited for a core), set by a driver that measures it (cut_replay).
    double cpu_p50_ms = 0.0, cpu_p99_ms = 0.0, cpu_max_ms = 0.0, cpu_total_ms = 0.0;
    double wall_s = 0.0;            ///< the whole replay, set by its driver
    double real_time_factor = 0.0;  ///< simulated over wall time (> 1: faster than real time)
  } ticks;

  /// The JSON layout of cut_replay --stats.
  nlohmann::json toJson() const;
};

}  // namespace tissue_cut
