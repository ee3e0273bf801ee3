// Whole-mesh topology figures: pieces, the boundary's Euler characteristic and area.
#pragma once

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// Number of pieces: groups of live tets joined across shared faces.
int countPieces(const TetMesh& mesh);

/// Euler characteristic V - E + F of the boundary surface (2 per sphere-like piece, 0 per torus).
int boundaryEulerCharacteristic(const TetMesh& mesh);

/// Area of the boundary surface in rest positions [m^2].
double boundaryRestArea(const TetMesh& mesh);

}  // namespace tissue_cut
