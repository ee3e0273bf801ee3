// SplitTable: how one cut tetrahedron is replaced by tetrahedra that fill the same volume and do
// not cross the cut, given the points the cut left on its edges and faces.
//
// Every face is triangulated by one global rule that depends only on the points on that face and
// their ids, so the two tets sharing a face always agree (conformity). Inside, the cases are:
//   complete  no point on a face: the cut separates the corners into two sides. Each side is a
//             convex region (tet, prism, pyramid) coned from its smallest-id vertex; with quad
//             diagonals through the smallest id too, this never makes a flat tet (Dompierre et
//             al. 1999). 3 edges -> 4 tets, 4 edges -> 6 tets; snapped corners give 3, 2 or
//             none (a cut along an existing face only separates).
//   partial   the cut front crossed two faces (face points f1, f2) and the cut crossed a path of
//             1-3 edges between them: cone from f1, whose own face is fanned from it, so every
//             tet is valid; the cut is the fan (f1, x1, ..., xk, f2). 6, 8 or 10 tets.
//   cone      points but no cut surface to separate (a front grazing an edge): cone from a point
//             that sees every face triangle, no separation.
//   tent      anything else (opposite edges, a face's three edges, 5-6 edges, a trembling hand):
//             cone from a new vertex at the centroid; the cut is the cone over the traces the cut
//             left on the faces. Always valid, one extra vertex.
#pragma once

#include <array>
#include <functional>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// A tet as the cut left it. Local numbering follows TetMesh: edges kTetEdge, face f opposite
/// corner f.
struct TetCut {
  TetVerts corner{};                                       ///< global ids, positively oriented
  std::array<int, 6> edge_point{-1, -1, -1, -1, -1, -1};   ///< global id of the point on each edge
  std::array<int, 4> face_point{-1, -1, -1, -1};           ///< global id of the point on each face
  std::array<bool, 4> on_cut{false, false, false, false};  ///< corner lies on the cut surface

  int numEdgePoints() const;
  int numFacePoints() const;
  bool hasPoints() const { return numEdgePoints() + numFacePoints() > 0; }
};

enum class SplitKind {
  kUntouched,  ///< nothing to replace or separate
  kAlongFace,  ///< no tet split: the cut runs along a face of the tet (cut_faces holds it)
  kComplete,
  kPartial,
  kCone,
  kTent,
  kNeedsSteiner,  ///< no case fits without a centroid vertex: call again with one
};

const char* splitKindName(SplitKind kind);

/// The replacement of one tet.
struct TetSplit {
  SplitKind kind = SplitKind::kUntouched;
  std::vector<TetVerts> tets;                 ///< positively oriented (rest and current)
  std::vector<std::array<int, 3>> cut_faces;  ///< faces on the cut surface, to be separated
};

/// Position of a global vertex id [m].
using PositionFn = std::function<Vec3(int)>;

/// The local edge (kTetEdge index) joining local corners i and j.
int tetEdgeIndex(int i, int j);

/// Triangles of face f by the global rule, oriented outward from the tet: a face point fans the
/// face; else 1 edge point fans from the opposite corner, 2 split off the corner they share and
/// cut the rest along the quad diagonal through its smallest id, 3 make the four-triangle split.
std::vector<std::array<int, 3>> faceTriangles(const TetCut& cut, int f);

/// The final replacement of a cut tet. `steiner` is the global id of a vertex at the tet's
/// centroid, or -1; when no case fits without it the result is kNeedsSteiner.
/// Every returned tet has positive volume in rest and (when the tet itself is not inverted there)
/// current positions.
TetSplit splitTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                  int steiner);
/// The same into *out (its lists emptied first and reused: no allocation once they have room).
void splitTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current, int steiner,
              TetSplit* out);

/// A temporary subdivision while the blade is still inside: conforming to the points so far, no
/// cut faces. kNeedsSteiner when no point of the tet can serve as apex.
TetSplit subdivideTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                      int steiner);
/// The same into *out (its lists emptied first and reused).
void subdivideTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                  int steiner, TetSplit* out);

}  // namespace tissue_cut
