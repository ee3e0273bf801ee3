// The built-in tissue block, used when no mesh file is given.
#pragma once

#include "tissue_cut/mesh/mesh_io.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// An axis-aligned box filled with tetrahedra: a grid of near-cubic cells, each split into the six
/// Kuhn tets around its main diagonal (conforming across cells, worst Q ~0.6 on cubic cells).
struct BlockSpec {
  Vec3 min{-0.05, -0.03, 0.0};  ///< lower corner [m]
  Vec3 max{0.05, 0.03, 0.03};   ///< upper corner [m]
  double cell_size = 0.006;     ///< target cell edge [m]; 0.006 gives 5,100 tets
};

/// Inputs: spec. Outputs: V #V by 3 [m], T #T by 4, positively oriented.
/// Throws std::invalid_argument for an empty box or a cell size that is not positive or would
/// make more than 2 million tets.
MeshData makeBlock(const BlockSpec& spec = {});

}  // namespace tissue_cut
