// Vertex smoothing: our extension to the paper's edge collapse. A vertex next to a bad tet moves
// to raise the worst quality Q of its star, without changing topology or rest volume: an
// interior vertex moves freely inside its star, a boundary vertex only within its flat boundary
// patch (in its plane) or along a straight crease (two planes, along their line); corners stay.
#pragma once

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// How vertex v may move without changing the shape of the boundary.
enum class VertexFreedom {
  kInterior,  ///< no boundary face: any point keeping the star's tets positive
  kPlane,     ///< all boundary faces in one plane: within that plane
  kLine,      ///< boundary faces in two planes (a straight crease): along their line
  kPinned,    ///< three or more planes, or a crack front (faces of both sides of a cut)
};

/// Inputs: mesh, live vertex v. Output: its freedom; *direction (if given) the plane's unit
/// normal (kPlane) or the line's unit direction (kLine). Two boundary faces count as one plane
/// when their unit normals agree to 1e-9 (cut surfaces are flat to rounding).
VertexFreedom vertexFreedom(const TetMesh& mesh, int v, Vec3* direction = nullptr);

/// What a smoothing attempt found.
struct SmoothingCheck {
  bool moved = false;
  VertexFreedom freedom = VertexFreedom::kPinned;
  double worst_before = 0.0;   ///< worst rest Q over v's star before
  double worst_after = 0.0;    ///< after the move (= worst_before when not moved)
  Vec3 target = Vec3::Zero();  ///< new rest position [m] (when moved)
};

/// Tries to move vertex v so that the worst rest Q of its star rises by at least `min_gain`.
/// Candidates: steps from v towards the mean of its link vertices, towards the mean of the points
/// that would make each star tet regular over its opposite face, and towards that point for the
/// worst tet, projected onto v's freedom; the best is kept, a few rounds. A move is accepted when
/// every star tet stays sound (positive, not flattened: see kMinCollapseRelativeVolume) in rest
/// and in current positions, the star's rest volume is unchanged to 1e-9 (relative) and the
/// worst Q rose by min_gain. The new current position and velocity are interpolated in the rest
/// tet of the old star holding the target (the material point's own motion), through
/// TetMesh::moveVertex, whose change goes to `record` (may be null).
/// Outputs: true when moved; *check (if given) what was found.
bool smoothVertex(TetMesh* mesh, int v, double min_gain, ChangeRecord* record,
                  SmoothingCheck* check = nullptr);

}  // namespace tissue_cut
