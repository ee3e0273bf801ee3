// Edge collapse (Ganovelli & O'Sullivan 2001): one end of a short edge moves onto the other and
// the tets holding both vanish. Pure functions on TetMesh; choosing which edges to try is the
// collapse queue's business.
#pragma once

#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/remesh/link_condition.hpp"

namespace tissue_cut {

/// What collapsing one edge would do, and why it would be refused.
struct CollapseCheck {
  CollapseRefusal refusal = CollapseRefusal::kNone;
  int removed = -1;   ///< the end that moves onto the other and dies
  int survivor = -1;  ///< the end that stays, keeping its rest and current positions
  /// Worst rest Q over the star of `removed` (tets that vanish included) before the collapse.
  double worst_before = 0.0;
  /// Worst rest Q over the tets of that star that live on with `survivor` in place of `removed`
  /// (1 when none does); 0 when refused before it was known (kBoundary, kLink, kInversion).
  double worst_after = 0.0;
  /// Rest volume the star would gain (negative: lose) [m^3]; 0 when refused before it was known.
  double volume_change = 0.0;
};

/// Smallest accepted volume of a tet after a collapse, relative to its longest edge cubed (a
/// regular tet has 0.118): below it the tet counts as flattened.
constexpr double kMinCollapseRelativeVolume = 1e-6;

/// Inputs: the corners of a tet [m]. Output: whether its signed volume exceeds
/// kMinCollapseRelativeVolume * (longest edge)^3 (positive and not flattened).
bool isSoundTet(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3);

/// Inputs: mesh, a tet's vertex ids (need not be a tet of the mesh yet). Output: isSoundTet in rest
/// and in current positions: what every tet a remesher makes must be.
bool isSoundInMesh(const TetMesh& mesh, const TetVerts& tv);

/// Inputs: a triangle p, q, r and a displacement d [m]. Output: d's component along the
/// triangle's normal relative to its longest edge (infinity for a degenerate triangle): how far a
/// point moved by d leaves the plane, the measure the boundary shape tolerance bounds.
double planeDeviation(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& d);

/// Decides how edge ab would collapse and whether it may.
/// Inputs: mesh; a, b two live vertices joined by an edge. Output: the check (see CollapseCheck).
/// Which end moves: the newer vertex (larger id) moves onto the older one, except that a boundary
/// vertex never leaves the boundary: if only one end is on the boundary, the interior end moves.
/// When both ends are alike and the preferred way is refused for geometry (kInversion, kQuality,
/// kBoundary), the other way round is checked too and taken if it passes.
/// Refusals, in the order they are tested:
///  - kBoundary: the edge is interior but both ends are on the boundary (either would leave it).
///    The link condition refuses these edges too (ω is in both links but not in Lk(ab)); kBoundary
///    names the reason that holds whichever end moves, so they are never reported as kLink.
///  - kLink: linkConditionHolds(mesh, a, b) is false.
///  - kInversion: a tet of the moved vertex's star not holding both ends would have signed volume
///    at most kMinCollapseRelativeVolume * (longest edge)^3 in rest or in current positions.
///  - kBoundary also, with shape_tolerance = 0: the rest volume of the moved vertex's star would
///    change by more than 1e-6 (relative), i.e. a boundary vertex would slide off a flat patch
///    (corner, crease, crack rim). With shape_tolerance > 0 (dimensionless): a boundary face
///    through the moved vertex would leave its plane by more than shape_tolerance times its
///    longest edge (the survivor's distance from that plane), so a short edge on a curved cut or
///    a kinked rim may go while every face keeps its place within that tolerance.
///  - kQuality: worst_after < worst_before (rest positions, Q = 3 r_in / R_circ).
/// Throws std::invalid_argument when ab is not an edge of live tets.
CollapseCheck checkCollapse(const TetMesh& mesh, int a, int b, double shape_tolerance = 0.0);

/// Collapses edge ab if checkCollapse accepts it: TetMesh::mergeVertices(removed, survivor,
/// record), so the survivor keeps its own rest and current positions.
/// Inputs: mesh; a, b as for checkCollapse; record (may be null) receives the change.
/// Outputs: true when collapsed; false (mesh and record unchanged) when refused; *check (if
/// given) the decision either way.
bool collapseEdge(TetMesh* mesh, int a, int b, ChangeRecord* record, CollapseCheck* check = nullptr,
                  double shape_tolerance = 0.0);

}  // namespace tissue_cut
