// Structural pre-scan of Gmsh .msh files (2.2 and 4.1, ASCII and binary).
//
// Gmsh's own parser trusts the file: a count that is too large makes it allocate or read past
// the data, an element with more tags than it expects makes it follow a parent pointer that is
// not there (an assert), a corrupted binary count sends it far into the file. So before Gmsh
// sees a byte, this pre-scan parses the same structure strictly: section markers, version,
// every declared count against the data that follows and the bytes left, every number (finite
// coordinates, tags in range), every node an element refers to, unique tags, and the tet limit.
// Gmsh then gets a copy holding only the sections it needs, exactly as validated.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "mesh_file.hpp"
#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut::mesh_io {

struct MshLayout {
  bool binary = false;
  /// $MeshFormat, $PhysicalNames, $Entities, $Nodes and $Elements as validated, with their
  /// markers rewritten as "$Name\n" ... "$EndName\n": the only bytes handed to Gmsh. Other
  /// sections (post-processing data, periodicity, comments) are checked to be closed and left
  /// out, which also keeps Gmsh from reading them.
  std::string gmsh_input;
  std::vector<std::uint64_t> node_tags;  ///< in file order
  std::vector<std::uint64_t> tet_tags;   ///< tags of the 4- and 10-node tets, in file order
};

/// Throws MeshIOError (file name, line or byte offset, what is wrong) for anything Gmsh should
/// not be given.
MshLayout prescanGmshMesh(const MeshFile& file, const MeshReadOptions& options);

}  // namespace tissue_cut::mesh_io
