// TetGrid: a uniform grid of tets by their bounding boxes (as filed, within a margin of where they
// are now), so that finding the tets near the blade costs as much as the blade's neighbourhood,
// not the whole mesh.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// Whether tet t's current bounding box meets the box [lo, hi]: what a query keeps. (Inline: the
/// cutter filters its candidates with it a few hundred times a tick. The box is taken as
/// std::min and std::max chain it, corner after corner, so a NaN corner counts as TetGrid's do.)
inline bool tetBoxMeets(const TetMesh& mesh, int t, const Vec3& lo, const Vec3& hi) {
  const TetVerts& tv = mesh.tet(t);
  const Vec3 &a = mesh.current(tv[0]), &b = mesh.current(tv[1]), &c = mesh.current(tv[2]),
             &d = mesh.current(tv[3]);
  for (int k = 0; k < 3; ++k) {
    const double low = std::min(std::min(std::min(a[k], b[k]), c[k]), d[k]);
    const double high = std::max(std::max(std::max(a[k], b[k]), c[k]), d[k]);
    if (!(low <= hi[k]) || !(high >= lo[k])) return false;
  }
  return true;
}

class TetGrid {
 public:
  /// Indexes every live tet. cell: grid cell edge [m]; margin: how far positions may drift
  /// before a rebuild [m]. Each vertex has a filed position (where it was at the build or its
  /// last refile) and a tet is filed under the box of its vertices' filed positions: while no
  /// vertex is further than `margin` from its filed position, no tet's box is further than that
  /// from its filed box, and a query, looking that much further, finds every tet it should.
  void build(const TetMesh& mesh, double cell, double margin);
  /// Files the tets a change added (removed ones are skipped at query time). A vertex of theirs
  /// further than the margin from its filed position (moved by the change, as smoothing moves
  /// one) is filed where it is now, with all its tets, which are appended to *refiled when given
  /// (the added ones among them; in no particular order, they may repeat).
  void update(const TetMesh& mesh, const ChangeRecord& change, std::vector<int>* refiled = nullptr);
  /// Live tets whose current bounding box overlaps the box [lo, hi] [m], in increasing id order.
  std::vector<int> query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi) const;
  /// The same into *out (its capacity is reused: no allocation once grown).
  void query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi, std::vector<int>* out) const;
  /// Every live tet a query of a box inside [lo, hi] could return, as long as the grid is not
  /// updated or rebuilt in between (the filed boxes, without looking at current positions), in
  /// increasing id order: a caller may keep these and filter them by current box instead.
  void candidates(const TetMesh& mesh, const Vec3& lo, const Vec3& hi, std::vector<int>* out) const;
  /// Whether tet t, filed just now, belongs to candidates(lo, hi).
  bool filedNear(const TetMesh& mesh, int t, const Vec3& lo, const Vec3& hi) const;
  /// filedNear() of each of `tets`, into (*near)[i] (1: near), the box grown once for all.
  void filedNear(const TetMesh& mesh, const std::vector<int>& tets, const Vec3& lo, const Vec3& hi,
                 std::vector<unsigned char>* near) const;
  /// True when the index has gone stale: a vertex drifted more than the margin from where it
  /// was filed (so a tet's box may have moved more than the margin), or dead entries pile up.
  /// Scans every vertex. (The cutter keeps the index fresh with refresh(); this checks the
  /// invariant refresh() keeps, for tests and callers that rebuild instead.)
  bool needsRebuild(const TetMesh& mesh) const;
  /// Keeps the index fresh without a rebuild: every vertex that drifted more than the margin
  /// from where it was filed is filed where it is now, and the tets around it under their new
  /// boxes (their old entries go). Appends the tets refiled to *refiled (each once, in
  /// increasing order). Queries made after it, before the tissue moves again, are exact however
  /// far it moved. `moved` bounds how far any vertex moved since the last call (infinity: not
  /// known); the vertices are scanned only when the moves since the last scan could have taken
  /// one past the margin (a vertex moved otherwise is refiled by an update()).
  void refresh(const TetMesh& mesh, double moved, std::vector<int>* refiled);
  /// How many calls of refresh() scanned the vertices (since construction).
  long long scans() const { return scans_; }
  /// True when dead entries pile up (twice the entries of the last build): time to rebuild.
  bool cluttered() const { return entries_ > 2 * entries_at_build_ + 1024; }
  bool empty() const { return cells_.empty(); }

 private:
  /// Cell coordinates of x, clamped to the grid: what lies outside is filed in the border
  /// cells, which queries clamp to alike.
  std::array<int, 3> cellOf(const Vec3& x) const;
  void insert(const TetMesh& mesh, int t);
  /// Files tet t anew where it is now: its box rewritten, and where the cells it spans changed,
  /// its entries out of the cells it left and into those it reached.
  void refile(const TetMesh& mesh, int t);
  /// Live tets filed in the cells around [lo, hi] whose filed box may have drifted into it, in id
  /// order; with `current`, only those whose current box meets [lo, hi].
  void filed(const TetMesh& mesh, const Vec3& lo, const Vec3& hi, bool current,
             std::vector<int>* out) const;
  /// How much further than [lo, hi] a filed box is looked for along axis d: the margin, and a
  /// little more for the floats.
  double reach(const Vec3& lo, const Vec3& hi, int d) const {
    return margin_ * 1.001 + 1e-6 * (std::abs(lo[d]) + std::abs(hi[d]));
  }

  double cell_ = 1.0, inv_cell_ = 1.0, margin_ = 0.0;
  Vec3 origin_ = Vec3::Zero();
  std::array<int, 3> dims_{0, 0, 0};
  // A tet's box as filed (floats, rounded outward): a query tests it before it reads the mesh.
  struct Box {
    float lo[3], hi[3];
  };
  // The tet ids filed in each cell, x fastest. The boxes are per tet slot, not per entry, so that
  // refiling a tet whose box still spans the same cells (most of the tissue's drift) writes its
  // box and nothing else: no cell is searched. A dead tet's entries stay until a rebuild; a slot
  // reused elsewhere leaves them pointing at the new tet's box, which a query tests like any.
  std::vector<std::vector<int>> cells_;
  std::vector<Box> boxes_;  // per tet slot
  std::size_t entries_ = 0, entries_at_build_ = 0;
  // Per tet slot, the cells its latest entries are in (first and last corner; -1: none).
  struct Filed {
    std::array<int, 3> first{-1, -1, -1}, last{-1, -1, -1};
  };
  std::vector<Filed> filed_;
  /// Tet t's box as filed: over its vertices' filed positions (rounded outward to floats), and
  /// the cells it spans.
  Box boxOf(const TetMesh& mesh, int t, Filed* cells) const;
  /// The query box [lo, hi] grown by reach(), in floats rounded outward: a filed box that may
  /// have drifted into [lo, hi] meets it.
  void grown(const Vec3& lo, const Vec3& hi, float* qlo, float* qhi) const;
  /// filedNear() with the grown box.
  bool filedIn(const TetMesh& mesh, int t, const float* qlo, const float* qhi) const;
  // How far a vertex may be from where it was filed, as far as refresh() knows: the farthest at
  // the last scan, plus the moves since.
  double drift_bound_ = 0.0;
  long long scans_ = 0;
  // Per vertex slot, where it was filed (see build()).
  std::vector<Vec3> built_positions_;
  // update()'s scratch: the vertices it files anew.
  std::vector<int> moved_scratch_;
  // Per tet slot, the stamp of the refresh that last took it: each tet once a call.
  mutable std::vector<unsigned> seen_;
  mutable unsigned stamp_ = 0;
  // filed()'s tets, a bit per tet slot: each once, read out in id order (a sort of the list
  // had cost more than the cells' loop). All clear between calls.
  mutable std::vector<std::uint64_t> found_bits_;
};

}  // namespace tissue_cut
