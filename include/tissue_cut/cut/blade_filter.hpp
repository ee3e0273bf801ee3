// BladeFilter: smooths the blade's path before the cutter sees it, for tools whose pose trembles
// or whose tracker is noisy. A One Euro filter (Casiez, Roussel and Vogel, CHI 2012): a first-order
// low-pass whose cutoff rises with the blade's speed, so a still or slow blade loses its jitter
// and a fast one keeps up. The speed is estimated, as in the authors' reference code, from the
// tool's move away from the filtered blade, low-passed at 1 Hz. Both ends share one cutoff
// (from the faster end), so the blade is a weighted mean of its past positions; it is then set
// back to the tool's blade length along its mean direction.
#pragma once

#include <optional>

#include "tissue_cut/cut/blade.hpp"

namespace tissue_cut {

struct BladeFilterParams {
  /// Cutoff of a still blade [Hz]; 0 turns the filter off (blades pass unchanged).
  double min_cutoff = 0.0;
  /// How fast the cutoff rises with the blade's speed [1/m]: cutoff = min_cutoff + beta * speed.
  /// The speed seen includes the blade's own lag over a tick, so a blade moving steadily at v
  /// trails the tool by just under sqrt(v dt / (2 pi beta)) (dt the tick; at 1 kHz and beta 20:
  /// 0.25 mm at 1 cm/s, 0.6 mm at 5 cm/s, 1.3 mm at 26 cm/s), and catches up once it stops.
  double beta = 20.0;
  /// A tool farther than this from the filtered blade (either end) restarts the filter at the
  /// tool [m]: the cutter then sees the jump whole (see CutterOptions::max_jump).
  double max_jump = 0.02;
};

class BladeFilter {
 public:
  explicit BladeFilter(const BladeFilterParams& params = {}) : params_(params) {}

  /// The blade to cut with this tick, `dt` [s] after the last. A lifted blade (nullopt) passes and
  /// restarts the filter; so does one while the filter is off.
  std::optional<BladeSegment> operator()(const std::optional<BladeSegment>& tool, double dt);

  bool enabled() const { return params_.min_cutoff > 0.0; }
  const BladeFilterParams& params() const { return params_; }
  /// New parameters; the filter restarts when it is turned on or off.
  void setParams(const BladeFilterParams& params);
  /// Forgets the path: the next blade passes unchanged.
  void reset() { have_ = false; }

 private:
  BladeFilterParams params_;
  bool have_ = false;
  BladeSegment blade_;                                         // the last filtered blade
  Vec3 base_speed_ = Vec3::Zero(), tip_speed_ = Vec3::Zero();  // smoothed velocities [m/s]
};

}  // namespace tissue_cut
