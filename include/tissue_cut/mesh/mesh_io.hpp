// Reading and writing tetrahedral meshes: Gmsh .msh (2.2, 4.1), TetGen .node/.ele, VTK legacy
// unstructured grids (ASCII, binary), closed STL surfaces (tetrahedralised with Gmsh).
#pragma once

#include <Eigen/Core>
#include <cstddef>
#include <stdexcept>
#include <string>

namespace tissue_cut {

/// A file that cannot be read. what() names the file and where in it ("f.msh: line 12: ...").
class MeshIOError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Options of readMesh.
struct MeshReadOptions {
  /// More tetrahedra than this is refused (protects memory) [count].
  std::size_t max_tets = 2000000;
  /// Target edge length when an STL surface is tetrahedralised [m]; 0 picks 1/20 of the
  /// bounding-box diagonal.
  double stl_mesh_size = 0.0;
};

/// A tetrahedral mesh as plain arrays, as read from a file.
struct MeshData {
  Eigen::MatrixXd V;   ///< #V by 3 vertex positions [m] (only vertices used by a tet are kept)
  Eigen::MatrixXi T;   ///< #T by 4 vertex ids into V, positively oriented
  int reoriented = 0;  ///< tets that were negatively oriented in the file and were flipped
};

/// Reads the tetrahedra of a mesh file, chosen by extension: .msh, .node or .ele (TetGen pair),
/// .vtk, .stl. Points, lines, triangles and other cells are ignored; a 10-node tet keeps its 4
/// corners. Unused vertices are dropped and the rest renumbered in file order.
/// Throws MeshIOError for a missing, empty, malformed or truncated file, a non-finite coordinate,
/// an index out of range, a zero-volume tet, or more than options.max_tets tets.
///
/// Error messages read "<file name>: <where>: <what>", where <where> is "line N" or "byte offset
/// N" (binary data) for a place in the file, or "tet N (element E)" / "(line L)" / "(cell C)" for
/// the N-th tet, counted from 0 in file order (its row in MeshData::T).
/// A .msh file is checked structurally before Gmsh reads it, since Gmsh's parser trusts its
/// input. An .stl surface must be closed; Gmsh fills it with tets of edge length about
/// options.stl_mesh_size.
MeshData readMesh(const std::string& path, const MeshReadOptions& options = {});

/// The same mesh renumbered for memory locality: vertices in the order of a Morton (Z-order)
/// curve through their bounding box (21 bits an axis; ties in file order), then tets by their
/// lowest new vertex id (ties in file order). Each tet keeps its corners' order (orientation and
/// volume as before). Mesh generators number vertices by how they were made (TetGen: the surface
/// first, then the inside), so that a vertex's neighbours lie anywhere in the arrays: on the
/// ~20k-tet organ the median id gap along an edge falls from 1,039 to 13, and the physics step's
/// and the cutter's loops find their neighbours' data in cache (see README, Performance).
MeshData spatiallyOrdered(const MeshData& mesh);

/// What writeMesh writes. Optional arrays may be left empty.
struct MeshWriteData {
  Eigen::MatrixXd V;           ///< #V by 3 current positions [m]
  Eigen::MatrixXi T;           ///< #T by 4 vertex ids
  Eigen::MatrixXd rest;        ///< #V by 3 rest positions [m] (VTK point data `rest`), optional
  Eigen::VectorXd quality;     ///< #T quality Q (VTK cell data `quality`), optional
  Eigen::VectorXi cut_region;  ///< #T 1 for tets made by cuts else 0 (VTK cell data), optional
};

/// Writes a mesh chosen by extension: .vtk (legacy ASCII with point/cell data), .node or .ele
/// (writes both files of the TetGen pair), .msh (Gmsh 2.2 ASCII). Throws MeshIOError when the
/// file cannot be written or the extension is unknown, and writes nothing when the arrays do not
/// fit together (ids out of range, optional arrays of the wrong size, non-finite values), since
/// such a file could not be read back.
void writeMesh(const std::string& path, const MeshWriteData& data);

}  // namespace tissue_cut
