// A recorded scalpel path (CSV `t,x,y,z,qx,qy,qz,qw`, tool poses in the mesh frame).
#pragma once

#include <Eigen/Geometry>
#include <stdexcept>
#include <string>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// A path file that cannot be used; what() names the file and line.
class PathError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

struct ToolPose {
  double t = 0.0;                ///< [s]
  Vec3 position = Vec3::Zero();  ///< tool origin in the mesh frame [m]
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  ///< tool to mesh frame
};

class ScalpelPath {
 public:
  /// Reads a CSV with the header `t,x,y,z,qx,qy,qz,qw`. Throws PathError (file and line) for a
  /// missing file, a wrong header, a row that is short or not numeric, a non-finite value, a zero
  /// quaternion, or time going backwards; an empty path is an error too.
  static ScalpelPath read(const std::string& path);
  explicit ScalpelPath(std::vector<ToolPose> poses);

  double startTime() const { return poses_.front().t; }
  double endTime() const { return poses_.back().t; }
  const std::vector<ToolPose>& poses() const { return poses_; }
  /// The pose at time t [s]: positions linearly, orientations by slerp; clamped at both ends.
  ToolPose at(double t) const;

 private:
  std::vector<ToolPose> poses_;
};

}  // namespace tissue_cut
