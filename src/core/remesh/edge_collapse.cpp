#include "tissue_cut/remesh/edge_collapse.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

namespace {

constexpr double kPi = 3.14159265358979323846;

// How far the boundary faces that move with `removed` would leave their planes, relative to each
// face's longest edge.
double boundaryDeviation(const TetMesh& mesh, int removed, int survivor, double length_floor) {
  const Vec3 move = mesh.rest(survivor) - mesh.rest(removed);
  double worst = 0.0;
  if (mesh.boundaryFacesAt(removed) == 0) return worst;  // (no face to look at)
  for (int t : mesh.vertexTets(removed)) {
    // Tets holding both ends count too: their boundary faces give way to faces through the
    // survivor.
    const TetVerts& tv = mesh.tet(t);
    for (int f = 0; f < 4; ++f) {
      // (One branch, mostly taken, where two went either way: `|`, not `||`.)
      if ((mesh.neighbor(t, f) >= 0) | (tv[f] == removed)) continue;
      worst = std::max(worst, planeDeviation(mesh.rest(tv[kTetFace[f][0]]),
                                             mesh.rest(tv[kTetFace[f][1]]),
                                             mesh.rest(tv[kTetFace[f][2]]), move,
                                             length_floor));
      if (std::isinf(worst)) return worst;
    }
  }
  return worst;
}

// The sum of the dihedral angles at edge uv of the tets around it (rest positions): the angle the
// material fills around the edge. Near 2 pi at a crack front, near 0 along a knife edge (a
// sliver's edge on the boundary), whose two faces also turn back on each other.
double materialAngle(const TetMesh& mesh, int u, int v) {
  const Vec3 &p = mesh.rest(u), axis = (mesh.rest(v) - p).normalized();
  double sum = 0.0;
  // The edge's tets in u's star order (as TetMesh::edgeTets(u, v) lists them), without a list.
  for (int t : mesh.vertexTets(u)) {
    if (!contains(mesh.tet(t), v)) continue;
    Vec3 side[2];
    int k = 0;
    for (int w : mesh.tet(t))
      if (w != u && w != v && k < 2) {
        const Vec3 d = mesh.rest(w) - p;
        side[k++] = d - axis * axis.dot(d);
      }
    sum += std::atan2(side[0].cross(side[1]).norm(), side[0].dot(side[1]));
  }
  return sum;
}

// findFolds()'s list, kept a thread (a collapse asks it for each end). Not inlined: a reference
// to a thread_local inlined into the loops was looked up again (a call, in a shared library) at
// each use.
[[gnu::noinline]] std::vector<std::pair<int, Vec3>>& threadEdgeNormals() {
  thread_local std::vector<std::pair<int, Vec3>> edge_normals;
  return edge_normals;
}

// The fold edges at v (see foldNeighbours): each one's other end once, in the order found, to
// add(u), which returns whether to go on looking; known(u) says whether u was added already.
template <typename Known, typename Add>
void findFolds(const TetMesh& mesh, int v, const Known& known, const Add& add) {
  // Each boundary face at v gives its outward unit normal to its two edges through v.
  if (mesh.boundaryFacesAt(v) == 0) return;  // (no face to look at)
  std::vector<std::pair<int, Vec3>>& edge_normals = threadEdgeNormals();
  edge_normals.clear();
  for (int t : mesh.vertexTets(v)) {
    const TetVerts& tv = mesh.tet(t);
    for (int f = 0; f < 4; ++f) {
      if ((tv[f] == v) | (mesh.neighbor(t, f) >= 0)) continue;  // (one branch, as above)
      const Vec3& a = mesh.rest(tv[kTetFace[f][0]]);
      Vec3 n = (mesh.rest(tv[kTetFace[f][1]]) - a).cross(mesh.rest(tv[kTetFace[f][2]]) - a);
      if (n.dot(mesh.rest(tv[f]) - a) > 0) n = -n;  // away from the tet's own fourth vertex
      const double len = n.norm();
      if (!(len > 0)) continue;
      n /= len;
      for (int k = 0; k < 3; ++k) {
        const int u = tv[kTetFace[f][k]];
        if (u != v) edge_normals.emplace_back(u, n);
      }
    }
  }
  for (std::size_t i = 0; i < edge_normals.size(); ++i)
    for (std::size_t j = i + 1; j < edge_normals.size(); ++j)
      if (edge_normals[i].first == edge_normals[j].first &&
          edge_normals[i].second.dot(edge_normals[j].second) < kFoldCosine &&
          !known(edge_normals[i].first) && materialAngle(mesh, v, edge_normals[i].first) > kPi &&
          !add(edge_normals[i].first))
        return;
}

// Whether `removed` may move onto `survivor` as far as the crack fronts through `removed` go:
// a front vertex only along its front, which then shifts by at most the tolerance.
bool frontKept(const TetMesh& mesh, int removed, int survivor, double shape_tolerance,
               double length_floor) {
  // Up to three folds, on the stack: a third already makes a corner.
  std::array<int, 3> folds{};
  std::size_t count = 0;
  findFolds(
      mesh, removed,
      [&](int u) {
        return std::find(folds.begin(), folds.begin() + count, u) != folds.begin() + count;
      },
      [&](int u) {
        folds[count++] = u;
        return count < folds.size();
      });
  if (count == 0) return true;
  if (count != 2) return false;  // where a front ends or fronts meet: a corner
  const int other = folds[0] == survivor ? folds[1] : folds[1] == survivor ? folds[0] : -1;
  if (other < 0) return false;  // off the front: the crack would close behind it
  const Vec3 &p = mesh.rest(removed), &s = mesh.rest(survivor), &o = mesh.rest(other);
  const double tolerance = std::max(shape_tolerance, 1e-6);
  return distanceToSegment(p, s, o) <= tolerance * std::max((s - o).norm(), length_floor);
}

// Whether the tet's corners are where they rest (always, without physics): its current
// positions then answer every question as its rest ones do.
bool atRest(const TetMesh& mesh, const TetVerts& tv) {
  for (int v : tv)
    if (mesh.current(v) != mesh.rest(v)) return false;
  return true;
}

// isSoundTet of the tet whose signed volume (signedVolume()) is `vol`.
bool isSoundWithVolume(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3, double vol) {
  const Vec3* p[4] = {&p0, &p1, &p2, &p3};
  double longest2 = 0.0;
  for (const auto& e : kTetEdge) longest2 = std::max(longest2, (*p[e[0]] - *p[e[1]]).squaredNorm());
  return soundVolume(vol, longest2, kMinCollapseRelativeVolume);
}

// The checks for moving `removed` onto `survivor`, in the order the header lists them.
CollapseCheck evaluate(const TetMesh& mesh, int removed, int survivor, bool link_holds,
                       bool a_boundary, bool b_boundary, int a, int b, double shape_tolerance,
                       double length_floor) {
  CollapseCheck check;
  check.removed = removed;
  check.survivor = survivor;

  const std::vector<int>& star = mesh.vertexTets(check.removed);
  if (a_boundary && b_boundary && !isBoundaryEdge(mesh, a, b)) {
    check.refusal = CollapseRefusal::kBoundary;
    return check;
  }
  if (!link_holds) {
    check.refusal = CollapseRefusal::kLink;
    return check;
  }

  // Every moved tet sound first (most checks stop at an inversion), then their quality and
  // volume.
  // A moved tet turned over in rest positions fails the soundness test at its first step: that one
  // test of every moved tet first finds most inversions at a fraction of the cost (the answer is
  // the same; only how soon it is known changes). The moved tets are kept, in star order, with
  // their rest volumes, for the soundness test and the volume sum after it.
  // On the stack for any usual star (a vertex is in ~24 tets; a thread_local buffer cost a TLS
  // lookup a call in this shared library).
  constexpr std::size_t kOnStack = 128;
  std::array<double, kOnStack> on_stack;
  std::array<TetVerts, kOnStack> moved_on_stack;
  std::vector<double> spilled;
  std::vector<TetVerts> moved_spilled;
  if (star.size() > kOnStack) {
    spilled.resize(star.size());
    moved_spilled.resize(star.size());
  }
  double* const rest_volume = star.size() > kOnStack ? spilled.data() : on_stack.data();
  TetVerts* const moved_tv = star.size() > kOnStack ? moved_spilled.data() : moved_on_stack.data();
  // Each star tet is renamed and measured, and kept only when it does not vanish with the edge
  // (it does not hold the survivor): the place advances by that test instead of branching on it
  // (about a quarter of the star vanishes, in no order a predictor learns). A vanishing tet's
  // volume (it has a corner twice) is measured and dropped.
  std::size_t moved = 0;
  for (const int t : star) {
    TetVerts tv = mesh.tet(t);
    const bool vanishes = contains(tv, check.survivor);
    for (int& x : tv) x = x == check.removed ? check.survivor : x;  // (each tet holds it once)
    const double volume =
        signedVolume(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3]));
    moved_tv[moved] = tv;
    rest_volume[moved] = volume;
    if (!vanishes & !(volume > 0.0)) {
      check.refusal = CollapseRefusal::kInversion;
      check.worst_after = 0.0;
      return check;
    }
    moved += vanishes ? 0 : 1;
  }
  // Where a moved tet's corners are where they rest (no physics), the current test is the rest
  // one, passed already: made only where they differ.
  for (std::size_t i = 0; i < moved; ++i) {
    const TetVerts& m = moved_tv[i];
    if (!(isSoundWithVolume(mesh.rest(m[0]), mesh.rest(m[1]), mesh.rest(m[2]), mesh.rest(m[3]),
                            rest_volume[i]) &&
          (atRest(mesh, m) || isSoundTet(mesh.current(m[0]), mesh.current(m[1]),
                                         mesh.current(m[2]), mesh.current(m[3]))))) {
      check.refusal = CollapseRefusal::kInversion;
      check.worst_after = 0.0;  // a flattened tet has Q = 0
      return check;
    }
  }
  double volume_before = 0.0, volume_after = 0.0;
  for (int t : star) volume_before += mesh.restVolume(t);
  for (std::size_t i = 0; i < moved; ++i) volume_after += rest_volume[i];
  check.volume_change = volume_after - volume_before;
  if (shape_tolerance <= 0.0) {
    // Inside the body the star keeps its volume exactly; a change means the moved vertex was on
    // a curved or creased part of the boundary (a corner, the crack's rim) and the shape would
    // change.
    if (std::abs(check.volume_change) > 1e-6 * volume_before) {
      check.refusal = CollapseRefusal::kBoundary;
      return check;
    }
  } else if (boundaryDeviation(mesh, check.removed, check.survivor, length_floor) >
             shape_tolerance) {
    check.refusal = CollapseRefusal::kBoundary;
    return check;
  }
  // The crack fronts after the faces (the same refusal; the fronts cost more to find).
  if (!frontKept(mesh, check.removed, check.survivor, shape_tolerance, length_floor)) {
    check.refusal = CollapseRefusal::kBoundary;
    return check;
  }
  // The qualities are needed for this last test only (most checks stop earlier, at an inversion
  // or at the boundary): the star's before (kept by the mesh), then each moved tet's until one
  // falls below that worst, which decides the refusal.
  check.worst_before = 1.0;
  for (int t : star) check.worst_before = std::min(check.worst_before, restQuality(mesh, t));
  check.worst_after = 1.0;
  for (std::size_t i = 0; i < moved; ++i) {
    const TetVerts& m = moved_tv[i];
    check.worst_after = std::min(check.worst_after, tetQuality(mesh.rest(m[0]), mesh.rest(m[1]),
                                                               mesh.rest(m[2]), mesh.rest(m[3])));
    if (check.worst_after < check.worst_before) {
      check.refusal = CollapseRefusal::kQuality;
      return check;
    }
  }
  return check;
}

}  // namespace

// The threshold scales with the tet so that it means the same at every mesh size, and a tiny tet
// made by a cut is not refused for being small.
bool isSoundTet(const Vec3& p0, const Vec3& p1, const Vec3& p2, const Vec3& p3) {
  return isSoundWithVolume(p0, p1, p2, p3, signedVolume(p0, p1, p2, p3));
}

double soundQualityInMesh(const TetMesh& mesh, const TetVerts& tv) {
  const double q = soundTetQuality(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]),
                                   mesh.rest(tv[3]), kMinCollapseRelativeVolume);
  if (q < 0.0) return -1.0;
  // soundTetQuality() tests the rest corners as isSoundTet() does (the same sums): where the
  // current corners are the rest ones (no physics), they passed already.
  if (!atRest(mesh, tv) && !isSoundTet(mesh.current(tv[0]), mesh.current(tv[1]),
                                       mesh.current(tv[2]), mesh.current(tv[3])))
    return -1.0;
  return q;
}

std::vector<int> foldNeighbours(const TetMesh& mesh, int v) {
  std::vector<int> folds;
  findFolds(
      mesh, v, [&](int u) { return std::find(folds.begin(), folds.end(), u) != folds.end(); },
      [&](int u) {
        folds.push_back(u);
        return true;
      });
  std::sort(folds.begin(), folds.end());
  return folds;
}

double planeDeviation(const Vec3& p, const Vec3& q, const Vec3& r, const Vec3& d,
                      double length_floor) {
  const Vec3 n = (q - p).cross(r - p);
  const double len = n.norm();
  if (!(len > 0)) return std::numeric_limits<double>::infinity();
  const double longest =
      std::max({(p - q).norm(), (q - r).norm(), (r - p).norm(), length_floor});
  return std::abs(n.dot(d)) / len / longest;
}

CollapseCheck checkCollapse(const TetMesh& mesh, int a, int b, double shape_tolerance,
                            double length_floor, bool link_last) {
  // Throws for a non-edge before anything else is read.
  requireEdge(mesh, a, b, "checkCollapse");
  return checkCollapseKnown(mesh, a, b, isBoundaryVertex(mesh, a), isBoundaryVertex(mesh, b),
                            shape_tolerance, length_floor, link_last);
}

CollapseCheck checkCollapseKnown(const TetMesh& mesh, int a, int b, bool a_boundary,
                                 bool b_boundary, double shape_tolerance, double length_floor,
                                 bool link_last) {
  const bool link_holds = link_last || linkConditionHolds(mesh, a, b);
  // Newer onto older: a cut point goes back onto an original vertex, and the older part of the
  // mesh, which other data has seen longer, stays where it was.
  int removed = std::max(a, b), survivor = std::min(a, b);
  if (a_boundary != b_boundary) {
    removed = a_boundary ? b : a;
    survivor = a_boundary ? a : b;
  }
  const CollapseCheck first =
      evaluate(mesh, removed, survivor, link_holds, a_boundary, b_boundary, a, b, shape_tolerance,
               length_floor);
  // When the preferred way would flatten a tet, worsen the star or bend the boundary, the other
  // way round may not (only where both ends are alike: a boundary vertex never leaves it).
  const bool geometric = first.refusal == CollapseRefusal::kInversion ||
                         first.refusal == CollapseRefusal::kQuality ||
                         first.refusal == CollapseRefusal::kBoundary;
  CollapseCheck decided = first;
  if (geometric && a_boundary == b_boundary) {
    const CollapseCheck second = evaluate(mesh, survivor, removed, link_holds, a_boundary,
                                          b_boundary, a, b, shape_tolerance, length_floor);
    if (second.refusal == CollapseRefusal::kNone) decided = second;
  }
  if (link_last && decided.refusal == CollapseRefusal::kNone && !linkConditionHolds(mesh, a, b)) {
    // What the link test first would have returned: the preferred way, refused before its
    // geometry was known.
    decided = CollapseCheck{};
    decided.refusal = CollapseRefusal::kLink;
    decided.removed = removed;
    decided.survivor = survivor;
  }
  return decided;
}

bool collapseEdge(TetMesh* mesh, int a, int b, ChangeRecord* record, CollapseCheck* check,
                  double shape_tolerance, double length_floor) {
  const CollapseCheck decided = checkCollapse(*mesh, a, b, shape_tolerance, length_floor);
  if (check) *check = decided;
  if (decided.refusal != CollapseRefusal::kNone) return false;
  mesh->mergeVertices(decided.removed, decided.survivor, record);
  return true;
}

}  // namespace tissue_cut
