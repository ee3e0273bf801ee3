#include "tissue_cut/cut/blade_filter.hpp"

#include <algorithm>
#include <cmath>

namespace tissue_cut {

namespace {

constexpr double kSpeedCutoff = 1.0;  // of the speed estimate [Hz] (the authors' default)

// The smoothing factor of a first-order low-pass with cutoff `hz` sampled every `dt` s.
double smoothing(double hz, double dt) {
  const double tau = 1.0 / (2.0 * M_PI * hz);
  return 1.0 / (1.0 + tau / dt);
}

}  // namespace

void BladeFilter::setParams(const BladeFilterParams& params) {
  if ((params.min_cutoff > 0.0) != enabled()) reset();
  params_ = params;
}

std::optional<BladeSegment> BladeFilter::operator()(const std::optional<BladeSegment>& tool,
                                                    double dt) {
  if (!tool || !enabled() || !(dt > 0.0)) {
    reset();
    return tool;
  }
  const double length = (tool->tip - tool->base).norm();
  if (!have_ || (tool->base - blade_.base).norm() > params_.max_jump ||
      (tool->tip - blade_.tip).norm() > params_.max_jump || !(length > 0.0)) {
    have_ = length > 0.0;
    blade_ = *tool;
    base_speed_.setZero();
    tip_speed_.setZero();
    return tool;
  }
  // The speed estimate first (from the tool's move away from the filtered blade), then the
  // blade with the cutoff that speed gives.
  const double a_speed = smoothing(kSpeedCutoff, dt);
  base_speed_ += a_speed * ((tool->base - blade_.base) / dt - base_speed_);
  tip_speed_ += a_speed * ((tool->tip - blade_.tip) / dt - tip_speed_);
  const double speed = std::max(base_speed_.norm(), tip_speed_.norm());
  const double a = smoothing(params_.min_cutoff + params_.beta * speed, dt);
  blade_.base += a * (tool->base - blade_.base);
  blade_.tip += a * (tool->tip - blade_.tip);
  // The weighted mean of blades is shorter where they turned: back to the tool's length.
  const Vec3 along = blade_.tip - blade_.base;
  const double n = along.norm();
  if (n > 0.0) blade_.tip = blade_.base + along * (length / n);
  return blade_;
}

}  // namespace tissue_cut
