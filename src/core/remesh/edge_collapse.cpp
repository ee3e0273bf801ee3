#include "tissue_cut/remesh/edge_collapse.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

namespace {

bool contains(const TetVerts& tv, int v) { return std::find(tv.begin(), tv.end(), v) != tv.end(); }

// How far the boundary faces that move with `removed` would leave their planes, relative to each
// face's longest edge.
double boundaryDeviation(const TetMesh& mesh, int removed, int survivor) {
  const Vec3 move = mesh.rest(survivor) - mesh.rest(removed);
  double worst = 0.0;
  for (int t : mesh.vertexTets(removed)) {
    // Tets holding both ends count too: their boundary faces give way to faces through the
    // survivor.
    const TetVerts& tv = mesh.tet(t);
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0 || tv[f] == removed) continue;
      worst = std::max(worst, planeDeviation(mesh.rest(tv[kTetFace[f][0]]),
                                             mesh.rest(tv[kTetFace[f][1]]),
                                             mesh.rest(tv[kTetFace[f][2]]), move));
      if (std::isinf(worst)) return worst;
    }
  }
  return worst;
}

// The checks for moving `removed` onto `survivor`, in the order the header lists them.
CollapseCheck evaluate(const TetMesh& mesh, int removed, int survivor, bool link_holds,
                       bool a_boundary, bool b_boundary, int a, int b, double shape_tolerance) {
  CollapseCheck check;
  check.removed = removed;
  check.survivor = survivor;

  const std::vector<int>& star = mesh.vertexTets(check.removed);
  check.worst_before = 1.0;
  for (int t : star) check.worst_before = std::min(check.worst_before, restQuality(mesh, t));

  if (a_boundary && b_boundary && !isBoundaryEdge(mesh, a, b)) {
    check.refusal = CollapseRefusal::kBoundary;
    return check;
  }
  if (!link_holds) {
    check.refusal = CollapseRefusal::kLink;
    return check;
  }

  check.worst_after = 1.0;
  double volume_before = 0.0, volume_after = 0.0;
  for (int t : star) volume_before += mesh.restVolume(t);
  for (int t : star) {
    TetVerts tv = mesh.tet(t);
    if (contains(tv, check.survivor)) continue;  // vanishes with the edge
    *std::find(tv.begin(), tv.end(), check.removed) = check.survivor;
    if (!isSoundInMesh(mesh, tv)) {
      check.refusal = CollapseRefusal::kInversion;
      check.worst_after = 0.0;  // a flattened tet has Q = 0
      return check;
    }
    check.worst_after = std::min(check.worst_after, tetQuality(mesh.rest(tv[0]), mesh.rest(tv[1]),
                                                               mesh.rest(tv[2]), mesh.rest(tv[3])));
    volume_after +=
        signedVolume(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3]));
  }
  check.volume_change = volume_after - volume_before;
  if (shape_tolerance <= 0.0) {
    // Inside the body the star keeps its volume exactly; a change means the moved vertex was on
    // a curved or creased part of the boundary (a corner, the crack's rim) and the shape would
    // change.
    if (std::abs(check.volume_change) > 1e-6 * volume_before) {
      check.refusal = CollapseRefusal::kBoundary;
      return check;
    }
  } else if (boundaryDeviation(mesh, check.removed, check.survivor) > shape_tolerance) {
    check.refusal = CollapseRefusal::kBoundary;
    return check;
  }
  if (check.worst_after < check.worst_before) check.refusal = CollapseRefusal::kQuality;
  return check;
}

}  // namespace

// The threshold scales with the tet so that it means the same at every mesh size, and a tiny tet
// made by a cut is not refused for being small.
bool isSoundTet(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  const Vec3* p[4] = {&p0, &p1, &p2, &p3};
  double longest = 0.0;
  for (const auto& e : kTetEdge) longest = std::max(longest, (*p[e[0]] - *p[e[1]]).norm());
  return signedVolume(p0, p1, p2, p3) > kMinCollapseRelativeVolume * longest * longest * longest;
}

bool isSoundInMesh(const TetMesh& mesh, const TetVerts& tv) {
  return isSoundTet(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3])) &&
         isSoundTet(mesh.current(tv[0]), mesh.current(tv[1]), mesh.current(tv[2]),
                    mesh.current(tv[3]));
}

double planeDeviation(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& d) {
  const Vec3 n = (q - p).cross(r - p);
  const double len = n.norm();
  if (!(len > 0)) return std::numeric_limits<double>::infinity();
  const double longest = std::max({(p - q).norm(), (q - r).norm(), (r - p).norm()});
  return std::abs(n.dot(d)) / len / longest;
}

CollapseCheck checkCollapse(const TetMesh& mesh, int a, int b, double shape_tolerance) {
  // Throws for a non-edge before anything else is read.
  const bool link_holds = linkConditionHolds(mesh, a, b);
  const bool a_boundary = isBoundaryVertex(mesh, a), b_boundary = isBoundaryVertex(mesh, b);
  // Newer onto older: a cut point goes back onto an original vertex, and the older part of the
  // mesh, which other data has seen longer, stays where it was.
  int removed = std::max(a, b), survivor = std::min(a, b);
  if (a_boundary != b_boundary) {
    removed = a_boundary ? b : a;
    survivor = a_boundary ? a : b;
  }
  const CollapseCheck first =
      evaluate(mesh, removed, survivor, link_holds, a_boundary, b_boundary, a, b, shape_tolerance);
  // When the preferred way would flatten a tet, worsen the star or bend the boundary, the other
  // way round may not (only where both ends are alike: a boundary vertex never leaves it).
  const bool geometric = first.refusal == CollapseRefusal::kInversion ||
                         first.refusal == CollapseRefusal::kQuality ||
                         first.refusal == CollapseRefusal::kBoundary;
  if (!geometric || a_boundary != b_boundary) return first;
  const CollapseCheck second =
      evaluate(mesh, survivor, removed, link_holds, a_boundary, b_boundary, a, b, shape_tolerance);
  return second.refusal == CollapseRefusal::kNone ? second : first;
}

bool collapseEdge(TetMesh* mesh, int a, int b, ChangeRecord* record, CollapseCheck* check,
                  double shape_tolerance) {
  const CollapseCheck decided = checkCollapse(*mesh, a, b, shape_tolerance);
  if (check) *check = decided;
  if (decided.refusal != CollapseRefusal::kNone) return false;
  mesh->mergeVertices(decided.removed, decided.survivor, record);
  return true;
}

}  // namespace tissue_cut
