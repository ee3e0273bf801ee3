// readMesh() and writeMesh(): the format is chosen by extension; the formats live in io/.
#include "tissue_cut/mesh/mesh_io.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <new>
#include <utility>
#include <vector>

#include "io/mesh_formats.hpp"

namespace tissue_cut {
namespace {

std::string lowercaseExtension(const std::string& path) {
  std::string extension = std::filesystem::path(path).extension().string();
  std::transform(extension.begin(), extension.end(), extension.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return extension;
}

std::string replaceExtension(const std::string& path, const std::string& extension) {
  return std::filesystem::path(path).replace_extension(extension).string();
}

}  // namespace

MeshData readMesh(const std::string& path, const MeshReadOptions& options) {
  const std::string extension = lowercaseExtension(path);
  std::string name = mesh_io::displayName(path);
  try {
    mesh_io::RawTetMesh raw;
    if (extension == ".node" || extension == ".ele") {
      raw = mesh_io::readTetGenMesh(path, options, name);
    } else if (extension == ".msh" || extension == ".vtk" || extension == ".stl") {
      const mesh_io::MeshFile file =
          mesh_io::loadMeshFile(path, mesh_io::maxMeshFileBytes(options));
      if (extension == ".msh") {
        raw = mesh_io::readGmshMesh(file, options);
      } else if (extension == ".vtk") {
        raw = mesh_io::readVtkLegacyMesh(file, options);
      } else {
        raw = mesh_io::readStlSurfaceAsTets(file, options);
      }
    } else {
      mesh_io::throwMeshIOError(
          name, "",
          "unknown extension \"" + extension + "\" (expected .msh, .node, .ele, .vtk or .stl)");
    }
    return mesh_io::assembleMeshData(name, std::move(raw), options);
  } catch (const std::bad_alloc&) {
    // Declared counts are checked against the file size, so this takes a file that is huge
    // and consistent; still an unreadable file, not a crash.
    mesh_io::throwMeshIOError(name, "", "out of memory while reading");
  }
}

namespace {

// A Morton code's cells along each axis (21 bits: three axes in 63).
constexpr int kMortonCells = (1 << 21) - 1;

// x's lowest 21 bits spread to every third bit of a 64-bit word.
std::uint64_t spreadBits(std::uint64_t x) {
  x &= 0x1fffff;
  x = (x | x << 32) & 0x1f00000000ffffULL;
  x = (x | x << 16) & 0x1f0000ff0000ffULL;
  x = (x | x << 8) & 0x100f00f00f00f00fULL;
  x = (x | x << 4) & 0x10c30c30c30c30c3ULL;
  x = (x | x << 2) & 0x1249249249249249ULL;
  return x;
}

}  // namespace

MeshData spatiallyOrdered(const MeshData& mesh) {
  const int nv = static_cast<int>(mesh.V.rows()), nt = static_cast<int>(mesh.T.rows());
  if (nv == 0) return mesh;
  const Eigen::RowVector3d lo = mesh.V.colwise().minCoeff();
  const double extent = (mesh.V.colwise().maxCoeff() - lo).maxCoeff();
  const double scale = extent > 0 ? kMortonCells / extent : 0.0;
  std::vector<std::pair<std::uint64_t, int>> code(nv);
  for (int v = 0; v < nv; ++v) {
    std::uint64_t c = 0;
    for (int k = 0; k < 3; ++k) {
      const double q = std::clamp((mesh.V(v, k) - lo[k]) * scale, 0.0, double{kMortonCells});
      c |= spreadBits(static_cast<std::uint64_t>(q)) << k;
    }
    code[v] = {c, v};
  }
  std::sort(code.begin(), code.end());
  MeshData out;
  out.reoriented = mesh.reoriented;
  out.V.resize(nv, 3);
  std::vector<int> new_id(nv);
  for (int k = 0; k < nv; ++k) {
    out.V.row(k) = mesh.V.row(code[k].second);
    new_id[code[k].second] = k;
  }
  std::vector<std::pair<int, int>> tet_order(nt);
  for (int t = 0; t < nt; ++t) {
    int lowest = nv;
    for (int c = 0; c < 4; ++c) lowest = std::min(lowest, new_id[mesh.T(t, c)]);
    tet_order[t] = {lowest, t};
  }
  std::sort(tet_order.begin(), tet_order.end());
  out.T.resize(nt, 4);
  for (int k = 0; k < nt; ++k)
    for (int c = 0; c < 4; ++c) out.T(k, c) = new_id[mesh.T(tet_order[k].second, c)];
  return out;
}

namespace mesh_io {

void checkWriteData(const std::string& path, const MeshWriteData& data) {
  const std::string name = displayName(path);
  const auto refuse = [&name](const std::string& what) {
    throwMeshIOError(name, "", "not written: " + what);
  };
  if (data.V.cols() != 3) refuse("V has " + std::to_string(data.V.cols()) + " columns, not 3");
  if (data.T.cols() != 4) refuse("T has " + std::to_string(data.T.cols()) + " columns, not 4");
  for (Eigen::Index v = 0; v < data.V.rows(); ++v) {
    if (!data.V.row(v).allFinite()) refuse("vertex " + std::to_string(v) + " is not finite");
  }
  for (Eigen::Index t = 0; t < data.T.rows(); ++t) {
    for (int k = 0; k < 4; ++k) {
      if (data.T(t, k) < 0 || data.T(t, k) >= data.V.rows()) {
        refuse("tet " + std::to_string(t) + ": vertex id " + std::to_string(data.T(t, k)) +
               " out of range [0, " + std::to_string(data.V.rows() - 1) + "]");
      }
    }
  }
  if (data.rest.size() > 0 && (data.rest.rows() != data.V.rows() || data.rest.cols() != 3)) {
    refuse("rest is " + std::to_string(data.rest.rows()) + " x " +
           std::to_string(data.rest.cols()) + ", not " + std::to_string(data.V.rows()) + " x 3");
  }
  if (data.rest.size() > 0 && !data.rest.allFinite()) refuse("rest holds non-finite values");
  if (data.quality.size() > 0 && data.quality.size() != data.T.rows()) {
    refuse("quality has " + std::to_string(data.quality.size()) + " values for " +
           std::to_string(data.T.rows()) + " tets");
  }
  // VTK's own legacy reader stops at "nan", so such a file would not open there.
  if (data.quality.size() > 0 && !data.quality.allFinite())
    refuse("quality holds non-finite values");
  if (data.cut_region.size() > 0 && data.cut_region.size() != data.T.rows()) {
    refuse("cut_region has " + std::to_string(data.cut_region.size()) + " values for " +
           std::to_string(data.T.rows()) + " tets");
  }
}

}  // namespace mesh_io

void writeMesh(const std::string& path, const MeshWriteData& data) {
  const std::string extension = lowercaseExtension(path);
  if (extension != ".vtk" && extension != ".node" && extension != ".ele" && extension != ".msh") {
    mesh_io::throwMeshIOError(
        mesh_io::displayName(path), "",
        "unknown extension \"" + extension + "\" (expected .vtk, .node, .ele or .msh)");
  }
  mesh_io::checkWriteData(path, data);
  if (extension == ".vtk") {
    mesh_io::writeVtkLegacyMesh(path, data);
  } else if (extension == ".msh") {
    mesh_io::writeGmsh22Mesh(path, data);
  } else {
    const bool upper = std::isupper(
        static_cast<unsigned char>(std::filesystem::path(path).extension().string().back()));
    mesh_io::writeTetGenMesh(replaceExtension(path, upper ? ".NODE" : ".node"),
                             replaceExtension(path, upper ? ".ELE" : ".ele"), data);
  }
}

}  // namespace tissue_cut
