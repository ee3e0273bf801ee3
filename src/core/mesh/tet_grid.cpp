#include "tissue_cut/mesh/tet_grid.hpp"

#include <algorithm>
#include <cmath>

namespace tissue_cut {

namespace {

void tetBox(const TetMesh& mesh, int t, Vec3* lo, Vec3* hi) {
  const TetVerts& v = mesh.tet(t);
  *lo = *hi = mesh.current(v[0]);
  for (int i = 1; i < 4; ++i) {
    *lo = lo->cwiseMin(mesh.current(v[i]));
    *hi = hi->cwiseMax(mesh.current(v[i]));
  }
}

}  // namespace

std::array<int, 3> TetGrid::cellOf(const Vec3& x) const {
  return {static_cast<int>(std::floor(x.x() / cell_)), static_cast<int>(std::floor(x.y() / cell_)),
          static_cast<int>(std::floor(x.z() / cell_))};
}

std::int64_t TetGrid::key(int i, int j, int k) const {
  return (static_cast<std::int64_t>(i) & 0x1FFFFF) |
         ((static_cast<std::int64_t>(j) & 0x1FFFFF) << 21) |
         ((static_cast<std::int64_t>(k) & 0x1FFFFF) << 42);
}

void TetGrid::insert(const TetMesh& mesh, int t) {
  Vec3 lo, hi;
  tetBox(mesh, t, &lo, &hi);
  lo.array() -= margin_;
  hi.array() += margin_;
  const auto [i0, j0, k0] = cellOf(lo);
  const auto [i1, j1, k1] = cellOf(hi);
  for (int i = i0; i <= i1; ++i)
    for (int j = j0; j <= j1; ++j)
      for (int k = k0; k <= k1; ++k) {
        cells_[key(i, j, k)].push_back(t);
        ++entries_;
      }
}

void TetGrid::build(const TetMesh& mesh, double cell, double margin) {
  cell_ = cell > 0 ? cell : 1.0;
  margin_ = margin;
  cells_.clear();
  entries_ = 0;
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t)) insert(mesh, t);
  live_at_build_ = mesh.numTets();
  built_positions_ = mesh.currentPositions();
}

void TetGrid::update(const TetMesh& mesh, const ChangeRecord& change) {
  for (int t : change.added_tets)
    if (mesh.tetAlive(t)) insert(mesh, t);
  for (int v : change.added_vertices) {
    if (v >= static_cast<int>(built_positions_.size())) built_positions_.resize(v + 1);
    built_positions_[v] = mesh.current(v);
  }
}

bool TetGrid::needsRebuild(const TetMesh& mesh) const {
  if (entries_ > 16u * static_cast<std::size_t>(std::max(live_at_build_, mesh.numTets())) + 1024)
    return true;
  const double limit = 0.5 * margin_ * margin_;
  const int n = std::min<int>(mesh.vertexSlots(), static_cast<int>(built_positions_.size()));
  for (int v = 0; v < n; ++v)
    if (mesh.vertexAlive(v) && (mesh.current(v) - built_positions_[v]).squaredNorm() > limit)
      return true;
  return false;
}

std::vector<int> TetGrid::query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi) const {
  std::vector<int> out;
  if (seen_.size() < static_cast<std::size_t>(mesh.tetSlots())) seen_.resize(mesh.tetSlots(), 0);
  if (++stamp_ == 0) {
    std::fill(seen_.begin(), seen_.end(), 0);
    stamp_ = 1;
  }
  const auto [i0, j0, k0] = cellOf(lo);
  const auto [i1, j1, k1] = cellOf(hi);
  if (static_cast<double>(i1 - i0 + 1) * (j1 - j0 + 1) * (k1 - k0 + 1) > 1e6) return out;
  for (int i = i0; i <= i1; ++i)
    for (int j = j0; j <= j1; ++j)
      for (int k = k0; k <= k1; ++k) {
        auto it = cells_.find(key(i, j, k));
        if (it == cells_.end()) continue;
        for (int t : it->second) {
          if (t >= mesh.tetSlots() || !mesh.tetAlive(t) || seen_[t] == stamp_) continue;
          seen_[t] = stamp_;
          Vec3 tlo, thi;
          tetBox(mesh, t, &tlo, &thi);
          if ((tlo.array() <= hi.array()).all() && (thi.array() >= lo.array()).all())
            out.push_back(t);
        }
      }
  return out;
}

}  // namespace tissue_cut
