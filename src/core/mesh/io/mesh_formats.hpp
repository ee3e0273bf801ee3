// The format readers and writers behind readMesh() and writeMesh(). Each reader returns the
// tetrahedra as they are in the file; assembleMeshData() applies the checks and cleanup that are
// the same for every format.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "mesh_file.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut::mesh_io {

/// Tetrahedra as a reader found them, before unused vertices are dropped and orientation fixed.
struct RawTetMesh {
  std::vector<double> xyz;            ///< 3 per vertex, in file order; finite where tets use it
  std::vector<std::int32_t> corners;  ///< 4 per tet: 0-based positions in xyz / 3, in range
  /// Per tet, how the file refers to it (an element tag, a line, a cell index); empty when the
  /// tets were made here and the file has no such reference.
  std::vector<std::int64_t> origins;
  std::string origin_kind;  ///< "element", "line", "cell"
};

/// Drops the vertices no tet uses (the rest keep their file order), flips negatively oriented
/// tets and refuses zero-volume ones, an empty mesh, or one above options.max_tets.
/// `name` is the file the tets came from, for error messages.
MeshData assembleMeshData(const std::string& name, RawTetMesh raw, const MeshReadOptions& options);

/// Largest file readMesh() loads: generous for any mesh within options.max_tets, but it keeps a
/// wrong path to a multi-gigabyte file from being pulled into memory.
std::size_t maxMeshFileBytes(const MeshReadOptions& options);

/// "<name>: <where>: N tets, more than the limit of M (MeshReadOptions::max_tets)".
[[noreturn]] void throwTetLimit(const std::string& name, const std::string& where,
                                std::uint64_t count, const MeshReadOptions& options);

/// Gmsh .msh 2.2 or 4.1: pre-scanned here, then read through the Gmsh API.
RawTetMesh readGmshMesh(const MeshFile& file, const MeshReadOptions& options);
/// TetGen .node/.ele pair; `path` names either file. Sets `name` to the .ele file name, which
/// is where later per-tet errors point.
RawTetMesh readTetGenMesh(const std::string& path, const MeshReadOptions& options,
                          std::string& name);
/// VTK legacy unstructured grid, ASCII or BINARY.
RawTetMesh readVtkLegacyMesh(const MeshFile& file, const MeshReadOptions& options);
/// Closed STL surface, tetrahedralised with Gmsh.
RawTetMesh readStlSurfaceAsTets(const MeshFile& file, const MeshReadOptions& options);

/// Refuses data whose arrays do not fit together (wrong widths, ids out of range, optional
/// arrays of the wrong length, non-finite values), naming the file that was to be written.
void checkWriteData(const std::string& path, const MeshWriteData& data);

void writeVtkLegacyMesh(const std::string& path, const MeshWriteData& data);
void writeTetGenMesh(const std::string& node_path, const std::string& ele_path,
                     const MeshWriteData& data);
void writeGmsh22Mesh(const std::string& path, const MeshWriteData& data);

}  // namespace tissue_cut::mesh_io
