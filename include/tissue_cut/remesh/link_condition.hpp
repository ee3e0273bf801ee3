// The link condition of Dey, Edelsbrunner, Guha and Nekhayev (1999): contracting an edge ab keeps
// the topology of a tetrahedral mesh iff Lk(a) ∩ Lk(b) = Lk(ab), with the mesh closed by a dummy
// vertex ω joined to every boundary simplex, so that the boundary is treated like the interior.
#pragma once

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// Why an edge collapse was refused (kNone: it was accepted).
enum class CollapseRefusal {
  kNone,
  kLink,       ///< Lk(a) ∩ Lk(b) != Lk(ab): the collapse would change the topology
  kBoundary,   ///< interior edge between two boundary vertices: one would leave the boundary
  kInversion,  ///< a tet of the moved vertex's star would invert or flatten (rest or current)
  kQuality,    ///< the star's worst quality Q (rest positions) would get worse
};

/// Words for a refusal ("none", "link", "boundary", "inversion", "quality"), for logs and stats.
const char* toString(CollapseRefusal refusal);

/// Inputs: mesh, a live vertex v. Output: whether v lies on a boundary face.
bool isBoundaryVertex(const TetMesh& mesh, int v);

/// Inputs: mesh, an edge ab of live tets. Output: whether ab lies on a boundary face.
bool isBoundaryEdge(const TetMesh& mesh, int a, int b);

/// Inputs: mesh, a live tet t holding a and b. Output: whether one of t's two faces through ab
/// lies on the boundary (isBoundaryEdge() asks this of each of the edge's tets).
inline bool openAtEdge(const TetMesh& mesh, int t, int a, int b) {
  const TetVerts& tv = mesh.tet(t);
  const int ia = localIndex(tv, a), ib = localIndex(tv, b);
  for (int f = 0; f < 4; ++f)
    if (f != ia && f != ib && mesh.neighbor(t, f) < 0) return true;
  return false;
}

/// Throws std::invalid_argument naming `who` and the pair unless a and b are two live vertices
/// joined by an edge of a live tet (what linkConditionHolds and checkCollapse require).
void requireEdge(const TetMesh& mesh, int a, int b, const char* who);

/// Inputs: mesh, two live vertices a != b joined by an edge of a live tet.
/// Output: whether contracting ab keeps the topology: Lk(a) ∩ Lk(b) = Lk(ab) at every level
/// (vertices, edges, triangles) in the mesh closed by ω. Lk(v) holds the vertices, edges and
/// triangles opposite v in its tets, plus ω, ω*x and ω*xy for each boundary vertex, edge vx and
/// face vxy. So an interior edge with both ends on the boundary is refused (ω is shared but not
/// in Lk(ab)), and a boundary edge must meet the boundary surface's own 2-D link condition.
/// Throws std::invalid_argument when ab is not such an edge.
bool linkConditionHolds(const TetMesh& mesh, int a, int b);

}  // namespace tissue_cut
