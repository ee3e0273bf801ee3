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
  /// Worst rest Q over the star of `removed` (tets that vanish included) before the collapse; 0
  /// when refused before the quality test (any refusal but kQuality).
  double worst_before = 0.0;
  /// Worst rest Q over the tets of that star that live on with `survivor` in place of `removed`
  /// (1 when none does); 0 when refused before it was known (kBoundary, kLink, kInversion). For
  /// kQuality the tets are measured only until one falls below worst_before: the lowest Q met
  /// up to it (below worst_before; the worst over all of them may be lower still).
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

/// Inputs: mesh, a tet's vertex ids (need not be a tet of the mesh yet). Output: its rest Q where
/// it is sound (isSoundTet) in rest and in current positions, what every tet a remesher makes
/// must be; -1 where it is not.
double soundQualityInMesh(const TetMesh& mesh, const TetVerts& tv);

/// Inputs: a triangle p, q, r, a displacement d [m] and a length floor [m]. Output: d's component
/// along the triangle's normal relative to the larger of its longest edge and length_floor
/// (infinity for a degenerate triangle): how far a point moved by d leaves the plane, the measure
/// the boundary shape tolerance bounds. The floor makes the measure absolute on faces shorter than
/// it: a cluster of sub-millimetre faces at a cut's rim may be evened out by a move that changes
/// the shape by no more than the tolerance times the floor (the remesher uses the mean edge, so
/// the surface moves no further than the cutter's own snapping does).
double planeDeviation(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& d,
                      double length_floor = 0.0);

/// Boundary edges whose two boundary faces turn back on each other (outward normals at more than
/// about 154 degrees: cosine below this) with the material wrapped around the edge (the dihedral
/// angles of its tets add up to more than pi) are folds: a crack front, where both walls of a cut
/// meet inside the body and lie on each other in rest positions. (A knife edge, a sliver's edge
/// on the boundary, has turned-back faces too, but next to no material around it.)
constexpr double kFoldCosine = -0.9;

/// Inputs: mesh, a vertex v. Output: the vertices u (ascending) for which uv is a fold edge (rest
/// positions). A vertex inside a crack front has two; one where the front ends at the skin, three
/// or more where fronts meet.
std::vector<int> foldNeighbours(const TetMesh& mesh, int v);

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
///    through the moved vertex would leave its plane by more than shape_tolerance times the
///    larger of its longest edge and length_floor (the survivor's distance from that plane), so a
///    short edge on a curved cut or a kinked rim may go while every face keeps its place within
///    that tolerance.
///    Also kBoundary, whatever the tolerance: the moved vertex lies on a crack front (see
///    foldNeighbours) and either the front ends or branches there, or the survivor is not its
///    neighbour along the front, or the front would shift by more than max(shape_tolerance, 1e-6)
///    times the larger of the new front edge and length_floor. The walls of a cut lie on each
///    other in rest positions, so the plane and volume measures cannot see a front vertex moving
///    up a wall: that would close the crack behind it.
///  - kQuality: worst_after < worst_before (rest positions, Q = 3 r_in / R_circ).
/// With link_last, the link condition is tested after the geometry, and only where a way passes
/// it: the same decision (refused or not, and which end moves), but an edge refused by both is
/// reported for its geometry, not as kLink. The collapse queue checks so: most of its edges fail
/// on geometry (the 20k organ's replay: seven checks in eight), and the link test is as dear as
/// the geometry's.
/// Throws std::invalid_argument when ab is not an edge of live tets.
CollapseCheck checkCollapse(const TetMesh& mesh, int a, int b, double shape_tolerance = 0.0,
                            double length_floor = 0.0, bool link_last = false);

/// checkCollapse() for a caller that knows ab is an edge of a live tet (not checked) and whether
/// each end is a boundary vertex (isBoundaryVertex): the collapse queue tries the six edges of a
/// tet, and would otherwise look at each of its four stars three times over for that.
CollapseCheck checkCollapseKnown(const TetMesh& mesh, int a, int b, bool a_boundary,
                                 bool b_boundary, double shape_tolerance, double length_floor,
                                 bool link_last);

/// Collapses edge ab if checkCollapse accepts it: TetMesh::mergeVertices(removed, survivor,
/// record), so the survivor keeps its own rest and current positions.
/// Inputs: mesh; a, b as for checkCollapse; record (may be null) receives the change.
/// Outputs: true when collapsed; false (mesh and record unchanged) when refused; *check (if
/// given) the decision either way.
bool collapseEdge(TetMesh* mesh, int a, int b, ChangeRecord* record, CollapseCheck* check = nullptr,
                  double shape_tolerance = 0.0, double length_floor = 0.0);

}  // namespace tissue_cut
