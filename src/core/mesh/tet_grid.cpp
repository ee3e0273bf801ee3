#include "tissue_cut/mesh/tet_grid.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>

namespace tissue_cut {

namespace {

// The float next to f towards -infinity (down) or +infinity (up), as std::nextafter gives, without
// the library call (six a tet filed); non-finite f goes to std::nextafter.
float floatBelow(double x) {
  const float f = static_cast<float>(x);
  if (!std::isfinite(f)) return std::nextafter(f, -HUGE_VALF);
  if (f == 0.0f) return -std::numeric_limits<float>::denorm_min();
  std::uint32_t bits;
  std::memcpy(&bits, &f, sizeof bits);
  bits = f > 0.0f ? bits - 1 : bits + 1;
  float g;
  std::memcpy(&g, &bits, sizeof g);
  return g;
}

float floatAbove(double x) { return -floatBelow(-x); }

// At most this many cells per live tet: the cell grows when the mesh's box is sparse.
constexpr double kMaxCellsPerTet = 4.0;
// A refresh sorts the tets it refiles when they are fewer than one slot in this many; else it
// reads them off in slot order (a sort costs ~17 ns an element, a slot's look ~0.5 ns).
constexpr std::size_t kSortedPerSlot = 16;

}  // namespace

std::array<int, 3> TetGrid::cellOf(const Vec3& x) const {
  std::array<int, 3> c;
  for (int d = 0; d < 3; ++d) {
    const double u = (x[d] - origin_[d]) * inv_cell_;
    // Compare as doubles first: a far-away (or non-finite) point must not overflow the int. Past
    // zero the conversion's truncation is the floor (and std::floor a library call here).
    c[d] = !(u > 0) ? 0 : u >= dims_[d] - 1 ? dims_[d] - 1 : static_cast<int>(u);
  }
  return c;
}

TetGrid::Box TetGrid::boxOf(const TetMesh& mesh, int t, Filed* cells) const {
  const TetVerts& v = mesh.tet(t);
  // Every vertex of a filed tet has a filed position (build() and update() see to it).
  Vec3 lo = built_positions_[v[0]], hi = lo;
  for (int i = 1; i < 4; ++i) {
    lo = lo.cwiseMin(built_positions_[v[i]]);
    hi = hi.cwiseMax(built_positions_[v[i]]);
  }
  Box box;
  for (int d = 0; d < 3; ++d) {
    box.lo[d] = floatBelow(lo[d]);
    box.hi[d] = floatAbove(hi[d]);
  }
  *cells = {cellOf(lo), cellOf(hi)};
  return box;
}

void TetGrid::insert(const TetMesh& mesh, int t) {
  Filed f;
  const Box box = boxOf(mesh, t, &f);
  const auto [i0, j0, k0] = f.first;
  const auto [i1, j1, k1] = f.last;
  growSlots(&filed_, static_cast<std::size_t>(t) + 1);
  growSlots(&boxes_, static_cast<std::size_t>(t) + 1);
  boxes_[t] = box;
  // A reused slot whose last entries span the same cells (a split's pieces, a collapse's or a
  // move's star take back the slots of the tets they replace, mostly there): those serve.
  if (filed_[t].first == f.first && filed_[t].last == f.last) return;
  filed_[t] = f;
  for (int k = k0; k <= k1; ++k)
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i) {
        cells_[i + dims_[0] * (j + static_cast<std::size_t>(dims_[1]) * k)].push_back(t);
        ++entries_;
      }
}

void TetGrid::refile(const TetMesh& mesh, int t) {
  if (t >= static_cast<int>(filed_.size()) || filed_[t].first[0] < 0) {
    insert(mesh, t);
    return;
  }
  // Its new box; the cells of the old range not in the new one lose it, those of the new range
  // not in the old one get it. The tissue's drift seldom moves a tet to other cells: then its box
  // is all that changes.
  const Filed old = filed_[t];
  Filed now;
  boxes_[t] = boxOf(mesh, t, &now);
  if (now.first == old.first && now.last == old.last) return;
  filed_[t] = now;
  auto within = [](const Filed& f, int i, int j, int k) {
    return i >= f.first[0] && i <= f.last[0] && j >= f.first[1] && j <= f.last[1] &&
           k >= f.first[2] && k <= f.last[2];
  };
  auto cellAt = [this](int i, int j, int k) -> std::vector<int>& {
    return cells_[i + dims_[0] * (j + static_cast<std::size_t>(dims_[1]) * k)];
  };
  for (int k = old.first[2]; k <= old.last[2]; ++k)
    for (int j = old.first[1]; j <= old.last[1]; ++j)
      for (int i = old.first[0]; i <= old.last[0]; ++i) {
        if (within(now, i, j, k)) continue;
        auto& cell = cellAt(i, j, k);
        // A dead tet whose slot was reused may have left an entry of the same id: either one goes
        // (both stand for the same slot's box; only the count matters here).
        const auto it = std::find(cell.begin(), cell.end(), t);
        if (it != cell.end()) {
          *it = cell.back();
          cell.pop_back();
          --entries_;
        }
      }
  for (int k = now.first[2]; k <= now.last[2]; ++k)
    for (int j = now.first[1]; j <= now.last[1]; ++j)
      for (int i = now.first[0]; i <= now.last[0]; ++i)
        if (!within(old, i, j, k)) {
          cellAt(i, j, k).push_back(t);
          ++entries_;
        }
}

void TetGrid::refresh(const TetMesh& mesh, double moved, std::vector<int>* refiled) {
  if (cells_.empty()) return;
  drift_bound_ += moved >= 0.0 ? moved : HUGE_VAL;  // not known (or NaN): anything may have moved
  if (!(drift_bound_ > margin_)) return;            // no vertex can be past the margin yet
  ++scans_;
  const double limit = margin_ * margin_;
  const int n = std::min<int>(mesh.vertexSlots(), static_cast<int>(built_positions_.size()));
  const Vec3* now = mesh.currentPositions().data();
  const std::size_t first = refiled->size();
  nextStamp(&seen_, &stamp_, mesh.tetSlots());
  double farthest = 0.0;  // squared, of the vertices left where they are filed
  for (int v = 0; v < n; ++v) {
    const double d2 = (now[v] - built_positions_[v]).squaredNorm();
    if (!(d2 > limit) || !mesh.vertexAlive(v)) {
      if (mesh.vertexAlive(v)) farthest = std::max(farthest, d2);
      continue;
    }
    // Filed here now: so are its tets, below.
    built_positions_[v] = now[v];
    // Each tet once, however many of its vertices drifted (the tissue sags as a whole).
    for (const int t : mesh.vertexTets(v)) {
      if (seen_[t] == stamp_) continue;
      seen_[t] = stamp_;
      refiled->push_back(t);
    }
  }
  drift_bound_ = std::sqrt(farthest);
  // In increasing order: sorted, or, where many tets moved (the tissue sagging as a whole: a few
  // thousand a tick), read off the stamps in slot order, which costs a quarter as much.
  const std::size_t count = refiled->size() - first;
  if (count * kSortedPerSlot < seen_.size()) {
    std::sort(refiled->begin() + first, refiled->end());
  } else {
    refiled->resize(first);
    const int slots = std::min<int>(mesh.tetSlots(), static_cast<int>(seen_.size()));
    for (int t = 0; t < slots; ++t)
      if (seen_[t] == stamp_) refiled->push_back(t);
  }
  for (std::size_t i = first; i < refiled->size(); ++i) refile(mesh, (*refiled)[i]);
}

void TetGrid::build(const TetMesh& mesh, double cell, double margin) {
  cell_ = cell > 0 ? cell : 1.0;
  margin_ = margin;
  Vec3 lo = Vec3::Constant(1e300), hi = Vec3::Constant(-1e300);
  for (int v = 0; v < mesh.vertexSlots(); ++v) {
    if (!mesh.vertexAlive(v) || !mesh.current(v).allFinite()) continue;
    lo = lo.cwiseMin(mesh.current(v));
    hi = hi.cwiseMax(mesh.current(v));
  }
  if (!(lo.array() <= hi.array()).all()) lo = hi = Vec3::Zero();
  const Vec3 extent = hi - lo;
  const double budget = kMaxCellsPerTet * std::max(mesh.numTets(), 1);
  auto count = [&](double c) {
    double n = 1.0;
    for (int d = 0; d < 3; ++d) n *= std::floor(extent[d] / c) + 1.0;
    return n;
  };
  while (count(cell_) > budget) cell_ *= 1.25;
  origin_ = lo;
  inv_cell_ = 1.0 / cell_;
  for (int d = 0; d < 3; ++d) dims_[d] = static_cast<int>(std::floor(extent[d] / cell_)) + 1;
  // Emptied cells keep their capacity: a rebuild of a grid of the same size allocates nothing.
  const std::size_t cells = static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2];
  if (cells_.size() > cells) cells_.resize(cells);
  for (auto& c : cells_) c.clear();
  cells_.resize(cells);
  entries_ = 0;
  assignSlots(&filed_, mesh.tetSlots(), Filed{});
  assignSlots(&boxes_, mesh.tetSlots(), Box{});
  built_positions_.reserve(mesh.currentPositions().capacity());
  built_positions_ = mesh.currentPositions();
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t)) insert(mesh, t);
  entries_at_build_ = entries_;
  drift_bound_ = 0.0;
}

void TetGrid::update(const TetMesh& mesh, const ChangeRecord& change, std::vector<int>* refiled) {
  growSlots(&built_positions_, static_cast<std::size_t>(mesh.vertexSlots()), Vec3::Zero());
  for (int v : change.added_vertices) built_positions_[v] = mesh.current(v);
  // A vertex the change moved (a smoothing move) past the margin from where it was filed is
  // filed where it is now, before the added tets are: then its other tets too. (Vertex ids are
  // never reused: an added vertex is filed where it was made, just above.)
  const double limit = margin_ * margin_;
  std::vector<int>& moved = moved_scratch_;
  moved.clear();
  for (int t : change.added_tets) {
    if (!mesh.tetAlive(t)) continue;
    for (int v : mesh.tet(t)) {
      if (!((mesh.current(v) - built_positions_[v]).squaredNorm() <= limit)) {
        built_positions_[v] = mesh.current(v);
        moved.push_back(v);
      }
    }
  }
  for (int t : change.added_tets)
    if (mesh.tetAlive(t)) insert(mesh, t);
  // The added tets were filed with the new positions already (refile() leaves them as they are).
  for (int v : moved)
    for (int t : mesh.vertexTets(v)) {
      refile(mesh, t);
      if (refiled) refiled->push_back(t);
    }
}

bool TetGrid::needsRebuild(const TetMesh& mesh) const {
  if (cluttered()) return true;
  // A tet is filed under its vertices' filed positions: with each vertex within the margin of
  // its own, no box has moved more than the margin from where it was filed.
  const double limit = margin_ * margin_;
  const int n = std::min<int>(mesh.vertexSlots(), static_cast<int>(built_positions_.size()));
  for (int v = 0; v < n; ++v)
    if (mesh.vertexAlive(v) && (mesh.current(v) - built_positions_[v]).squaredNorm() > limit)
      return true;
  return false;
}

std::vector<int> TetGrid::query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi) const {
  std::vector<int> out;
  query(mesh, lo, hi, &out);
  return out;
}

void TetGrid::filed(const TetMesh& mesh, const Vec3& lo, const Vec3& hi, bool current,
                    std::vector<int>* out) const {
  out->clear();
  if (cells_.empty()) return;
  growSlots(&found_bits_, (static_cast<std::size_t>(mesh.tetSlots()) + 63) / 64, std::uint64_t{0});
  std::size_t first_word = found_bits_.size(), last_word = 0;
  const Vec3 margin = Vec3::Constant(margin_);
  const auto [i0, j0, k0] = cellOf(lo - margin);
  const auto [i1, j1, k1] = cellOf(hi + margin);
  float qlo[3], qhi[3];
  grown(lo, hi, qlo, qhi);
  for (int k = k0; k <= k1; ++k)
    for (int j = j0; j <= j1; ++j)
      for (int i = i0; i <= i1; ++i)
        for (const int t : cells_[i + dims_[0] * (j + static_cast<std::size_t>(dims_[1]) * k)]) {
          const Box& e = boxes_[t];
          if (e.lo[0] > qhi[0] || e.hi[0] < qlo[0] || e.lo[1] > qhi[1] || e.hi[1] < qlo[1] ||
              e.lo[2] > qhi[2] || e.hi[2] < qlo[2])
            continue;
          if (t >= mesh.tetSlots() || !mesh.tetAlive(t)) continue;
          const std::size_t word = static_cast<std::size_t>(t) >> 6;
          const std::uint64_t bit = std::uint64_t{1} << (t & 63);
          if (found_bits_[word] & bit) continue;  // met in another cell
          // (One left out here is tested again in its other cells, with the same answer.)
          if (current && !tetBoxMeets(mesh, t, lo, hi)) continue;
          found_bits_[word] |= bit;
          first_word = std::min(first_word, word);
          last_word = std::max(last_word, word);
        }
  // Read out in id order, each word cleared for the next call.
  for (std::size_t word = first_word; word <= last_word && word < found_bits_.size(); ++word) {
    std::uint64_t bits = found_bits_[word];
    found_bits_[word] = 0;
    while (bits) {
      out->push_back(static_cast<int>(word * 64 + __builtin_ctzll(bits)));
      bits &= bits - 1;
    }
  }
}

void TetGrid::candidates(const TetMesh& mesh, const Vec3& lo, const Vec3& hi,
                         std::vector<int>* out) const {
  filed(mesh, lo, hi, false, out);
}

void TetGrid::grown(const Vec3& lo, const Vec3& hi, float* qlo, float* qhi) const {
  // A filed box that may have drifted into the query box overlaps it grown by the margin (a
  // little more, and rounded outward, for the floats).
  for (int d = 0; d < 3; ++d) {
    const double slack = reach(lo, hi, d);
    qlo[d] = floatBelow(lo[d] - slack);
    qhi[d] = floatAbove(hi[d] + slack);
  }
}

bool TetGrid::filedNear(const TetMesh& mesh, int t, const Vec3& lo, const Vec3& hi) const {
  float qlo[3], qhi[3];
  grown(lo, hi, qlo, qhi);
  return filedIn(mesh, t, qlo, qhi);
}

void TetGrid::filedNear(const TetMesh& mesh, const std::vector<int>& tets, const Vec3& lo,
                        const Vec3& hi, std::vector<unsigned char>* near) const {
  float qlo[3], qhi[3];
  grown(lo, hi, qlo, qhi);
  near->resize(tets.size());
  for (std::size_t i = 0; i < tets.size(); ++i) (*near)[i] = filedIn(mesh, tets[i], qlo, qhi);
}

bool TetGrid::filedIn(const TetMesh& mesh, int t, const float* qlo, const float* qhi) const {
  if (cells_.empty() || !mesh.tetAlive(t) || t >= static_cast<int>(boxes_.size())) return false;
  // The test candidates() makes of its filed box.
  const Box& e = boxes_[t];
  return !(e.lo[0] > qhi[0] || e.hi[0] < qlo[0] || e.lo[1] > qhi[1] || e.hi[1] < qlo[1] ||
           e.lo[2] > qhi[2] || e.hi[2] < qlo[2]);
}

void TetGrid::query(const TetMesh& mesh, const Vec3& lo, const Vec3& hi,
                    std::vector<int>* out) const {
  filed(mesh, lo, hi, true, out);
}

}  // namespace tissue_cut
