// TetGrid: a uniform spatial hash of tets by their current bounding boxes, so that finding the
// tets near the blade costs as much as the blade's neighbourhood, not the whole mesh.
#pragma once

#include <array>
#include <cstdint>
#include <unordered_map>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

class TetGrid {
 public:
  /// Indexes every live tet. cell: grid cell edge [m]; margin: each tet is filed under its
  /// current box grown by this much [m], so positions may drift that far before a rebuild.
  void build(const TetMesh& mesh, double cell, double margin);
  /// Files the tets a change added (removed ones are skipped at query time).
  void update(const TetMesh& mesh, const ChangeRecord& change);
  /// Live tets whose current bounding box overlaps the box [lo, hi] [m].
  std::vector<int> query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi) const;
  /// True when the index has gone stale: positions drifted past the margin for some vertex, or
  /// dead entries pile up. Scans every vertex: call it now and then, not every tick.
  bool needsRebuild(const TetMesh& mesh) const;
  bool empty() const { return cells_.empty(); }

 private:
  std::int64_t key(int i, int j, int k) const;
  std::array<int, 3> cellOf(const Vec3& x) const;
  void insert(const TetMesh& mesh, int t);

  double cell_ = 1.0, margin_ = 0.0;
  std::unordered_map<std::int64_t, std::vector<int>> cells_;
  std::size_t entries_ = 0;
  int live_at_build_ = 0;
  std::vector<Vec3> built_positions_;
  mutable std::vector<unsigned> seen_;
  mutable unsigned stamp_ = 0;
};

}  // namespace tissue_cut
