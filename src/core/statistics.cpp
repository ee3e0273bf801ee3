#include "tissue_cut/statistics.hpp"

#include <algorithm>

namespace tissue_cut {

void TickTimes::record(double ms, double deadline_ms) {
  ++count_;
  if (ms > deadline_ms) ++misses_;
  if (window_ == 0 || ms_.size() < window_) {
    ms_.push_back(ms);
  } else {
    ms_[next_] = ms;
    next_ = (next_ + 1) % window_;
  }
}

double TickTimes::percentile(double p) const {
  if (ms_.empty()) return 0.0;
  std::vector<double> sorted = ms_;
  const std::size_t k =
      std::min(sorted.size() - 1, static_cast<std::size_t>(p / 100.0 * (sorted.size() - 1) + 0.5));
  std::nth_element(sorted.begin(), sorted.begin() + k, sorted.end());
  return sorted[k];
}

double TickTimes::max() const {
  return ms_.empty() ? 0.0 : *std::max_element(ms_.begin(), ms_.end());
}

void TickTimes::clear() {
  ms_.clear();
  next_ = 0;
  count_ = misses_ = 0;
}

nlohmann::json Statistics::toJson() const {
  using nlohmann::json;
  json j;
  j["mesh"] = {
      {"vertices", vertices}, {"tetrahedra", tetrahedra}, {"surface_triangles", surface_triangles}};
  j["initial"] = {{"vertices", initial_vertices},
                  {"tetrahedra", initial_tetrahedra},
                  {"volume_rest", initial_volume_rest}};
  j["volume_rest"] = volume_rest;
  j["volume_current"] = volume_current;
  j["quality"] = {
      {"min", quality.min},
      {"mean", quality.mean},
      {"histogram", std::vector<int>(quality.histogram.begin(), quality.histogram.end())}};
  j["cut"] = {{"cut_tetrahedra", cut.cut_tetrahedra},
              {"created_tetrahedra", cut.created_tetrahedra},
              {"time_ms", cut.time_ms},
              {"refused", cut.refused},
              {"quiet_ticks", cut.quiet_ticks},
              {"quiet_refreshes", cut.quiet_refreshes},
              {"feature_ticks", cut.feature_ticks}};
  j["collapse"] = {{"collapsed_edges", collapse.collapsed_edges},
                   {"removed_tetrahedra", collapse.removed_tetrahedra},
                   {"pending", collapse.pending},
                   {"smoothed_vertices", collapse.smoothed_vertices},
                   {"flips", collapse.flips},
                   {"deferred_ticks", collapse.deferred_ticks},
                   {"rejected",
                    {{"link", collapse.rejected_link},
                     {"inversion", collapse.rejected_inversion},
                     {"quality", collapse.rejected_quality},
                     {"boundary", collapse.rejected_boundary}}},
                   {"time_ms", collapse.time_ms}};
  j["region"] = {{"tetrahedra", region.tetrahedra},
                 {"quality_mean", region.quality_mean},
                 {"quality_min", region.quality_min},
                 {"below_tau", region.below_tau}};
  j["physics"] = {{"mass_total", physics.mass_total},
                  {"kinetic_energy", physics.kinetic_energy},
                  {"instabilities", physics.instabilities},
                  {"springs", physics.springs},
                  {"steps", physics.steps},
                  {"time_ms", physics.time_ms},
                  {"cg_iterations_mean", physics.cg_iterations_mean},
                  {"ns_per_spring_iteration", physics.ns_per_spring_iteration},
                  {"inertia_added", physics.inertia_added},
                  {"threads", physics.threads},
                  {"clusters", physics.clusters}};
  j["ticks"] = {{"count", ticks.count},           {"rate_hz", ticks.rate_hz},
                {"p50_ms", ticks.p50_ms},         {"p99_ms", ticks.p99_ms},
                {"max_ms", ticks.max_ms},         {"deadline_misses", ticks.deadline_misses},
                {"cpu_p50_ms", ticks.cpu_p50_ms}, {"cpu_p99_ms", ticks.cpu_p99_ms},
                {"cpu_max_ms", ticks.cpu_max_ms}, {"cpu_total_ms", ticks.cpu_total_ms},
                {"wall_s", ticks.wall_s},         {"real_time_factor", ticks.real_time_factor}};
  return j;
}

}  // namespace tissue_cut
