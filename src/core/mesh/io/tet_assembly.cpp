// The checks and cleanup every format shares once its tets are read.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>

#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {
namespace {

// A tet is "zero volume" below this fraction of the cube of the bounding-box diagonal: far
// below any tet a mesher would make, far above round-off of a flat tet's volume.
constexpr double kZeroVolumeRelative = 1e-12;

std::string tetRef(const RawTetMesh& raw, std::size_t tet) {
  std::string ref = "tet " + std::to_string(tet);
  if (tet < raw.origins.size()) {
    ref += " (" + raw.origin_kind + " " + std::to_string(raw.origins[tet]) + ")";
  }
  return ref;
}

}  // namespace

std::size_t maxMeshFileBytes(const MeshReadOptions& options) {
  // About 1 KiB per allowed tet covers the most verbose format (ASCII with attributes and
  // several element types per tet) with a wide margin.
  constexpr std::size_t kBaseBytes = std::size_t{256} << 20;
  constexpr std::size_t kBytesPerTet = 1024;
  const std::size_t limit = std::numeric_limits<std::size_t>::max();
  if (options.max_tets > (limit - kBaseBytes) / kBytesPerTet) return limit;
  return kBaseBytes + options.max_tets * kBytesPerTet;
}

void throwTetLimit(const std::string& name, const std::string& where, std::uint64_t count,
                   const MeshReadOptions& options) {
  throwMeshIOError(name, where,
                   std::to_string(count) + " tets, more than the limit of " +
                       std::to_string(options.max_tets) + " (MeshReadOptions::max_tets)");
}

MeshData assembleMeshData(const std::string& name, RawTetMesh raw, const MeshReadOptions& options) {
  const std::size_t num_tets = raw.corners.size() / 4;
  const std::size_t num_points = raw.xyz.size() / 3;
  if (num_tets == 0) throwMeshIOError(name, "", "no tetrahedra (4- or 10-node) in the file");
  if (num_tets > options.max_tets) throwTetLimit(name, "", num_tets, options);

  // Keep the vertices some tet uses, in file order.
  std::vector<int> new_id(num_points, -1);
  for (const std::int32_t id : raw.corners) new_id[static_cast<std::size_t>(id)] = 0;
  int num_used = 0;
  for (int& id : new_id) {
    if (id == 0) id = num_used++;
  }

  MeshData mesh;
  mesh.V.resize(num_used, 3);
  for (std::size_t i = 0; i < num_points; ++i) {
    if (new_id[i] < 0) continue;
    for (int k = 0; k < 3; ++k) {
      const double x = raw.xyz[3 * i + k];
      // The readers report non-finite coordinates where they are in the file; this is the
      // backstop for a reader that missed one.
      if (!std::isfinite(x)) {
        throwMeshIOError(name, "vertex " + std::to_string(i), "non-finite coordinate");
      }
      mesh.V(new_id[i], k) = x;
    }
  }
  std::vector<double>().swap(raw.xyz);

  mesh.T.resize(static_cast<Eigen::Index>(num_tets), 4);
  for (std::size_t t = 0; t < num_tets; ++t) {
    for (int k = 0; k < 4; ++k) {
      mesh.T(static_cast<Eigen::Index>(t), k) =
          new_id[static_cast<std::size_t>(raw.corners[4 * t + k])];
    }
  }

  const double diagonal = (mesh.V.colwise().maxCoeff() - mesh.V.colwise().minCoeff()).norm();
  const double min_volume = kZeroVolumeRelative * diagonal * diagonal * diagonal;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    const Eigen::Vector3d a = mesh.V.row(mesh.T(t, 0));
    const Eigen::Vector3d b = mesh.V.row(mesh.T(t, 1));
    const Eigen::Vector3d c = mesh.V.row(mesh.T(t, 2));
    const Eigen::Vector3d d = mesh.V.row(mesh.T(t, 3));
    const double volume = (b - a).dot((c - a).cross(d - a)) / 6.0;
    if (!(std::abs(volume) > min_volume)) {
      char detail[160];
      std::snprintf(detail, sizeof(detail),
                    "zero volume (|signed volume| %.3g <= %.0e * bbox diagonal^3 = %.3g)", volume,
                    kZeroVolumeRelative, min_volume);
      throwMeshIOError(name, tetRef(raw, static_cast<std::size_t>(t)), detail);
    }
    if (volume < 0) {
      std::swap(mesh.T(t, 2), mesh.T(t, 3));
      ++mesh.reoriented;
    }
  }
  return mesh;
}

}  // namespace tissue_cut::mesh_io
