#include "tissue_cut/cut/blade.hpp"

#include <cmath>

namespace tissue_cut {

BladeSegment bladeFromPose(const Vec3& origin, const Eigen::Quaterniond& q, double length) {
  BladeSegment b;
  b.base = origin;
  b.tip = origin + q.normalized() * Vec3(0.0, 0.0, -length);
  return b;
}

std::string checkPose(const Vec3& origin, const Eigen::Quaterniond& q) {
  if (!origin.allFinite()) return "position is not finite";
  if (!q.coeffs().allFinite()) return "orientation is not finite";
  const double n = q.norm();
  if (n < 1e-6) return "orientation quaternion is zero";
  if (std::abs(n - 1.0) > 0.1)
    return "orientation quaternion is not normalised (norm " + std::to_string(n) + ")";
  return "";
}

}  // namespace tissue_cut
