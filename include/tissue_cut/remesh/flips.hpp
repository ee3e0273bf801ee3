// Topological flips: our extension to the paper's edge collapse. A 2-3 flip replaces two tets
// sharing an interior face abc (apexes d, e) by the three tets around the new edge de; a 3-2 flip
// does the reverse, replacing the three tets around an interior edge ab by two tets sharing the
// face of ab's ring. No vertex moves, the boundary is not touched and the rest volume is the
// same (the same convex region is tiled again), so shape and topology stay as they were; only the
// connectivity inside changes. Edge removal generalises the 3-2 flip to rings of up to ten tets.
// A 2-2 flip swaps the diagonal of two boundary triangles that lie
// in one plane (to a tolerance) over the two tets below them. A flip is taken only when it
// raises the worst quality Q of the tets it replaces, so flips cannot cycle.
#pragma once

#include <array>
#include <functional>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// One flip that may be done: which tets go and which come.
struct FlipCandidate {
  std::vector<int> removed;       ///< tet ids (2 for 2-3 and 2-2 flips, n for edge removal)
  std::vector<TetVerts> added;    ///< positively oriented in rest positions
  double worst_before = 0.0;      ///< worst rest Q over `removed`
  double worst_after = 0.0;       ///< worst rest Q over `added`
  double volume_change = 0.0;     ///< rest volume added (negative: lost) [m^3]; 0 but for 2-2
};

/// Inputs: mesh; live tet t; face f (0..3, the face opposite t's vertex f), which must be
/// interior. Output: the 2-3 flip of that face when it is legal and raises the worst rest Q by at
/// least min_gain, else nothing (returns false). Legal: the new edge de does not exist yet, and
/// each new tet is sound (positive and not flattened, see isSoundTet) in rest and in current
/// positions, which holds exactly when de crosses the inside of face abc.
/// `may_join(d, e)` (null: always) must allow the new edge.
bool flip23(const TetMesh& mesh, int t, int f, double min_gain, FlipCandidate* out,
            const std::function<bool(int, int)>& may_join = nullptr);

/// Largest ring removeEdge works on.
constexpr int kMaxEdgeRing = 10;

/// An edge's tets as TetMesh::edgeTets() lists them: `count` of them, the first kMaxEdgeRing
/// (at most) in `tets`. Found once, they serve both the edge's removal and its 2-2 flip.
struct EdgeTets {
  std::array<int, kMaxEdgeRing> tets{};
  int count = 0;
};
EdgeTets edgeTetsOf(const TetMesh& mesh, int a, int b);

/// Edge removal (the 3-2 flip's generalisation, Shewchuk 2002; n = 3 is the 3-2 flip): the n
/// tets around an interior edge ab (3 <= n <= kMaxEdgeRing) are replaced by 2n - 4 tets joining
/// each triangle of a triangulation of ab's ring polygon to a and to b. The triangulation
/// maximising the worst rest Q is found by dynamic programming over sub-polygons; chords that are
/// edges already and triangles that are faces already are not used. Output (returns true) when
/// every new tet is sound in rest and current positions and the worst rest Q rises by at least
/// min_gain.
/// `may_join(u, v)` (null: always) must allow every chord used.
bool removeEdge(const TetMesh& mesh, int a, int b, double min_gain, FlipCandidate* out,
                const std::function<bool(int, int)>& may_join = nullptr);
/// The same with the edge's tets found already (edgeTetsOf(mesh, a, b)).
bool removeEdge(const TetMesh& mesh, int a, int b, const EdgeTets& edge, double min_gain,
                FlipCandidate* out, const std::function<bool(int, int)>& may_join = nullptr);

/// Inputs: mesh; a, b the ends of a boundary edge held by exactly two tets, abcx and abdx (abc and
/// abd its boundary faces, abx the face between the tets); shape_tolerance and length_floor as for
/// checkCollapse.
/// Output: the 2-2 flip to the tets over the other diagonal cd (cdax and cdbx) when d lies within
/// shape_tolerance times the larger of abc's longest edge and length_floor from abc's plane (and c
/// from abd's), abc and abd face the same way (not folded onto each other, as at a crack front),
/// cd is no edge yet, both new tets are sound in rest and current positions and the worst rest Q
/// rises by at least min_gain; else returns false. volume_change is the rest volume the flip adds.
bool flip22(const TetMesh& mesh, int a, int b, double shape_tolerance, double min_gain,
            FlipCandidate* out, double length_floor = 0.0);
/// The same with the edge's tets found already (edgeTetsOf(mesh, a, b)).
bool flip22(const TetMesh& mesh, int a, int b, const EdgeTets& edge, double shape_tolerance,
            double min_gain, FlipCandidate* out, double length_floor = 0.0);

/// Does the flip: TetMesh::replaceTets(removed, added) with every added tet new (added_from -1:
/// the element is re-made, its springs and masses are rebuilt from it). Returns the new tet ids.
std::vector<int> applyFlip(TetMesh* mesh, const FlipCandidate& flip, ChangeRecord* record);

}  // namespace tissue_cut
