// The scalpel's blade: a segment in the mesh frame, from a tool pose.
#pragma once

#include <Eigen/Geometry>
#include <string>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// The blade at one instant, in the mesh frame [m]: from the tool origin (base) to the tip.
struct BladeSegment {
  Vec3 base = Vec3::Zero();
  Vec3 tip = Vec3::Zero();
};

/// The blade of a tool at `origin` [m] with orientation `q` (tool to mesh frame): it lies along
/// the tool's -z axis, `length` [m] long. q need not be normalised (it is normalised here).
BladeSegment bladeFromPose(const Vec3& origin, const Eigen::Quaterniond& q, double length);

/// Why a tool pose is unusable ("position is not finite", "quaternion is zero"...), or "".
std::string checkPose(const Vec3& origin, const Eigen::Quaterniond& q);

}  // namespace tissue_cut
