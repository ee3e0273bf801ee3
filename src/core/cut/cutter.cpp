#include "tissue_cut/cut/cutter.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <type_traits>

#include "tissue_cut/mesh/sorted_search.hpp"

namespace tissue_cut {

namespace {

// The planes of the two swept triangles, and the signed distance of x from plane k computed as
// pointNearTriangle and segmentCrossesTriangle compute it (the same operations: the same value).
struct SweptPlanes {
  explicit SweptPlanes(const std::array<Triangle, 2>& t) : tris(t) {
    for (int k = 0; k < 2; ++k) {
      n[k] = (tris[k][1] - tris[k][0]).cross(tris[k][2] - tris[k][0]);
      len[k] = n[k].norm();
    }
  }
  double distance(int k, const Vec3& x) const {
    return len[k] > 0 ? n[k].dot(x - tris[k][0]) / len[k] : HUGE_VAL;
  }
  const std::array<Triangle, 2>& tris;
  std::array<Vec3, 2> n;
  std::array<double, 2> len;
};

// The sweep's filter of tets (see sweep()): each usable swept triangle's plane and its three
// in-plane side normals, pointing away from it, as separating axes, with the room the crossing
// test's rounding needs in the plane. A point's place along the eight axes is values(); a tet's
// distance from the plane of a triangle it lies over, from its corners' places, reach(); whether
// the sweep keeps a tet at that distance, keeps().
struct SweepAxes {
  struct Axis {
    Vec3 n;
    double at;
  };
  std::array<std::array<Axis, 4>, 2> axes;
  std::array<bool, 2> usable{false, false};
  std::array<double, 2> side_tol{0.0, 0.0};
  // The bands around a plane, with room for rounding: the snap distance's, and the wound's (for a
  // tet holding a wound vertex).
  double narrow = 0.0, wide = 0.0;
  SweepAxes(const std::array<Triangle, 2>& tris, double snap, double wound_snap,
            double mean_edge) {
    const double tol = 1e-9 * mean_edge;
    narrow = snap * (1.0 + 1e-9) + tol;
    wide = std::max(snap, wound_snap) * (1.0 + 1e-9) + tol;
    for (int k = 0; k < 2; ++k) {
      const Vec3 n = (tris[k][1] - tris[k][0]).cross(tris[k][2] - tris[k][0]);
      if (!(n.norm() > 0)) continue;
      usable[k] = true;
      const Vec3 unit = n.normalized();
      axes[k][0] = {unit, unit.dot(tris[k][0])};
      double longest = 0.0;
      for (int e = 0; e < 3; ++e) {
        const Vec3 &p = tris[k][e], &q = tris[k][(e + 1) % 3], &r = tris[k][(e + 2) % 3];
        longest = std::max(longest, (q - p).norm());
        Vec3 m = (q - p).cross(unit);
        if (m.dot(r - p) > 0) m = -m;  // away from the triangle
        const double len = m.norm();
        if (len > 0) m /= len;
        axes[k][e + 1] = {m, m.dot(p)};
      }
      // segmentCrossesTriangle lets barycentric coordinates down to -1e-9 through.
      side_tol[k] = 1e-6 * longest + tol;
    }
  }
  // at[4 k + e]: x along axis e of triangle k (0 where the triangle is not usable).
  void values(const Vec3& x, double* at) const {
    for (int k = 0; k < 2; ++k)
      for (int e = 0; e < 4; ++e)
        at[4 * k + e] = usable[k] ? axes[k][e].n.dot(x) - axes[k][e].at : 0.0;
  }
  // The distance of a tet, its corners' values() given, from the plane of a swept triangle it
  // lies over (infinity: none).
  double reach(const std::array<const double*, 4>& corner) const {
    double best = std::numeric_limits<double>::infinity();
    for (int k = 0; k < 2; ++k) {
      if (!usable[k]) continue;
      bool over = true;
      for (int e = 1; e < 4 && over; ++e) {
        double lo = std::numeric_limits<double>::infinity();
        for (const double* at : corner) lo = std::min(lo, at[4 * k + e]);
        over = lo <= side_tol[k];
      }
      if (!over) continue;
      double lo = std::numeric_limits<double>::infinity(), hi = -lo;
      for (const double* at : corner) {
        lo = std::min(lo, at[4 * k]);
        hi = std::max(hi, at[4 * k]);
      }
      best = std::min(best, std::max({0.0, lo, -hi}));
    }
    return best;
  }
  // wound(): whether the tet holds a wound vertex (asked only where it decides).
  template <typename Wound>
  bool keeps(double reach, const Wound& wound) const {
    return reach <= narrow || (reach <= wide && wound());
  }
};

// The sweep's box from `from` to `to`: the blade's four ends, grown by the snap distance.
std::pair<Vec3, Vec3> sweepBox(const BladeSegment& from, const BladeSegment& to, double snap) {
  const Vec3 lo = from.base.cwiseMin(from.tip).cwiseMin(to.base).cwiseMin(to.tip);
  const Vec3 hi = from.base.cwiseMax(from.tip).cwiseMax(to.base).cwiseMax(to.tip);
  return {lo.array() - snap, hi.array() + snap};
}

void renameIn(TetCut* cut, int from, int to) {
  for (int& v : cut->corner)
    if (v == from) v = to;
  for (int& v : cut->edge_point)
    if (v == from) v = to;
  for (int& v : cut->face_point)
    if (v == from) v = to;
}

}  // namespace

Cutter::Cutter(TetMesh* mesh, const CutterOptions& options) : mesh_(mesh), options_(options) {
  reset();
}

void Cutter::reset() {
  swept_valid_ = false;
  pending_.clear();
  wound_flag_.clear();
  marked_.clear();
  marked_at_.clear();
  previous_.reset();
  deferred_.clear();
  kept_off_.clear();
  stood_for_.clear();
  quiet_valid_ = false;
  changed_near_.clear();
  counts_ = CutCounts{};
  stateChanged();
  separated_at_ = -1;
  assignSlots(&pending_of_, mesh_->tetSlots(), -1);
  double sum = 0.0;
  const auto edges = mesh_->edges();
  for (const auto& [a, b] : edges) sum += (mesh_->rest(a) - mesh_->rest(b)).norm();
  mean_edge_ = edges.empty() ? 1.0 : sum / edges.size();
  snap_distance_ = options_.snap * mean_edge_;
  wound_snap_distance_ = std::max(options_.snap, options_.wound_snap) * mean_edge_;
  rebuildGrid();
  sizeScratch();
}

void Cutter::sizeScratch() {
  // Sized here, at load, rather than by the tick that first needs them: the first separation
  // of the 20k organ's incision (tick 12, one cut tet) took 0.35-0.37 ms in heldSplits() alone,
  // against 15-55 us on the cut ticks after it, touching ~1 MB of fresh pages. Each keeps the
  // meaning it has between uses (stamps older than their calls, no corner's group, no face
  // open, no vertex splitting, marks and wound flags of none).
  const std::size_t tets = mesh_->tetSlots(), verts = mesh_->vertexSlots();
  growSlots(&star_stamp_, tets, 0u);
  growSlots(&star_place_, tets, 0);
  growSlots(&corner_group_, tets, {-1, -1, -1, -1});
  growSlots(&open_face_, tets, {});
  growSlots(&region_stamp_, tets, 0u);
  growSlots(&split_state_, verts, {});
  growSlots(&marked_at_, verts, 0);
  growSlots(&wound_flag_, verts, {});
  for (auto* stamps :
       {&check_stamp_, &ring_stamp_, &wait_stamp_, &axis_stamp_, &vertex_seen_, &kept_stale_})
    growSlots(stamps, verts, 0u);
  growSlots(&axis_slot_, verts, 0);
}

void Cutter::tissueMoved(double distance) {
  told_motion_ = true;
  const double d = distance >= 0.0 ? distance : HUGE_VAL;  // NaN: anything may have moved
  moved_ += d;
  gap_tissue_ += d;
  quiet_moved_ += d;
}

void Cutter::rebuildGrid() {
  grid_.build(*mesh_, 2.0 * mean_edge_, mean_edge_);
  near_cache_valid_ = false;  // the candidates were the old grid's
  gap_valid_ = false;
}

void Cutter::mark(const std::array<int, 3>& face) {
  // Only a face between two tets can open; a cut along a boundary face (a blade following its
  // wound) has nothing to open there, and a mark would keep its vertices busy for good.
  const int t1 = mesh_->faceTet(face[0], face[1], face[2]);
  if (t1 < 0 || mesh_->faceTet(face[0], face[1], face[2], t1) < 0) return;
  if (marked_.insert(face).second) {
    stateChanged();
    for (int v : face) {
      growSlots(&marked_at_, static_cast<std::size_t>(v) + 1, 0);
      ++marked_at_[v];
    }
    changed_near_.insert(changed_near_.end(), face.begin(), face.end());
  }
}

bool Cutter::unmark(const std::array<int, 3>& face) {
  if (!marked_.erase(face)) return false;
  stateChanged();
  changed_near_.insert(changed_near_.end(), face.begin(), face.end());
  for (int v : face) --marked_at_[v];
  return true;
}

bool Cutter::isBusyAfresh(int v) const {
  if (deferred_.count(v) || markedAt(v)) return true;
  for (int t : mesh_->vertexTets(v))
    if (isPendingPiece(t)) return true;
  return false;
}

bool Cutter::keepBusy(int v) const {
  // Asked for each vertex of each tet the collapse queue takes up, most of them several times
  // between two changes of the answers (stateEpoch()): each answer is kept for its epoch.
  const std::size_t slot = static_cast<std::size_t>(v);
  const bool busy = isBusyAfresh(v);
  growSlots(&busy_known_, slot + 1, 0LL);
  growSlots(&busy_answer_, slot + 1, static_cast<unsigned char>(0));
  busy_known_[slot] = busy_epoch_ + 1;
  busy_answer_[slot] = busy ? 1 : 0;
  return busy;
}

void Cutter::refreshGrid(const ChangeRecord& change) {
  update_refiled_.clear();
  grid_.update(*mesh_, change, &update_refiled_);
  joinNearCache(change.added_tets);
  joinNearCache(update_refiled_);
  // What the new tets hold near the blade joins the quiet ticks' features (every edge of theirs:
  // the ones a crossing of which changes nothing are too few there to look for), sorted before
  // the next tick looks at them.
  if (quiet_valid_ && !pieces_only_ && !change.added_tets.empty()) {
    static const std::vector<std::pair<int, int>> none;
    newQuietBatch();
    for (int t : change.added_tets)
      if (mesh_->tetAlive(t) && !isPendingPiece(t)) quietTet(mesh_->tet(t), 0.0, none);
    quiet_unsorted_ = true;
  }
}

void Cutter::joinNearCache(const std::vector<int>& tets) {
  if (!near_cache_valid_) return;
  std::vector<unsigned char>& near = join_near_;
  grid_.filedNear(*mesh_, tets, near_cache_lo_, near_cache_hi_, &near);
  for (std::size_t k = 0; k < tets.size(); ++k) {
    const int t = tets[k];
    const std::size_t i = lowerBoundIndex(near_cache_, t);
    const auto it = near_cache_.begin() + static_cast<std::ptrdiff_t>(i);
    const bool cached = it != near_cache_.end() && *it == t;
    if (!near[k]) {
      if (cached) {
        near_gap_[i] = 0.0;  // a slot reused far away: left to the box filter
        keepClose(i, false);
      }
      continue;
    }
    // A tet filed anew is new or has moved (refiled, or a slot reused): its gap is taken where it
    // is first read (kGapDue), so that a tet made and replaced before then (a pending tet's
    // pieces, a collapse's star) is never measured.
    const double gap = gap_valid_ ? kGapDue : 0.0;
    if (!cached) {
      near_cache_.insert(it, t);
      near_gap_.insert(near_gap_.begin() + i, gap);
    } else {
      near_gap_[i] = gap;
    }
    keepClose(i, !cached);
  }
}

void Cutter::keepClose(std::size_t place, bool inserted) {
  if (!closeKept()) return;  // made anew before the next sweep looks
  const int i = static_cast<int>(place);
  auto at = near_close_.begin() + static_cast<std::ptrdiff_t>(lowerBoundIndex(near_close_, i));
  if (inserted)
    for (auto shift = at; shift != near_close_.end(); ++shift) ++*shift;
  // A place whose gap grew past gap_far_ may stay: the sweep tests each gap it looks at.
  if (near_gap_[place] <= gap_far_ && (inserted || at == near_close_.end() || *at != i))
    near_close_.insert(at, i);
}

void Cutter::cacheNear(const Vec3& lo, const Vec3& hi, bool anew) {
  // The blade moves a little each tick: the grid's candidates around a box larger by half a mean
  // edge serve the ticks while it stays inside.
  if (anew || !cacheHolds(lo, hi)) {
    near_cache_lo_ = lo.array() - 0.5 * mean_edge_;
    near_cache_hi_ = hi.array() + 0.5 * mean_edge_;
    const bool had = near_cache_valid_;
    old_cache_.swap(near_cache_);
    old_gap_.swap(near_gap_);
    grid_.candidates(*mesh_, near_cache_lo_, near_cache_hi_, &near_cache_);
    near_cache_valid_ = true;
    // The tets of the old cache keep their gaps (both lists are in id order), the others are
    // measured by the next sweep's query, which takes the gaps again (see sweepQuery()).
    near_gap_.assign(near_cache_.size(), std::numeric_limits<double>::quiet_NaN());
    if (had) {
      std::size_t j = 0;
      for (std::size_t i = 0; i < near_cache_.size(); ++i) {
        while (j < old_cache_.size() && old_cache_[j] < near_cache_[i]) ++j;
        if (j < old_cache_.size() && old_cache_[j] == near_cache_[i]) near_gap_[i] = old_gap_[j];
      }
    }
    gap_retake_ = true;
  }
}

void Cutter::roomAround(const BladeSegment& at) {
  // quietReach() keeps the features within its reach of `at` only while the sweeps' boxes stay
  // inside the cache; near the cache's edge the reach shrinks to nothing, and the ticks are
  // swept until one sweep's box leaves the cache and takes it anew. Taken anew here first, the
  // reach is whole. (The cache and the gaps only filter: what the sweeps find is the same.)
  if (!closeKept()) return;
  if (cacheMargin(at) - snap_distance_ >= options_.quiet_reach * mean_edge_) return;
  const auto [box_lo, box_hi] = sweepBox(at, at, snap_distance_);
  cacheNear(box_lo, box_hi, true);
  retakeGaps(at);
}

bool Cutter::cacheHolds(const Vec3& lo, const Vec3& hi) const {
  return near_cache_valid_ && !(lo.array() < near_cache_lo_.array()).any() &&
         !(hi.array() > near_cache_hi_.array()).any();
}

double Cutter::cacheMargin(const BladeSegment& at) const {
  const Vec3 lo = at.base.cwiseMin(at.tip), hi = at.base.cwiseMax(at.tip);
  return std::min((lo - near_cache_lo_).minCoeff(), (near_cache_hi_ - hi).minCoeff());
}

void Cutter::gridQuery(const Vec3& lo, const Vec3& hi, std::vector<int>* out) {
  // Each query filters the cached candidates by current boxes, exactly as the grid would (live
  // tets whose current box meets [lo, hi], in id order).
  cacheNear(lo, hi);
  out->clear();
  for (int t : near_cache_)
    if (mesh_->tetAlive(t) && tetBoxMeets(*mesh_, t, lo, hi)) out->push_back(t);
}

double Cutter::measureDue(std::size_t i) {
  // Measured now instead of when the tet was filed: the tissue's moves since gap_ref_ are counted
  // as they are now, and the bound holds as well (see near_gap_).
  return near_gap_[i] = dueGap(i);
}

double Cutter::dueGap(std::size_t i) const {
  const int t = near_cache_[i];
  return mesh_->tetAlive(t) ? gapOf(t) + gap_tissue_ : 0.0;
}

std::pair<double, double> Cutter::gapReach(const BladeSegment& from, const BladeSegment& to,
                                           double step, double moved) const {
  // How far from the sweep a tet can still take part in it: the wound's band (a vertex snapped
  // or an edge crossing near a wound vertex), the fronts' shift, with room for the rounding
  // tolerances of the tests (relative to the mean edge and to the sweep's size).
  const double slack = 0.01 * mean_edge_ +
                       1e-5 * ((from.tip - from.base).norm() + (to.tip - to.base).norm() + step);
  const double reach = std::max(snap_distance_, frontShift()) + slack + moved;
  // Only a tet holding a vertex on a wound takes part from within the wound's band.
  return {reach, std::max(reach, wound_snap_distance_ + slack + moved)};
}

bool Cutter::gapTakes(int t, double gap, double reach, double wound_reach) const {
  // A pending tet's pieces are always looked at: the tet, not a piece, decides its part.
  return gap <= reach || isPendingPiece(t) ||
         (gap <= wound_reach && mesh_->tetAlive(t) && anyOnWound(mesh_->tet(t)));
}

double Cutter::gapOf(int t) const {
  // Every use of a gap is a filter against gap_far_ or less: a bound past it is as good as the
  // largest one, and most of the cache's tets give one on the cheaper axes. (Carried over, such
  // a bound is measured again sooner; that costs less than the face normals of every tet: in the
  // 20k replay 9,808 gaps instead of 8,182, 3.6 M instructions instead of 4.9 M. Stopping past
  // gap_far_ plus a quarter, a half, one or two mean edges cost more: 3.9-4.7 M.)
  const TetVerts& tv = mesh_->tet(t);
  return segmentTetGap(gap_segment_,
                       {mesh_->current(tv[0]), mesh_->current(tv[1]), mesh_->current(tv[2]),
                        mesh_->current(tv[3])},
                       gap_far_);
}

bool Cutter::gapsRestart(const BladeSegment& from) const {
  return !gap_valid_ || !told_motion_ || from.base != gap_last_.base || from.tip != gap_last_.tip;
}

bool Cutter::gapsRetaken(const BladeSegment& from, double step) const {
  return gapsRestart(from) || gap_retake_ ||
         !(gap_blade_ + step + gap_tissue_ <= 0.2 * mean_edge_);
}

void Cutter::retakeGaps(const BladeSegment& from) {
  const bool restart = gapsRestart(from);
  gap_retake_ = false;
  const double moves = gap_blade_ + gap_tissue_;
  const bool carry = !restart && std::isfinite(moves);
  gap_far_ = std::max({snap_distance_, frontShift(), wound_snap_distance_}) + 0.3 * mean_edge_;
  gap_ref_ = from;
  gap_segment_ = PreparedSegment(from.base, from.tip);
  gap_blade_ = 0.0;
  gap_tissue_ = 0.0;
  near_gap_.resize(near_cache_.size());
  for (std::size_t i = 0; i < near_cache_.size(); ++i) {
    if (!mesh_->tetAlive(near_cache_[i])) {
      near_gap_[i] = 0.0;
      continue;
    }
    if (carry && near_gap_[i] - moves > gap_far_) {  // false for a tet new in the cache (NaN)
      near_gap_[i] -= moves;
      continue;
    }
    near_gap_[i] = gapOf(near_cache_[i]);
  }
  gap_valid_ = true;
  near_close_.clear();
  for (std::size_t i = 0; i < near_cache_.size(); ++i)
    if (near_gap_[i] <= gap_far_) near_close_.push_back(static_cast<int>(i));
}

void Cutter::sweepQuery(const BladeSegment& from, const BladeSegment& to, const Vec3& lo,
                        const Vec3& hi, std::vector<int>* out) {
  cacheNear(lo, hi);
  const double step = std::max((to.base - from.base).norm(), (to.tip - from.tip).norm());
  // The gaps are taken anew from this tick's blade when they are not known, when the blade
  // did not come from where the last sweep left it (a new stroke), when nobody says how far the
  // tissue moves, and when the moves since add up to a fifth of an edge (the filter loosens).
  // In the last case a tet's old gap less those moves still bounds its distance from the blade
  // here (the blade came on from where the gaps were taken by at most gap_blade_, the tissue by
  // at most gap_tissue_): a tet whose bound stays beyond any reach until the gaps are taken again
  // (gap_far_) keeps it, and only the others are measured (most of the cache lies far from the
  // blade).
  if (gapsRetaken(from, step)) retakeGaps(from);
  gap_blade_ += step;
  gap_last_ = to;
  const auto [reach, wound_reach] = gapReach(from, to, step, gap_blade_ + gap_tissue_);
  if (!(wound_reach < gap_far_)) {
    // A blade so long that the tests' rounding room reaches past gap_far_ (kilometres): every
    // gap measured in full, none carried.
    gap_far_ = HUGE_VAL;
    for (std::size_t i = 0; i < near_cache_.size(); ++i) near_gap_[i] = dueGap(i);
    near_close_.resize(near_cache_.size());
    std::iota(near_close_.begin(), near_close_.end(), 0);
  }
  // Only the close places can pass the test below (reach and wound_reach are under gap_far_),
  // and a pending tet's pieces wherever they are: both, merged in order.
  far_pieces_.clear();
  for (const auto& [pid, p] : pending_)
    for (int t : p.pieces) {
      const std::size_t i = lowerBoundIndex(near_cache_, t);
      if (i == near_cache_.size() || near_cache_[i] != t) continue;
      if (!(near_gap_[i] <= gap_far_)) far_pieces_.push_back(static_cast<int>(i));
    }
  std::sort(far_pieces_.begin(), far_pieces_.end());
  out->clear();
  auto close = near_close_.begin();
  auto far = far_pieces_.begin();
  while (close != near_close_.end() || far != far_pieces_.end()) {
    // A place may be in both (a close gap that grew since): looked at once.
    const bool take_close =
        far == far_pieces_.end() || (close != near_close_.end() && *close < *far);
    if (!take_close && close != near_close_.end() && *close == *far) ++close;
    const std::size_t i = take_close ? *close++ : *far++;
    const int t = near_cache_[i];
    if (gapTakes(t, gapAt(i), reach, wound_reach) && mesh_->tetAlive(t) &&
        tetBoxMeets(*mesh_, t, lo, hi))
      out->push_back(t);
  }
}

template <typename Make>
bool Cutter::changeMesh(const std::vector<int>& remove, const Make& make, ChangeRecord* change,
                        std::vector<int>* ids) {
  ChangeRecord& local = mesh_change_;  // (make() changes only the mesh: never nested)
  local.clear();
  std::vector<int>& added = ids ? *ids : change_added_;  // the new tets, into the caller's list
  try {
    make(&local, &added);
  } catch (const std::logic_error& e) {
    // TetMesh checks a change whole before making it: refused, the mesh is as it was. The caller
    // leaves the cut closed there; the tick reports it and the model goes on.
    ++counts_.refused;
    if (refusal_.empty()) refusal_ = e.what();
    return false;
  }
  growSlots(&pending_of_, mesh_->tetSlots(), -1);
  for (int t : remove) pending_of_[t] = -1;
  stateChanged();
  refreshGrid(local);
  change->append(local);
  return true;
}

bool Cutter::replace(const std::vector<int>& remove, const std::vector<TetVerts>& add,
                     ChangeRecord* change, const std::vector<int>* from, std::vector<int>* ids) {
  return changeMesh(
      remove,
      [&](ChangeRecord* local, std::vector<int>* added) {
        mesh_->replaceTets(remove, add, local, from, added);
      },
      change, ids);
}

bool Cutter::splitOff(const std::vector<int>& tets, int v, int copy, ChangeRecord* change,
                      std::vector<int>* ids) {
  return changeMesh(
      tets,
      [&](ChangeRecord* local, std::vector<int>* added) {
        mesh_->renameVertex(tets, v, copy, local, added);
      },
      change, ids);
}

void Cutter::noteChanged(const ChangeRecord& change) {
  for (int t : change.added_tets)
    if (mesh_->tetAlive(t))
      for (int v : mesh_->tet(t)) changed_near_.push_back(v);
  // A collapse also drops the tets around the merged edge: the survivor's neighbours held them.
  for (const auto& merged : change.merged_vertices) {
    const int survivor = merged.second;
    if (!mesh_->vertexAlive(survivor)) continue;
    for (int t : mesh_->vertexTets(survivor))
      for (int v : mesh_->tet(t)) changed_near_.push_back(v);
  }
}

void Cutter::follow(const ChangeRecord& change) {
  // A collapse changes no vertex's busy state (it works only where none is busy), but it may
  // let a waiting vertex split.
  if (!change.empty()) ++epoch_;
  noteChanged(change);
  growSlots(&pending_of_, mesh_->tetSlots(), -1);
  for (int t : change.removed_tets) pending_of_[t] = -1;
  for (const auto& [gone, survivor] : change.merged_vertices) {
    if (static_cast<std::size_t>(gone) >= wound_flag_.size() || !wound_flag_[gone]) continue;
    setWoundFlag(survivor, wound_flag_[gone]);
    wound_flag_[gone] = 0;
  }
  refreshGrid(change);
}

TetVerts Cutter::cornersOf(const Coarse& c) const {
  return c.pending >= 0 ? pending_.at(c.pending).cut.corner : mesh_->tet(c.tet);
}

void Cutter::coarseNear(const Vec3& lo, const Vec3& hi, std::vector<Coarse>* out) {
  if (swept_valid_ && (lo.array() >= swept_lo_.array()).all() &&
      (hi.array() <= swept_hi_.array()).all()) {
    // Inside this tick's sweep box, whose tets no change since has replaced: filter those,
    // exactly as the grid would (live tets whose current box meets [lo, hi], in id order).
    near_scratch_.clear();
    for (int t : swept_near_)
      if (tetBoxMeets(*mesh_, t, lo, hi)) near_scratch_.push_back(t);
  } else {
    gridQuery(lo, hi, &near_scratch_);
  }
  coarseOf(near_scratch_, out);
}

void Cutter::coarseOf(const std::vector<int>& tets, std::vector<Coarse>* out) const {
  out->clear();
  std::vector<int>& seen_pending = seen_scratch_;  // few: the tets the blade is inside
  seen_pending.clear();
  for (int t : tets) {
    const int pid = pending_of_[t];
    if (pid < 0) {
      out->push_back({-1, t});
    } else if (std::find(seen_pending.begin(), seen_pending.end(), pid) == seen_pending.end()) {
      seen_pending.push_back(pid);
      out->push_back({pid, -1});
    }
  }
}

bool Cutter::coarseAround(const Corners& verts, std::vector<Coarse>* out) const {
  // The coarse tets (plain tets and pending tets) having all of `verts` as corners. A pending
  // tet's pieces may split its faces, so pending tets are matched by their corners. False when
  // the edge or face is already cut or lies inside a pending tet (a crossing there is ignored:
  // the blade crossed it twice).
  out->clear();
  std::vector<int>& seen = seen_scratch_;  // pending tets taken
  seen.clear();
  for (int t : mesh_->vertexTets(verts[0])) {
    const TetVerts& tv = mesh_->tet(t);
    bool fine_holds = true;
    for (int v : verts) fine_holds = fine_holds && localIndex(tv, v) >= 0;
    const int pid = pending_of_[t];
    if (pid < 0) {
      if (fine_holds) out->push_back({-1, t});
      continue;
    }
    const Pending& p = pending_.at(pid);
    Corners local;
    for (int v : verts) {
      const int i = localIndex(p.cut.corner, v);
      if (i >= 0) local.push_back(i);
    }
    if (local.size() != verts.size()) {
      if (fine_holds) return false;  // a piece's own edge or face, inside the pending tet
      continue;
    }
    if (std::find(seen.begin(), seen.end(), pid) != seen.end()) continue;
    seen.push_back(pid);
    if (verts.size() == 2 && p.cut.edge_point[tetEdgeIndex(local[0], local[1])] >= 0) return false;
    if (verts.size() == 3 && p.cut.face_point[6 - local[0] - local[1] - local[2]] >= 0)
      return false;
    out->push_back({pid, -1});
  }
  return !out->empty();
}

int Cutter::makePending(int tet) {
  const int pid = next_pending_++;
  Pending& p = pending_[pid];
  p.cut.corner = mesh_->tet(tet);
  for (int c = 0; c < 4; ++c) p.cut.on_cut[c] = onCut(p.cut.corner[c]);
  // Room for the pieces of its subdivisions (setPieces()), taken once.
  p.pieces.reserve(kPiecesRoom);
  p.pieces.assign(1, tet);
  pending_of_[tet] = pid;
  stateChanged();
  return pid;
}

bool Cutter::conforming(const std::vector<Coarse>& around, const Corners& verts) const {
  // Around one edge or face, a tet the blade left and that is cut again may have as a corner a
  // point that is still only on an edge or face of a pending neighbour: there the neighbour's
  // face is already split more finely on the other side. A second point on such a face is
  // placed alike on both sides (the face rule splits it as the older point did first); a face
  // point, or a third point, could not be, so that crossing is ignored.
  std::vector<int>& points = points_scratch_;  // (each once or more: only asked whether held)
  points.clear();
  for (const Coarse& c : around) {
    if (c.pending < 0) continue;
    const TetCut& cut = pending_.at(c.pending).cut;
    for (int v : cut.edge_point)
      if (v >= 0) points.push_back(v);
    for (int v : cut.face_point)
      if (v >= 0) points.push_back(v);
  }
  bool finer = false;
  for (const Coarse& c : around)
    for (int v : cornersOf(c))
      finer = finer || std::find(points.begin(), points.end(), v) != points.end();
  if (!finer) return true;
  if (verts.size() != 2) return false;
  for (const Coarse& c : around) {
    if (c.pending < 0) continue;
    const TetCut& cut = pending_.at(c.pending).cut;
    const int i = localIndex(cut.corner, verts[0]), j = localIndex(cut.corner, verts[1]);
    for (int f = 0; f < 4; ++f) {
      if (f == i || f == j) continue;  // the two faces holding edge ij
      if (cut.face_point[f] >= 0) return false;
      int on_face = 0;
      for (int e = 0; e < 6; ++e)
        if (kTetEdge[e][0] != f && kTetEdge[e][1] != f && cut.edge_point[e] >= 0) ++on_face;
      if (on_face >= 2) return false;
    }
  }
  return true;
}

void Cutter::registerEdgePoint(int a, int b, double s, ChangeRecord* change) {
  std::vector<Coarse>& around = around_;
  if (!coarseAround({a, b}, &around)) return;  // already cut here, or inside a pending tet
  if (!conforming(around, {a, b})) return;
  // A point nearer a corner than this would only make a needle: keep it a little inside.
  s = std::clamp(s, 0.05, 0.95);
  const int v = mesh_->addVertex({{a, 1.0 - s}, {b, s}}, change);
  setWoundFlag(v, kWound);
  for (const Coarse& c : around) {
    const int pid = c.pending >= 0 ? c.pending : makePending(c.tet);
    Pending& p = pending_[pid];
    p.cut.edge_point[tetEdgeIndex(localIndex(p.cut.corner, a), localIndex(p.cut.corner, b))] = v;
    p.dirty = true;
  }
}

bool Cutter::faceOnBoundary(const Coarse& c, const std::array<int, 3>& face) const {
  if (c.pending < 0) {
    const TetVerts& tv = mesh_->tet(c.tet);
    return mesh_->neighbor(c.tet, 6 - localIndex(tv, face[0]) - localIndex(tv, face[1]) -
                                      localIndex(tv, face[2])) < 0;
  }
  // A pending tet's face may be split among its pieces: look at a piece face lying on it.
  const Pending& p = pending_.at(c.pending);
  InlineVector<int, 6> on_face{face[0], face[1], face[2]};
  int local[3];
  for (int k = 0; k < 3; ++k) local[k] = localIndex(p.cut.corner, face[k]);
  for (int i = 0; i < 3; ++i)
    for (int j = i + 1; j < 3; ++j) {
      const int e = p.cut.edge_point[tetEdgeIndex(local[i], local[j])];
      if (e >= 0) on_face.push_back(e);
    }
  for (int t : p.pieces) {
    const TetVerts& tv = mesh_->tet(t);
    for (int f = 0; f < 4; ++f) {
      bool lies = true;
      for (int k = 0; k < 3 && lies; ++k)
        lies = std::find(on_face.begin(), on_face.end(), tv[kTetFace[f][k]]) != on_face.end();
      if (lies) return mesh_->neighbor(t, f) < 0;
    }
  }
  return false;
}

void Cutter::registerFacePoint(const std::array<int, 3>& face, const Vec3& weights,
                               ChangeRecord* change) {
  std::vector<Coarse>& around = around_;
  if (!coarseAround({face[0], face[1], face[2]}, &around)) return;
  // Both sides must take the point, or neither: a side already cut and replaced (its face split
  // into smaller faces) cannot, so the crossing is ignored there.
  if (around.size() == 1 && !faceOnBoundary(around[0], face)) return;
  if (!conforming(around, {face[0], face[1], face[2]})) return;
  // Keep the point off the face's edges: a front through an edge lands just beside it.
  Vec3 w = weights.cwiseMax(0.05);
  w /= w.sum();
  const int v = mesh_->addVertex({{face[0], w[0]}, {face[1], w[1]}, {face[2], w[2]}}, change);
  setWoundFlag(v, kWound);
  for (const Coarse& c : around) {
    const int pid = c.pending >= 0 ? c.pending : makePending(c.tet);
    Pending& p = pending_[pid];
    const int f = 6 - localIndex(p.cut.corner, face[0]) - localIndex(p.cut.corner, face[1]) -
                  localIndex(p.cut.corner, face[2]);
    p.cut.face_point[f] = v;
    p.dirty = true;
  }
}

bool Cutter::nearTrailingLine(const Vec3& x, const std::array<Triangle, 2>& tris) const {
  // tris[0] = (base0, tip0, tip1), tris[1] = (base0, tip1, base1): the blade came from base0-tip0
  // and is at base1-tip1.
  const Vec3 &base0 = tris[0][0], &tip0 = tris[0][1], &tip1 = tris[1][1], &base1 = tris[1][2];
  const Vec3 line = tip0 - base0;
  const double len2 = line.squaredNorm();
  if (!(len2 > 0)) return false;
  const double s = line.dot(x - base0) / len2;
  if (!(s > 0.0 && s < 1.0) || (x - base0 - s * line).norm() >= snap_distance_) return false;
  // Not ahead of the blade: a slow blade's quad is thin, and the band around the line reaches
  // tissue it has not come to yet.
  const Vec3 along = (tip1 - base1).normalized();
  Vec3 motion = 0.5 * ((base1 + tip1) - (base0 + tip0));
  motion -= motion.dot(along) * along;
  return (x - base1).dot(motion) <= 0.0;
}

void Cutter::trySnap(int v, const std::array<Triangle, 2>& tris,
                     const std::array<PreparedTriangle, 2>& prepared, const Vec3& normal) {
  if (onCut(v)) return;
  const Vec3& x = mesh_->current(v);
  // Where a trembling blade turns from one tick to the next, the two ticks' quads meet along the
  // blade's line at an angle, and a vertex just outside that crease lies over neither quad
  // although it is within the snap distance of both: it is taken when it lies that close to the
  // line the blade came from. Only a vertex not on a wound: a wound's own points there are
  // followed by the band below.
  const bool at_crease = !onWound(v) && nearTrailingLine(x, tris);
  const PointOverTriangle over0(x, prepared[0]), over1(x, prepared[1]);
  if (!at_crease && !over0.near(snap_distance_) && !over1.near(snap_distance_)) {
    // A point of an earlier cut whose wall runs along this sweep is taken as lying on it within
    // a wider band: the blade is moving inside that wound (which the tissue has moved since).
    if (!onWound(v) || (!over0.near(wound_snap_distance_) && !over1.near(wound_snap_distance_)) ||
        !woundFacing(v, normal))
      return;
  }
  // A vertex next to a cut point already made stays off the cut: the point took its place. It
  // stays off for good, once that tet is replaced too: snapped later, by a blade coming back
  // along the cut, it would give faces along the cut through it and the points around it, a
  // fraction of a millimetre off the wall, and the tets between would be cut off as chips (a
  // blade trembling 10 um on its way back over the block cut off 36 of them).
  const auto kept = kept_off_.find(v);
  if (kept != kept_off_.end()) {
    if (kept->second == mesh_->rest(v)) return;
    kept_off_.erase(kept);  // the slot holds another vertex now, or this one was moved
  }
  for (int t : mesh_->vertexTets(v)) {
    const int pid = pending_of_[t];
    if (pid < 0) continue;
    const Pending& p = pending_.at(pid);
    const int i = localIndex(p.cut.corner, v);
    if (i < 0) return;  // v is itself a cut point of a pending tet
    for (int e = 0; e < 6; ++e)
      if (p.cut.edge_point[e] >= 0 && (kTetEdge[e][0] == i || kTetEdge[e][1] == i)) {
        if (!onWound(v)) kept_off_[v] = mesh_->rest(v);
        return;
      }
  }
  setWoundFlag(v, kOnCut);
  std::vector<int> around = mesh_->vertexTets(v);
  for (int t : around) {
    const int pid = pending_of_[t];
    if (pid >= 0) {
      Pending& p = pending_[pid];
      p.cut.on_cut[localIndex(p.cut.corner, v)] = true;
      continue;
    }
    // Three corners on the cut: the cut may run along a face; decided when the blade leaves.
    int on = 0;
    for (int u : mesh_->tet(t)) on += onCut(u) ? 1 : 0;
    if (on >= 3) makePending(t);
  }
}

int Cutter::addSteiner(const Pending& p, ChangeRecord* change) {
  const auto& c = p.cut.corner;
  return mesh_->addVertex({{c[0], 0.25}, {c[1], 0.25}, {c[2], 0.25}, {c[3], 0.25}}, change);
}

void Cutter::setPieces(int pid, const std::vector<int>& pieces) {
  Pending& p = pending_[pid];
  p.pieces = pieces;
  for (int t : pieces) pending_of_[t] = pid;
}

void Cutter::subdivide(int pid, ChangeRecord* change) {
  Pending& p = pending_[pid];
  p.dirty = false;
  ++counts_.subdivisions;
  auto rest = [this](int v) { return mesh_->rest(v); };
  auto cur = [this](int v) { return mesh_->current(v); };
  TetSplit& split = subdivide_split_;
  subdivideTet(p.cut, rest, cur, p.steiner, &split);
  if (split.kind == SplitKind::kNeedsSteiner) {
    p.steiner = addSteiner(p, change);
    subdivideTet(p.cut, rest, cur, p.steiner, &split);
  }
  if (split.kind == SplitKind::kUntouched) return;
  std::vector<int>& ids = subdivide_ids_;
  std::vector<int>& old = subdivide_old_;
  old = p.pieces;
  // The pieces stand in for the pending tet, whose corners, edges and faces a sweep looks at:
  // nothing new for the quiet ticks' features.
  pieces_only_ = true;
  const bool replaced = replace(old, split.tets, change, nullptr, &ids);
  pieces_only_ = false;
  if (replaced) setPieces(pid, ids);
  dropUnusedSteiner(&p.steiner, change);
}

void Cutter::dropUnusedSteiner(int* steiner, ChangeRecord* change) {
  // A centroid vertex one subdivision needed may be left out by the next (more points came) or
  // by the final split: a vertex no tet holds must go.
  if (*steiner < 0 || !mesh_->vertexAlive(*steiner) || !mesh_->vertexTets(*steiner).empty()) return;
  ChangeRecord local;  // appended, so that a centroid added within this change never existed
  mesh_->removeVertex(*steiner, &local);
  change->append(local);
  *steiner = -1;
}

void Cutter::finalize(int pid, ChangeRecord* change, std::vector<int>* touched) {
  Pending& p = finalize_pending_;  // a copy: pending_[pid] is erased below
  p = pending_[pid];
  auto rest = [this](int v) { return mesh_->rest(v); };
  auto cur = [this](int v) { return mesh_->current(v); };
  TetSplit& split = finalize_split_;
  splitTet(p.cut, rest, cur, p.steiner, &split);
  if (split.kind == SplitKind::kNeedsSteiner) {
    if (p.steiner < 0) p.steiner = addSteiner(p, change);
    splitTet(p.cut, rest, cur, p.steiner, &split);
  }
  // A tent's sheet ends at its centroid. Where a later pass of the blade crossed this tet's edge
  // next to a wound vertex at one end, the crossing was dropped because that vertex stood for it
  // (woundAround()); if the cut through that corner separates the tet cleanly, it is taken
  // instead, so that the sheet reaches the vertex and the earlier cut. Otherwise the sheet stopped
  // one face short of it and left a bridge across the wound (the bench incision's mouth on the
  // 20k organ; handles in the wounds of strokes trembling 0.1 mm a tick).
  if (split.kind == SplitKind::kTent && !stood_for_.empty()) {
    for (int i = 0; i < 4 && split.kind == SplitKind::kTent; ++i) {
      if (p.cut.on_cut[i]) continue;
      bool stood = false;
      for (int j = 0; j < 4 && !stood; ++j)
        stood = j != i && stood_for_.count(pairKey(p.cut.corner[i], p.cut.corner[j])) > 0;
      if (!stood) continue;
      TetCut through = p.cut;
      through.on_cut[i] = true;
      TetSplit other = splitTet(through, rest, cur, p.steiner);
      if (other.kind != SplitKind::kComplete) continue;
      p.cut = through;
      split = std::move(other);
    }
  }
  // A tet whose pieces predate its last points (finalizeLeft() did not subdivide it again) gets
  // pieces that conform to every point wherever they stay in the mesh: kept as they are, or kept
  // because the replacement is refused.
  auto conformingPieces = [&] {
    if (!pending_[pid].dirty) return;
    subdivide(pid, change);
    p.pieces = pending_[pid].pieces;
  };
  if (split.kind != SplitKind::kUntouched && split.kind != SplitKind::kAlongFace) {
    std::vector<int>& ids = finalize_ids_;
    std::vector<int>& from = finalize_from_;
    from.assign(split.tets.size(), -1);
    if (!replace(p.pieces, split.tets, change, &from, &ids)) {
      // Refused: the tet keeps its temporary pieces (they fill it and conform to every point),
      // and the cut stays closed inside it.
      conformingPieces();
      for (int t : p.pieces) pending_of_[t] = -1;
      dropUnusedSteiner(&p.steiner, change);
      pending_.erase(pid);
      stateChanged();
      return;
    }
    dropUnusedSteiner(&p.steiner, change);
    ++counts_.cut_tetrahedra;
    counts_.created_tetrahedra += static_cast<int>(ids.size());
    for (const TetVerts& t : split.tets) touched->insert(touched->end(), t.begin(), t.end());
  } else {
    conformingPieces();
    for (int t : p.pieces) pending_of_[t] = -1;
  }
  ++counts_.by_kind[static_cast<int>(split.kind)];
  if (on_split) on_split(p.cut, split);
  for (const auto& f : split.cut_faces) {
    mark(sortedFace(f[0], f[1], f[2]));
    touched->insert(touched->end(), f.begin(), f.end());
  }
  if (p.steiner >= 0 && mesh_->vertexAlive(p.steiner) && mesh_->vertexTets(p.steiner).empty()) {
    ChangeRecord local;
    mesh_->removeVertex(p.steiner, &local);
    change->append(local);
  }
  pending_.erase(pid);
  stateChanged();
}

void Cutter::finalizeLeft(const std::optional<BladeSegment>& blade, ChangeRecord* change,
                          bool stroke_end) {
  // The tets the blade has left are replaced now; the others that took new points are
  // subdivided anew to stand in the mesh until then. A tet left on the tick it took a point is
  // not subdivided first (its final split replaces whatever pieces it has; see finalize()).
  std::vector<int>& resubdivide = final_ids_;
  resubdivide.clear();
  left_.clear();
  for (auto& [pid, p] : pending_) {
    const TetVerts& c = p.cut.corner;
    const bool left = !blade || !p.planes.meets(blade->base, blade->tip, mesh_->current(c[0]),
                                                mesh_->current(c[1]), mesh_->current(c[2]),
                                                mesh_->current(c[3]), 1e-3 * mean_edge_);
    if (left) left_.push_back(pid);
    if (p.dirty && (!left || options_.subdivide_left)) resubdivide.push_back(pid);  // map order
  }
  for (int pid : resubdivide) subdivide(pid, change);
  std::sort(left_.begin(), left_.end());
  std::vector<int>& touched = final_touched_;
  touched.clear();
  for (int pid : left_) finalize(pid, change, &touched);
  // Vertices waiting to split are tried again only when the mesh or the marks changed since the
  // last try (the separation depends on nothing else, so a retry would only defer them again),
  // and all of them once a stroke ends (see separate()).
  if (!touched.empty() || (!deferred_.empty() && (separated_at_ != epoch_ || stroke_end)))
    separate(&touched, stroke_end, change);
  else if (deferred_.empty())
    changed_near_.clear();  // nothing waits near these changes
}

int Cutter::groupsAround(int v) const {
  // Called for every vertex a cut touched, a few times each: no allocation once grown (a vector
  // of vectors a call had been a quarter of it), and a face is looked up among the marked ones
  // only when all three of its vertices hold one.
  const std::vector<int>& star = mesh_->vertexTets(v);
  const int n = static_cast<int>(star.size());
  std::vector<int>& parent = star_parent_;
  parent.resize(n);
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  // Each star tet's place in the star, by tet slot (valid where star_stamp_ is this call's).
  nextStamp(&star_stamp_, &star_call_, mesh_->tetSlots());
  growSlots(&star_place_, star_stamp_.size(), {});
  for (int i = 0; i < n; ++i) {
    star_stamp_[star[i]] = star_call_;
    star_place_[star[i]] = i;
  }
  // A face is marked only if each of its vertices is on a marked face. Each face between two star
  // tets is looked at once, from the tet earlier in the star (from the other side it joined what
  // was joined already: the same groups, the same roots, half the marked-face lookups).
  const bool any_marked = markedAt(v);
  int components = n;
  for (int i = 0; i < n; ++i) {
    const TetVerts& tv = mesh_->tet(star[i]);
    for (int f = 0; f < 4; ++f) {
      // Not the face opposite v (it does not hold v), nor one on the boundary: one branch.
      const int u = mesh_->neighbor(star[i], f);
      if ((tv[f] == v) | (u < 0)) continue;
      if (star_stamp_[u] != star_call_ || star_place_[u] < i) continue;
      const int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]];
      if (any_marked && markedAt(a) && markedAt(b) && markedAt(c) &&
          marked_.count(sortedFace(a, b, c)))
        continue;
      const int from = find(i), to = find(star_place_[u]);
      if (from == to) continue;
      parent[from] = to;
      // One group: nothing splits, no caller reads the lists, and the faces left cannot part it.
      if (--components == 1) return 1;
    }
  }
  // One group (or none): nothing splits, and no caller reads the lists.
  int roots = 0;
  for (int r = 0; r < n && roots < 2; ++r) roots += parent[r] == r;
  if (roots < 2) return roots;
  // The groups in the order of their roots' places in the star, each in star order: counted,
  // then filled.
  std::vector<int>& group_of = star_group_;
  group_of.assign(n, -1);
  group_start_.assign(1, 0);
  for (int r = 0; r < n; ++r)
    if (parent[r] == r) {
      group_of[r] = static_cast<int>(group_start_.size()) - 1;
      group_start_.push_back(0);
    }
  const int groups = static_cast<int>(group_start_.size()) - 1;
  for (int i = 0; i < n; ++i) {
    parent[i] = find(i);
    ++group_start_[group_of[parent[i]] + 1];
  }
  for (int k = 0; k < groups; ++k) group_start_[k + 1] += group_start_[k];
  // Filled forward with each group's start as its cursor, which ends at the next group's start.
  group_tets_.resize(n);
  for (int i = 0; i < n; ++i) group_tets_[group_start_[group_of[parent[i]]]++] = star[i];
  for (int k = groups; k > 0; --k) group_start_[k] = group_start_[k - 1];
  group_start_[0] = 0;
  return groups;
}

const std::vector<int>& Cutter::heldSplits(const std::vector<int>& verts) {
  // Opening the cut splits vertices; a cut face opens where one of its vertices is split between
  // its two tets. While the blade is still cutting nearby, splitting some vertex may leave the
  // boundary pinched at a neighbour that cannot split yet (its star is still joined through tets
  // not cut yet). The separation is simulated first; a vertex whose split would pinch the
  // boundary waits (it is tried again on later ticks, when the cut around it is complete).
  // The groups depend on the mesh and the marks only: taken once. Each tet of a splitting vertex's
  // star records, at that vertex's corner, the group it will use (-1: the vertex does not split).
  growSlots(&corner_group_, mesh_->tetSlots(), {-1, -1, -1, -1});
  growSlots(&open_face_, mesh_->tetSlots(), {});
  growSlots(&split_state_, mesh_->vertexSlots(), {});
  constexpr unsigned char kSplits = 1, kHeld = 2;  // split_state_: a candidate, held back
  std::vector<int>& splitting = held_splitting_;
  std::vector<int>& stars = held_stars_;
  splitting.clear();
  stars.clear();
  nextStamp(&kept_stale_, &kept_call_, mesh_->vertexSlots());
  kept_groups_.assign(verts.size(), -1);
  kept_count_.assign(verts.size(), 0);
  kept_start_.clear();
  kept_tets_.clear();
  for (std::size_t place = 0; place < verts.size(); ++place) {
    const int v = verts[place];
    if (!mesh_->vertexAlive(v)) continue;
    const int groups = groupsAround(v);
    kept_count_[place] = groups;
    if (groups < 2) {
      kept_groups_[place] = kCountKept;
      continue;
    }
    kept_groups_[place] = static_cast<int>(kept_start_.size());
    for (int k = 0; k <= groups; ++k)
      kept_start_.push_back(static_cast<int>(kept_tets_.size()) + group_start_[k]);
    kept_tets_.insert(kept_tets_.end(), group_tets_.begin(),
                      group_tets_.begin() + group_start_[groups]);
    splitting.push_back(v);
    split_state_[v] = kSplits;
    for (int k = 0; k < groups; ++k)
      for (int i = group_start_[k]; i < group_start_[k + 1]; ++i) {
        const int t = group_tets_[i];
        corner_group_[t][localIndex(mesh_->tet(t), v)] = k;
        stars.push_back(t);
      }
  }
  // The result: the candidates held back (all of them if the rounds do not settle), sorted.
  auto done = [&](bool settled) -> const std::vector<int>& {
    std::vector<int>& result = held_result_;
    result.clear();
    for (int v : splitting)
      if (!settled || split_state_[v] == kHeld) result.push_back(v);
    for (int t : stars) corner_group_[t] = {-1, -1, -1, -1};
    for (int v : splitting) split_state_[v] = 0;
    std::sort(result.begin(), result.end());
    return result;
  };
  using Key = std::int64_t;  // a vertex and the group of it a tet will use (-1: not split)
  auto keyOf = [&](int t, int corner) {
    return (static_cast<Key>(mesh_->tet(t)[corner]) << 20) |
           static_cast<Key>(corner_group_[t][corner] + 1);
  };
  std::vector<int>& region = held_region_;
  std::vector<int>& opened = held_opened_;
  std::vector<int>& check = held_check_;
  std::vector<int>& held = held_back_;
  std::vector<FanEdge>& fan = held_fan_;
  for (int round = 0; round < 32; ++round) {
    nextStamp(&region_stamp_, &region_call_, mesh_->tetSlots());
    region.clear();
    for (int v : splitting)
      if (split_state_[v] == kSplits)
        for (int t : mesh_->vertexTets(v))
          if (region_stamp_[t] != region_call_) {
            region_stamp_[t] = region_call_;
            region.push_back(t);
          }
    if (region.empty()) return done(true);
    // Faces that open: shared by two tets of which one names a vertex of it differently (after
    // the split) from the other. Flagged on both sides; their vertices' boundaries change.
    nextStamp(&check_stamp_, &check_call_, mesh_->vertexSlots());
    opened.clear();
    check.clear();
    for (int t : region) {
      const TetVerts& tv = mesh_->tet(t);
      for (int f = 0; f < 4; ++f) {
        const int u = mesh_->neighbor(t, f);
        if (u < 0) continue;
        const TetVerts& uv = mesh_->tet(u);
        bool same = true;
        for (int j = 0; j < 3 && same; ++j) {
          const int c = kTetFace[f][j];
          same = corner_group_[t][c] == corner_group_[u][localIndex(uv, tv[c])];
        }
        if (same) continue;
        if (!(open_face_[t] & (1 << f))) {
          int back = 0;
          while (mesh_->neighbor(u, back) != t) ++back;
          open_face_[t] |= static_cast<unsigned char>(1 << f);
          open_face_[u] |= static_cast<unsigned char>(1 << back);
          opened.push_back(t);
          opened.push_back(u);
        }
        for (int j = 0; j < 3; ++j) {
          const int x = tv[kTetFace[f][j]];
          if (check_stamp_[x] == check_call_) continue;
          check_stamp_[x] = check_call_;
          check.push_back(x);
        }
      }
    }
    held.clear();
    for (int w : check) {
      // The boundary triangles around each copy of w after the split, as links prev -> next:
      // each copy's must close into one cycle (a disc), or the boundary is pinched at w.
      fan.clear();
      for (int t : mesh_->vertexTets(w)) {
        const TetVerts& tv = mesh_->tet(t);
        for (int f = 0; f < 4; ++f) {
          if (tv[f] == w) continue;
          if (mesh_->neighbor(t, f) >= 0 && !(open_face_[t] & (1 << f))) continue;
          for (int j = 0; j < 3; ++j)
            if (tv[kTetFace[f][j]] == w)
              fan.push_back({keyOf(t, kTetFace[f][j]), keyOf(t, kTetFace[f][(j + 2) % 3]),
                             keyOf(t, kTetFace[f][(j + 1) % 3])});
        }
      }
      std::sort(fan.begin(), fan.end(), [](const FanEdge& a, const FanEdge& b) {
        return a.copy != b.copy ? a.copy < b.copy : a.prev < b.prev;
      });
      bool manifold = true;
      for (std::size_t i = 0; i < fan.size() && manifold;) {
        std::size_t j = i;
        while (j < fan.size() && fan[j].copy == fan[i].copy) ++j;
        for (std::size_t k = i + 1; k < j && manifold; ++k)
          manifold = fan[k].prev != fan[k - 1].prev;  // one link out of each
        // Walk the links from the first: a single cycle through all of them.
        const Key start = fan[i].prev;
        Key cur = start;
        std::size_t steps = 0;
        while (manifold) {
          const auto it = std::lower_bound(
              fan.begin() + i, fan.begin() + j, cur,
              [](const FanEdge& e, Key prev) { return e.prev < prev; });
          if (it == fan.begin() + j || it->prev != cur) break;
          cur = it->next;
          ++steps;
          if (cur == start || steps > j - i) break;
        }
        if (steps != j - i || cur != start) manifold = false;
        i = j;
      }
      if (manifold) continue;
      // Hold back every split that opens a face at w.
      for (int t : mesh_->vertexTets(w)) {
        const TetVerts& tv = mesh_->tet(t);
        for (int f = 0; f < 4; ++f) {
          if (tv[f] == w || !(open_face_[t] & (1 << f))) continue;
          for (int j = 0; j < 3; ++j)
            if (split_state_[tv[kTetFace[f][j]]] == kSplits) held.push_back(tv[kTetFace[f][j]]);
        }
      }
    }
    for (int t : opened) open_face_[t] = 0;
    if (held.empty()) return done(true);
    for (int x : held) {
      if (split_state_[x] != kSplits) continue;
      split_state_[x] = kHeld;
      for (int t : mesh_->vertexTets(x)) corner_group_[t][localIndex(mesh_->tet(t), x)] = -1;
    }
  }
  return done(false);
}

int Cutter::groupsKept(int v, int place) {
  const int first = place < static_cast<int>(kept_groups_.size()) ? kept_groups_[place] : -1;
  if (!options_.keep_groups || first == -1 || kept_stale_[v] == kept_call_) return groupsAround(v);
  ++counts_.groups_kept;
  // What groupsAround(v) would answer now: it depends on v's star and the marks on its faces only.
  const int groups = kept_count_[place];
  if (first == kCountKept) return groups;  // one group (or none): not listed
  const int base = kept_start_[first];
  group_start_.resize(groups + 1);
  for (int k = 0; k <= groups; ++k) group_start_[k] = kept_start_[first + k] - base;
  group_tets_.assign(kept_tets_.begin() + base, kept_tets_.begin() + kept_start_[first + groups]);
  return groups;
}

void Cutter::keptStale(const std::vector<int>& tets) {
  growSlots(&kept_stale_, mesh_->vertexSlots(), 0u);
  for (int t : tets)
    for (int x : mesh_->tet(t)) kept_stale_[x] = kept_call_;
}

void Cutter::separate(std::vector<int>* touched_io, bool all_waiting, ChangeRecord* change) {
  // Whether a vertex can split depends on its star and marks (its groups), on the faces it and its
  // neighbours would open (their vertices are in its first ring) and on the boundary fans around
  // those (tets of its second ring). A waiting vertex farther than two rings from every change
  // since the last try is left waiting, untried. Tried together with far waiting vertices it
  // might sometimes pass (the simulation holds back whole neighbourhoods at a pinch), so at the
  // end of a stroke every waiting vertex is tried. On a blade trembling inside its own wound
  // thousands wait, and trying them all on every tick made ticks of a hundred milliseconds.
  noteChanged(*change);
  nextStamp(&ring_stamp_, &ring_call_, mesh_->vertexSlots());
  std::vector<int>& ring = ring_;
  ring.clear();
  for (int v : changed_near_)
    if (mesh_->vertexAlive(v) && ring_stamp_[v] != ring_call_) {
      ring_stamp_[v] = ring_call_;
      ring.push_back(v);
    }
  changed_near_.clear();
  // Being within two rings is symmetric: the rings are grown from the changed vertices, or from
  // each waiting vertex when those are fewer (mostly one or two against 5-30 changed: growing
  // from the changes had been a tenth of the cut ticks' replacement work).
  const bool from_waiting = !all_waiting && deferred_.size() < ring.size();
  // ring becomes the vertices of the tets around it not stamped yet, stamped now.
  auto grow = [&](std::vector<unsigned>* stamp, unsigned call) {
    std::vector<int>& next = ring_next_;
    next.clear();
    for (int v : ring)
      for (int t : mesh_->vertexTets(v))
        for (int x : mesh_->tet(t))
          if ((*stamp)[x] != call) {
            (*stamp)[x] = call;
            next.push_back(x);
          }
    ring.swap(next);
  };
  for (int step = 0; step < 2 && !deferred_.empty() && !from_waiting; ++step)
    grow(&ring_stamp_, ring_call_);
  // From a waiting vertex w: its two rings, grown in `ring` (the changes' own are stamped).
  auto near_change = [&](int w) {
    if (ring_stamp_[w] == ring_call_) return true;
    if (!from_waiting) return false;  // the changes' two rings are stamped
    nextStamp(&wait_stamp_, &wait_call_, mesh_->vertexSlots());
    wait_stamp_[w] = wait_call_;
    ring.assign(1, w);
    for (int step = 0; step < 2; ++step) {
      grow(&wait_stamp_, wait_call_);
      for (int x : ring)
        if (ring_stamp_[x] == ring_call_) return true;
    }
    return false;
  };
  std::vector<int>& touched = *touched_io;
  std::vector<int>& before = separate_before_;  // the waiting vertices tried again, in order
  before.clear();
  for (auto it = deferred_.begin(); it != deferred_.end();) {
    if (!all_waiting && mesh_->vertexAlive(*it) && !near_change(*it)) {
      ++it;  // waits on, untried
      continue;
    }
    before.push_back(*it);
    touched.push_back(*it);
    it = deferred_.erase(it);
  }
  std::sort(touched.begin(), touched.end());
  touched.erase(std::unique(touched.begin(), touched.end()), touched.end());
  separated_at_ = epoch_;  // before the splits below: those make it try again next tick
  counts_.separation_tries += static_cast<long long>(touched.size());
  const std::vector<int>& held = heldSplits(touched);
  std::vector<int>& after = separate_after_;  // the vertices tried that wait now, in order
  after.clear();
  bool reclosed = false;  // a refused split closed faces for good: groups may have merged
  for (std::size_t place = 0; place < touched.size(); ++place) {
    const int v = touched[place];
    if (!mesh_->vertexAlive(v)) continue;
    const bool waits = std::binary_search(held.begin(), held.end(), v);
    if (waits && !reclosed) {
      after.push_back(v);  // held with two groups or more; splits before it did not change them
      continue;
    }
    if (groupsKept(v, static_cast<int>(place)) < 2) continue;
    if (waits) {
      after.push_back(v);
      continue;
    }
    // The groups as vectors: replace() takes the tets it removes (and renames) as one.
    std::vector<std::vector<int>>& groups = separate_groups_;
    groups.resize(group_start_.size() - 1);
    for (std::size_t k = 0; k + 1 < group_start_.size(); ++k)
      groups[k].assign(group_tets_.begin() + group_start_[k],
                       group_tets_.begin() + group_start_[k + 1]);
    // The group holding a pending tet's pieces keeps the vertex, so pending state stays as is.
    std::size_t keep = 0;
    for (std::size_t k = 0; k < groups.size(); ++k)
      for (int t : groups[k])
        if (pending_of_[t] >= 0) keep = k;
    for (std::size_t k = 0; k < groups.size(); ++k) {
      if (k == keep) continue;
      const std::vector<int>& tets = groups[k];
      keptStale(tets);  // renamed below, or their marks opened for good
      ChangeRecord& local = separate_change_;
      local.clear();
      const int copy = mesh_->addVertex({{v, 1.0}}, &local);
      std::vector<int>& in_group = in_group_;  // sorted
      in_group.assign(tets.begin(), tets.end());
      std::sort(in_group.begin(), in_group.end());
      auto inGroup = [&](int t) { return std::binary_search(in_group.begin(), in_group.end(), t); };
      // Cut faces between two tets of this group move to the copy; the others open.
      std::vector<std::pair<std::array<int, 3>, bool>>& marks = separate_marks_;
      marks.clear();  // face, moves to the copy
      for (int t : tets) {
        const TetVerts& tv = mesh_->tet(t);
        for (int f = 0; f < 4; ++f) {
          if (tv[f] == v) continue;
          const auto key = sortedFace(tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]);
          if (!marked_.count(key)) continue;
          const int u = mesh_->neighbor(t, f);
          marks.emplace_back(key, u >= 0 && inGroup(u));
        }
      }
      std::vector<int>& pendings = separate_pendings_;  // ascending, each once
      pendings.clear();
      for (int t : tets)
        if (pending_of_[t] >= 0) pendings.push_back(pending_of_[t]);
      std::sort(pendings.begin(), pendings.end());
      pendings.erase(std::unique(pendings.begin(), pendings.end()), pendings.end());
      std::vector<int>& ids = separate_ids_;
      if (!splitOff(tets, v, copy, &local, &ids)) {
        // Refused: no copy; the faces that would have opened here stay closed for good.
        ChangeRecord gone;  // appended, so that the copy never existed
        mesh_->removeVertex(copy, &gone);
        local.append(gone);
        change->append(local);
        for (const auto& [key, moves] : marks) unmark(key);
        reclosed = true;
        continue;
      }
      change->append(local);
      noteChanged(local);  // tried again next time, around the split
      ++counts_.separated_vertices;
      if (onWound(v)) setWoundFlag(copy, wound_flag_[v]);
      for (auto [key, moves] : marks) {
        if (!unmark(key) || !moves) continue;
        for (int& x : key)
          if (x == v) x = copy;
        std::sort(key.begin(), key.end());
        mark(key);
      }
      for (int pid : pendings) {
        Pending& p = pending_[pid];
        renameIn(&p.cut, v, copy);
        if (p.steiner == v) p.steiner = copy;
        std::vector<int>& pieces = separate_pieces_;
        pieces.clear();
        for (int t : p.pieces)
          if (!inGroup(t)) pieces.push_back(t);
        for (std::size_t j = 0; j < tets.size(); ++j)
          if (std::find(p.pieces.begin(), p.pieces.end(), tets[j]) != p.pieces.end())
            pieces.push_back(ids[j]);
        setPieces(pid, pieces);
      }
    }
  }
  if (after != before) stateChanged();
  deferred_.insert(after.begin(), after.end());
}

void Cutter::sweep(const BladeSegment& from, const BladeSegment& to, ChangeRecord* change,
                   const Reached* only) {
  const auto tris = sweptTriangles(from, to);
  const double tiny = 1e-12 * mean_edge_ * mean_edge_;
  if (triangleArea(tris[0]) <= tiny && triangleArea(tris[1]) <= tiny) return;
  const std::array<PreparedTriangle, 2> prepared{PreparedTriangle(tris[0]),
                                                 PreparedTriangle(tris[1])};
  const auto [lo, hi] = sweepBox(from, to, snap_distance_);
  if (only) {
    // The one vertex first, as the sweep snaps its vertices before it crosses edges.
    const Vec3 normal = sweepNormal(tris);
    if (only->vertex >= 0) trySnap(only->vertex, tris, prepared, normal);
    if (!only->edges.empty())
      crossEdges(from, to, tris, prepared, normal, lo, hi, &only->edges, change);
    return;
  }
  sweepQuery(from, to, lo, hi, &near_scratch_);
  std::vector<Coarse>& near = sweep_near_;
  coarseOf(near_scratch_, &near);
  // The fronts of this tick lie in this box (moved by less than the snap distance) and within
  // the sweep's reach: their searches filter these tets, as long as no tet is replaced before
  // (see step()).
  swept_near_ = near_scratch_;
  swept_lo_ = lo;
  swept_hi_ = hi;
  swept_valid_ = true;
  // Only a tet meeting the slab of a swept triangle grown by the snap band along its normal can
  // hold a vertex that snaps onto the sweep (pointNearTriangle: within the band of the plane,
  // over the triangle itself) or an edge that crosses it; the wound's wider band counts only for
  // tets holding a wound vertex. A tet is tested against each triangle along its normal (grown by
  // the band) and the in-plane normals of its three sides (a separating axis test; in the plane
  // only the crossing test's own rounding margin). The box around a long, tilted blade holds many
  // more tets; the others are left out before the per-vertex and per-edge work (they would do
  // nothing there).
  const SweepAxes axes(tris, snap_distance_, wound_snap_distance_, mean_edge_);
  const SweptPlanes planes(tris);
  // Each vertex's place along the eight axes and its distances from the two planes, taken once a
  // tick (the near tets share most of their vertices; the sweep moves none): per vertex slot,
  // where its values are in axis_values_.
  nextStamp(&axis_stamp_, &axis_call_, mesh_->vertexSlots());
  growSlots(&axis_slot_, axis_stamp_.size());
  axis_values_.clear();
  auto slotOf = [&](int v) {
    if (axis_stamp_[v] != axis_call_) {
      axis_stamp_[v] = axis_call_;
      axis_slot_[v] = static_cast<int>(axis_values_.size());
      const Vec3& x = mesh_->current(v);
      std::array<double, 10> at{};
      axes.values(x, at.data());
      at[8] = planes.distance(0, x);
      at[9] = planes.distance(1, x);
      axis_values_.push_back(at);
    }
    return axis_slot_[v];
  };
  // The distance of the tet from the plane of a swept triangle it lies over (infinity: none).
  auto reach = [&](const TetVerts& tv) {
    const std::array<int, 4> slot{slotOf(tv[0]), slotOf(tv[1]), slotOf(tv[2]), slotOf(tv[3])};
    return axes.reach({axis_values_[slot[0]].data(), axis_values_[slot[1]].data(),
                       axis_values_[slot[2]].data(), axis_values_[slot[3]].data()});
  };
  std::vector<TetVerts>& corners = sweep_corners_;
  corners.clear();
  for (const Coarse& c : near) {
    const TetVerts tv = cornersOf(c);
    if (axes.keeps(reach(tv), [&] { return anyOnWound(tv); })) corners.push_back(tv);
  }
  const Vec3 normal = sweepNormal(tris);
  // Each vertex once, in the order of the tets (a second look would decide the same); one
  // farther than both bands from both planes is near neither triangle (trySnap would do nothing).
  nextStamp(&vertex_seen_, &seen_stamp_, mesh_->vertexSlots());
  const double band = std::max(snap_distance_, wound_snap_distance_);
  for (const TetVerts& tv : corners)
    for (int v : tv) {
      if (vertex_seen_[v] == seen_stamp_) continue;
      vertex_seen_[v] = seen_stamp_;
      const auto& at = axis_values_[axis_slot_[v]];  // a corner: reach() took its values
      if (std::abs(at[8]) > band && std::abs(at[9]) > band) continue;
      trySnap(v, tris, prepared, normal);
    }
  crossEdges(from, to, tris, prepared, normal, lo, hi, nullptr, change);
}

bool Cutter::anyOnWound(const TetVerts& tv) const {
  return std::any_of(tv.begin(), tv.end(), [&](int v) { return onWound(v); });
}

int Cutter::sweepLooksAt(int v, const BladeSegment& from, const BladeSegment& to,
                         const std::array<Triangle, 2>& tris) const {
  // The sweep passes v to trySnap() when v lies within the bands of a swept triangle's plane and
  // is a corner of a coarse tet it keeps: one of sweepQuery()'s tets (in the near cache, in its
  // close list or a pending tet's piece beyond it, its gap within reach, its box meeting the
  // sweep's), or the pending tet of one, whose corners' reach is within the band. The same tests
  // on v's own tets, with the gaps and the cache as the sweep would find them; where it would
  // take either anew first, the answer is not known here.
  const SweptPlanes planes(tris);
  const double band = std::max(snap_distance_, wound_snap_distance_);
  const Vec3& x = mesh_->current(v);
  if (std::abs(planes.distance(0, x)) > band && std::abs(planes.distance(1, x)) > band) return 0;
  // (Named values, not structured bindings: the lambdas below capture them.)
  const std::pair<Vec3, Vec3> box = sweepBox(from, to, snap_distance_);
  const Vec3 &lo = box.first, &hi = box.second;
  if (!cacheHolds(lo, hi)) return -1;  // cacheNear() would take the cache anew
  const double step = std::max((to.base - from.base).norm(), (to.tip - from.tip).norm());
  if (gapsRetaken(from, step)) return -1;
  const std::pair<double, double> reaches =
      gapReach(from, to, step, gap_blade_ + step + gap_tissue_);
  const double reach = reaches.first, wound_reach = reaches.second;
  if (!(wound_reach < gap_far_)) return -1;  // every gap measured anew
  auto queried = [&](int t) {
    const std::size_t i = lowerBoundIndex(near_cache_, t);
    if (i == near_cache_.size() || near_cache_[i] != t) return false;
    const std::size_t c = lowerBoundIndex(near_close_, static_cast<int>(i));
    const bool close = c < near_close_.size() && near_close_[c] == static_cast<int>(i);
    if (!close && !(isPendingPiece(t) && !(near_gap_[i] <= gap_far_))) return false;
    const double gap = near_gap_[i] != kGapDue ? near_gap_[i] : dueGap(i);
    return gapTakes(t, gap, reach, wound_reach) && mesh_->tetAlive(t) &&
           tetBoxMeets(*mesh_, t, lo, hi);
  };
  const SweepAxes axes(tris, snap_distance_, wound_snap_distance_, mean_edge_);
  auto kept = [&](const TetVerts& tv) {
    std::array<std::array<double, 8>, 4> at;
    for (int k = 0; k < 4; ++k) axes.values(mesh_->current(tv[k]), at[k].data());
    return axes.keeps(axes.reach({at[0].data(), at[1].data(), at[2].data(), at[3].data()}),
                      [&] { return anyOnWound(tv); });
  };
  for (int t : mesh_->vertexTets(v)) {
    if (!isPendingPiece(t)) {
      if (queried(t) && kept(mesh_->tet(t))) return 1;
      continue;
    }
    const Pending& p = pending_.at(pending_of_[t]);
    if (localIndex(p.cut.corner, v) < 0) continue;  // v inside it: not one of its corners
    if (std::any_of(p.pieces.begin(), p.pieces.end(), queried) && kept(p.cut.corner)) return 1;
  }
  return 0;
}

Vec3 Cutter::sweepNormal(const std::array<Triangle, 2>& tris) const {
  const double tiny = 1e-12 * mean_edge_ * mean_edge_;
  Vec3 normal = (tris[0][1] - tris[0][0]).cross(tris[0][2] - tris[0][0]);
  if (normal.norm() <= tiny) normal = (tris[1][1] - tris[1][0]).cross(tris[1][2] - tris[1][0]);
  normal.normalize();
  return normal;
}

void Cutter::crossEdges(const BladeSegment& from, const BladeSegment& to,
                        const std::array<Triangle, 2>& tris,
                        const std::array<PreparedTriangle, 2>& prepared, const Vec3& normal,
                        const Vec3& lo, const Vec3& hi,
                        const std::vector<std::pair<int, int>>* only, ChangeRecord* change) {
  // The edges of the sweep's tets (sweep_corners_, their vertices' plane distances in
  // axis_values_), or those of `only` (the kept edges a targeted tick reached: the sweep would
  // act on no other edge), with their plane distances taken here as the sweep takes them (the
  // same operations: the same values). Either way in increasing order, so that the points are
  // made in the same order.
  const double tiny = 1e-12 * mean_edge_ * mean_edge_;
  const SweptPlanes planes(tris);
  // An edge can cross the swept quad only where its box meets the quad's box, and only when its
  // ends lie strictly on opposite sides of a usable triangle's plane (segmentCrossesTriangle).
  const Vec3 slack = Vec3::Constant(1e-6 * mean_edge_);
  const Vec3 quad_lo = lo.array() + snap_distance_ - slack.array();
  const Vec3 quad_hi = hi.array() - snap_distance_ + slack.array();
  std::array<bool, 2> has_area, crossable;
  for (int k = 0; k < 2; ++k) {
    has_area[k] = triangleArea(tris[k]) > tiny;
    crossable[k] = has_area[k] && planes.len[k] > 0;
  }
  // The tests in order of cost (all must hold; most edges of the corners lie on one side).
  auto mayCross = [&](int a, int b) {
    bool opposite = false;
    for (int k = 0; k < 2 && !opposite; ++k) {
      if (!crossable[k]) continue;
      const double dp =
          only ? planes.distance(k, mesh_->current(a)) : axis_values_[axis_slot_[a]][8 + k];
      const double dq =
          only ? planes.distance(k, mesh_->current(b)) : axis_values_[axis_slot_[b]][8 + k];
      opposite = (dp > 0 && dq < 0) || (dp < 0 && dq > 0);
    }
    if (!opposite) return false;
    if (onCut(a) || onCut(b)) return false;
    if (!mesh_->vertexAlive(a) || !mesh_->vertexAlive(b)) return false;
    const Vec3 &pa = mesh_->current(a), &pb = mesh_->current(b);
    return !((pa.cwiseMin(pb).array() > quad_hi.array()).any() ||
             (pa.cwiseMax(pb).array() < quad_lo.array()).any());
  };
  // The edges that may cross, in increasing order, each once (as a std::set would give them).
  std::vector<std::pair<int, int>>& edges = edge_scratch_;
  edges.clear();
  if (only) {
    for (const auto& [a, b] : *only)
      if (mayCross(a, b)) edges.emplace_back(a, b);
  } else {
    for (const TetVerts& tv : sweep_corners_)
      for (const auto& e : kTetEdge) {
        const int a = std::min(tv[e[0]], tv[e[1]]), b = std::max(tv[e[0]], tv[e[1]]);
        if (mayCross(a, b)) edges.emplace_back(a, b);
      }
  }
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  // The ribbon's own edges (the tip's and base's paths, and the blade where the stroke began)
  // are its front: an edge crossing right on the front is left whole and the front's face points
  // take its place, so a front running along mesh faces makes no points on their edges.
  // (On the stack: a sweep is made on every tick the blade moves near the tissue.)
  const std::array<std::array<Vec3, 2>, 3> front{
      {{from.tip, to.tip}, {from.base, to.base}, {from.base, from.tip}}};
  const int fronts = stroke_start_ ? 3 : 2;
  const double front_gap = frontShift();
  auto nearFront = [&](const Vec3& x) {
    for (int i = 0; i < fronts; ++i)
      if (distanceToSegment(x, front[i][0], front[i][1]) < front_gap) return true;
    return false;
  };
  for (const auto& [a, b] : edges) {  // mayCross() held; registering points changes none of it
    for (int k = 0; k < 2; ++k) {
      if (!has_area[k]) continue;
      double s;
      Vec3 bary;
      const Vec3 &pa = mesh_->current(a), &pb = mesh_->current(b);
      if (segmentCrossesTriangle(pa, pb, prepared[k], 1e-9, &s, &bary)) {
        const Vec3 x = pa + s * (pb - pa);
        int standing = -1;
        if (nearFront(x)) break;
        if (!woundAround(x, {a, b}, normal, &standing)) {
          registerEdgePoint(a, b, s, change);
        } else if (standing >= 0) {
          stood_for_.insert(pairKey(standing, standing == a ? b : a));
        }
        break;
      }
    }
  }
}

const std::vector<std::pair<int, int>>& Cutter::refusedEdges() {
  // An edge already cut in a pending tet: coarseAround() refuses a crossing of it, which then
  // changes nothing, unless an end on a wound makes the crossing stand for that end.
  std::vector<std::pair<int, int>>& out = quiet_scratch_;
  out.clear();
  for (const auto& [pid, p] : pending_)
    for (int e = 0; e < 6; ++e) {
      const int a = p.cut.corner[kTetEdge[e][0]], b = p.cut.corner[kTetEdge[e][1]];
      if (p.cut.edge_point[e] >= 0 && !onWound(a) && !onWound(b))
        out.emplace_back(std::min(a, b), std::max(a, b));
    }
  std::sort(out.begin(), out.end());
  return out;
}

bool Cutter::snapLooksOnly(int v) const {
  // trySnap() returns before changing anything: v is on the cut, kept off it where it is now,
  // or a cut point of the first pending tet around it (which holds until that tet is replaced).
  if (onCut(v)) return true;
  const auto kept = kept_off_.find(v);
  if (kept != kept_off_.end()) return kept->second == mesh_->rest(v);
  if (!onWound(v)) return false;
  for (int t : mesh_->vertexTets(v)) {
    const int pid = pending_of_[t];
    if (pid >= 0) return localIndex(pending_.at(pid).cut.corner, v) < 0;
  }
  return false;
}

void Cutter::quietTet(const TetVerts& tv, double lower,
                      const std::vector<std::pair<int, int>>& cut_edges) {
  const BladeSegment& at = quiet_ref_;
  const double wide = std::max(snap_distance_, wound_snap_distance_);
  const double near = quiet_reach_ + quiet_slack_;
  // Within the widest band of its vertices, `near` further: the wound's band only where one is
  // on a wound (looked up only where the two bands answer differently).
  auto withinBand = [&](double gap) {
    if (gap <= near + snap_distance_) return true;
    return gap <= near + wide && anyOnWound(tv);
  };
  if (!withinBand(lower)) return;
  const std::array<Vec3, 4> x{mesh_->current(tv[0]), mesh_->current(tv[1]), mesh_->current(tv[2]),
                              mesh_->current(tv[3])};
  // A ball around the tet: its distance from the blade is at least `ball`.
  const Vec3 centre = 0.25 * (x[0] + x[1] + x[2] + x[3]);
  double radius2 = 0.0;
  for (const Vec3& p : x) radius2 = std::max(radius2, (p - centre).squaredNorm());
  const double radius = std::sqrt(radius2);
  const double ball = quiet_segment_.distanceTo(centre) - radius;
  if (!withinBand(ball)) return;
  // Each vertex once a batch (it is in ~20 of these tets): what it gives does not depend on
  // the tet. Its distance from the blade is kept for the edges below.
  std::array<double, 4> dist;
  for (int k = 0; k < 4; ++k) {
    if (quiet_seen_[tv[k]] == quiet_batch_) {
      dist[k] = quiet_dist_[tv[k]];
      continue;
    }
    quiet_seen_[tv[k]] = quiet_batch_;
    const double own = onWound(tv[k]) ? wide : snap_distance_;
    const double d = quiet_segment_.distanceTo(x[k]);
    quiet_dist_[tv[k]] = dist[k] = d;
    if (d <= own + near && !snapLooksOnly(tv[k])) quiet_verts_.push_back({d - own, tv[k]});
  }
  if (ball <= near)
    for (const auto& e : kTetEdge) {
      const int a = std::min(tv[e[0]], tv[e[1]]), b = std::max(tv[e[0]], tv[e[1]]);
      if (onCut(a) || onCut(b)) continue;
      // A lower bound first: a point of the edge t from one end and L - t from the other lies at
      // least d_a - t and d_b - (L - t) from the blade, so at least (d_a + d_b - L) / 2 (the
      // slack covers rounding: the bound only filters, the distance below decides). Compared
      // squared: L >= d_a + d_b - 2 (near + slack).
      // From the lower id to the higher, whichever tet the edge is met in: one distance an edge.
      const bool forward = tv[e[0]] == a;
      const Vec3 &pa = x[forward ? e[0] : e[1]], &pb = x[forward ? e[1] : e[0]];
      const double shortest = dist[e[0]] + dist[e[1]] - 2.0 * (near + quiet_slack_);
      if (shortest > 0.0 && (pb - pa).squaredNorm() < shortest * shortest) continue;
      if (std::binary_search(cut_edges.begin(), cut_edges.end(), std::make_pair(a, b))) continue;
      // Met before in this batch: kept or left out already, as it would be here.
      const std::uint64_t edge =
          (std::uint64_t{static_cast<std::uint32_t>(a)} << 32) | static_cast<std::uint32_t>(b);
      if (!quiet_edges_met_.put(edge, 0)) continue;
      const double d = segmentSegmentDistance(pa, pb, at.base, at.tip);
      if (d <= near) quiet_edges_.push_back({d, a, b});
    }
  // The fronts' paths start at the tip and the base moved along the blade by frontShift() (along
  // the blade of their tick's end): within the moves since of these points, plus the shift times
  // the turn of the blade's direction (at most 4 moves over its length).
  const double length = quiet_segment_.len;
  const Vec3 line = quiet_segment_.d / length;
  const double front_scale = 1.0 + 4.0 * frontShift() / length;
  for (int end = 0; end < 2; ++end) {
    const Vec3 front =
        end == 0 ? Vec3(at.tip - frontShift() * line) : Vec3(at.base + frontShift() * line);
    if (!((centre - front).norm() - radius <= near * front_scale)) continue;
    for (const auto& f : kTetFace) {
      const double d = pointTriangleDistance(front, x[f[0]], x[f[1]], x[f[2]]) / front_scale;
      if (d <= near)
        (end == 0 ? quiet_faces_ : quiet_base_faces_)
            .push_back({d, sortedFace(tv[f[0]], tv[f[1]], tv[f[2]])});
    }
  }
}

void Cutter::newQuietBatch() {
  nextStamp(&quiet_seen_, &quiet_batch_, mesh_->vertexSlots());
  growSlots(&quiet_dist_, quiet_seen_.size(), 0.0);
  quiet_edges_met_.begin();
}

void Cutter::sortQuiet() {
  quiet_unsorted_ = false;
  // A feature met twice with the same key keeps one entry, tested again as soon as either would
  // be: one of them may have come back with a tet a change made (its `next` not known yet).
  // The entries from the front that are in order (what the last sort left, when features
  // joined since: refreshGrid()) are merged with the others sorted, not sorted again.
  auto tidy = [](auto* list, auto* scratch) {
    using Item = typename std::decay_t<decltype(*list)>::value_type;
    auto less = [](const Item& x, const Item& y) { return x.key() < y.key(); };
    std::size_t sorted = 1;
    while (sorted < list->size() && !less((*list)[sorted], (*list)[sorted - 1])) ++sorted;
    if (sorted < list->size()) {
      std::sort(list->begin() + sorted, list->end(), less);
      scratch->resize(list->size());  // its room kept: swapped with the list's
      std::merge(list->begin(), list->begin() + sorted, list->begin() + sorted, list->end(),
                 scratch->begin(), less);
      list->swap(*scratch);
    }
    std::size_t kept = 0;
    for (std::size_t i = 0; i < list->size(); ++i) {
      if (kept > 0 && (*list)[kept - 1].key() == (*list)[i].key()) {
        (*list)[kept - 1].next = std::min((*list)[kept - 1].next, (*list)[i].next);
        continue;
      }
      if (kept != i) (*list)[kept] = (*list)[i];
      ++kept;
    }
    list->resize(kept);
  };
  tidy(&quiet_verts_, &quiet_verts_merged_);
  tidy(&quiet_edges_, &quiet_edges_merged_);
  tidy(&quiet_faces_, &quiet_faces_merged_);
  tidy(&quiet_base_faces_, &quiet_faces_merged_);
}

double Cutter::quietReach(const BladeSegment& at) {
  // What a sweep acts on (sweep(), trySnap(), crossFront()): a vertex off the cut within the snap
  // distance of its quad or of the line it came from, or a wound vertex within the wound's band
  // under its quad, facing it; an edge of a coarse tet crossing the quad, neither end on the cut;
  // a face of one that the tip's or the base's path crosses, moved along the blade by
  // frontShift(). Each tick's quad lies within the larger of its blade's end moves of the blade
  // before it, so within the blade's moves since `at` of `at`, the fronts' paths likewise (the
  // blade turns a little); the tissue's moves add to that. So until the moves reach the quiet
  // reach, only the features that close to `at` can be acted on: they are kept, and each tick
  // tests them as the sweep would (watchedQuiet()), a few instead of all near the blade. Some
  // only look and change nothing, and are left out (snapLooksOnly(); an edge already cut in a
  // pending tet with no end on a wound, which coarseAround() refuses). The sweep looks only at
  // the tets whose boxes meet its quad's box grown by the snap distance: all in the near cache
  // while the blade's box stays that far inside the cache's; of those, the ones beyond gap_far_
  // lie further than any band.
  quiet_verts_.clear();
  quiet_edges_.clear();
  quiet_faces_.clear();
  quiet_base_faces_.clear();
  if (!closeKept()) return 0.0;
  const double length = (at.tip - at.base).norm();
  if (!(length > 2.0 * frontShift())) return 0.0;
  const double wide = std::max(snap_distance_, wound_snap_distance_);
  const double moves = gap_blade_ + gap_tissue_;
  const double slack = 1e-3 * mean_edge_ + 1e-6 * length;
  quiet_slack_ = slack;
  quiet_reach_ = std::min({options_.quiet_reach * mean_edge_, cacheMargin(at) - snap_distance_,
                           gap_far_ - moves - wide}) -
                 2.0 * slack;
  if (!(quiet_reach_ > 0.0)) return 0.0;
  quiet_ref_ = at;
  quiet_segment_ = PreparedSegment(at.base, at.tip);
  const std::vector<std::pair<int, int>>& cut_edges = refusedEdges();
  newQuietBatch();
  for (const auto& [pid, p] : pending_) quietTet(p.cut.corner, 0.0, cut_edges);
  for (int i : near_close_) {
    const int t = near_cache_[i];
    if (mesh_->tetAlive(t) && !isPendingPiece(t))
      quietTet(mesh_->tet(t), gapAt(i) - moves, cut_edges);
  }
  sortQuiet();
  return quiet_reach_;
}

bool Cutter::watchedQuiet(const BladeSegment& from, const BladeSegment& to, double moved,
                          Reached* out) const {
  // The tests sweep(), trySnap() and crossFront() make before they act, on the kept features the
  // moves have reached (each test a little wider: the sweep's own filters may leave a feature
  // out, never in). Each triangle's plane first, computed as those tests compute it: a feature
  // clear of it by their own measure is clear of the test.
  const double reached = moved + quiet_slack_;
  const auto tris = sweptTriangles(from, to);
  const double tiny = 1e-12 * mean_edge_ * mean_edge_;
  const std::array<PreparedTriangle, 2> prepared{PreparedTriangle(tris[0]),
                                                 PreparedTriangle(tris[1])};
  auto nearPlane = [&](int k, const Vec3& x, double band) {
    return !(std::abs(prepared[k].n.dot(x - tris[k][0])) > band * prepared[k].len * (1.0 + 1e-9));
  };
  Vec3 normal = prepared[0].n;
  if (normal.norm() <= tiny) normal = prepared[1].n;
  normal.normalize();
  const PreparedSegment to_blade(to.base, to.tip);  // for the distances below
  if (out) {
    out->vertex = -1;
    out->more = false;
    out->edges.clear();
    out->faces = false;
  }
  // A vertex passing: the first is noted; a second (another vertex) ends the test (the sweep
  // takes its vertices in the order of its tets).
  auto vertexPasses = [&](int v) {
    if (!out) return true;
    if (out->vertex < 0 || out->vertex == v) {
      out->vertex = v;
      return false;
    }
    out->more = true;
    return true;
  };
  // A vertex that passes lies within the wider band of a tick's quad (or of the line the blade
  // came from, within the snap distance: an edge of that quad).
  const double wide = std::max(snap_distance_, wound_snap_distance_);
  for (const QuietVertex& q : quiet_verts_) {
    if (q.at > reached) break;
    if (q.next > reached) continue;  // clear of every quad's band until the moves reach `next`
    const int v = q.v;
    if (onCut(v) || !mesh_->vertexAlive(v)) continue;  // snapped since: only looks
    const Vec3& x = mesh_->current(v);
    const bool crease = !onWound(v) && nearTrailingLine(x, tris);
    const PointOverTriangle over0(x, prepared[0]), over1(x, prepared[1]);
    const bool over =
        (!crease || out) && ((nearPlane(0, x, snap_distance_) && over0.near(snap_distance_)) ||
                             (nearPlane(1, x, snap_distance_) && over1.near(snap_distance_)));
    // Whether the sweep would pass v to trySnap(), as far as it is in doubt: 1 yes, 0 no (the
    // vertex is left alone), -1 not known here (the tick is swept).
    auto looked = [&] {
      const int answer = sweepLooksAt(v, from, to, tris);
      if (answer < 0) out->more = true;
      return answer;
    };
    if (crease || over) {
      // A vertex over a swept triangle within the snap distance lies in the sweep's box and over
      // the triangle, with every tet around it: the sweep looks at it. One taken at the crease
      // alone (see trySnap()) may lie over none of them: the sweep's filters decide.
      if (out && !over) {
        const int answer = looked();
        if (answer < 0) return false;
        if (answer == 0) continue;
      }
      if (vertexPasses(v)) return false;
      continue;
    }
    // Within the wound's wider band, the tets around it may lie outside the sweep's box (grown by
    // the snap distance only): the sweep's filters decide.
    if (!(onWound(v) &&
          ((nearPlane(0, x, wound_snap_distance_) && over0.near(wound_snap_distance_)) ||
           (nearPlane(1, x, wound_snap_distance_) && over1.near(wound_snap_distance_))) &&
          woundFacing(v, normal))) {
      // Clear of this tick's quad: every later tick's lies within the moves since of this
      // blade, and the vertex moves within the tissue's.
      q.next = moved + to_blade.distanceTo(x) - wide;
      continue;
    }
    if (!out) return false;
    const int answer = looked();
    if (answer < 0) return false;
    if (answer == 0) continue;
    if (vertexPasses(v)) return false;
  }
  double s;
  Vec3 bary;
  for (const QuietEdge& q : quiet_edges_) {
    if (q.at > reached) break;
    if (q.next > reached) continue;  // clear of every quad until the moves reach `next`
    if (onCut(q.a) || onCut(q.b) || !mesh_->vertexAlive(q.a) || !mesh_->vertexAlive(q.b)) continue;
    const Vec3 &pa = mesh_->current(q.a), &pb = mesh_->current(q.b);
    bool crosses = false;
    for (int k = 0; k < 2 && !crosses; ++k) {
      // Ends strictly on both sides of the plane, or no crossing.
      const double da = prepared[k].n.dot(pa - tris[k][0]);
      const double db = prepared[k].n.dot(pb - tris[k][0]);
      crosses = ((da > 0 && db < 0) || (da < 0 && db > 0)) &&
                segmentCrossesTriangle(pa, pb, prepared[k], 1e-9, &s, &bary);
    }
    if (crosses) {
      if (!out) return false;
      out->edges.emplace_back(q.a, q.b);
    } else {
      // Every later tick's quad lies within the moves since of this blade, and the edge moves
      // within the tissue's: it meets none before the moves grow by its distance from it.
      q.next = moved + segmentSegmentDistance(pa, pb, to.base, to.tip);
    }
  }
  if (out) {  // an edge may be kept twice, from two batches
    std::sort(out->edges.begin(), out->edges.end());
    out->edges.erase(std::unique(out->edges.begin(), out->edges.end()), out->edges.end());
  }
  // crossFront()'s two paths this tick, each moved along the blade toward the other end.
  // A later tick's front path lies within the moves since of this one's end, times front_scale
  // (the shift along the blade turns with it: by at most 4 moves over its length).
  const double front_scale = 1.0 + 4.0 * frontShift() / (to.tip - to.base).norm();
  auto crossed = [&](const std::vector<QuietFace>& faces, const Vec3& from_end, const Vec3& to_end,
                     const Vec3& inward) {
    const Vec3 shift = inward.norm() > 0 ? Vec3(frontShift() * inward.normalized()) : Vec3::Zero();
    const Vec3 p = from_end + shift, q = to_end + shift;
    for (const QuietFace& face : faces) {
      if (face.at > reached) break;
      if (face.next > reached) continue;  // clear of every path until the moves reach `next`
      const auto& f = face.f;
      if (!mesh_->vertexAlive(f[0]) || !mesh_->vertexAlive(f[1]) || !mesh_->vertexAlive(f[2]))
        continue;
      const Triangle tri{mesh_->current(f[0]), mesh_->current(f[1]), mesh_->current(f[2])};
      // crossFront() may take the face the other way round: rounding may differ there.
      if (segmentCrossesTriangle(p, q, tri, 2e-9, &s, &bary)) return true;
      if (front_scale < HUGE_VAL)  // (not for a blade of no length)
        face.next = moved + pointTriangleDistance(q, tri[0], tri[1], tri[2]) / front_scale;
    }
    return false;
  };
  const bool faces = crossed(quiet_faces_, from.tip, to.tip, to.base - to.tip) ||
                     crossed(quiet_base_faces_, from.base, to.base, to.tip - to.base);
  if (!out) return !faces;
  out->faces = faces;
  return out->none();
}

void Cutter::crossFront(const std::array<Vec3, 2>& front, const Vec3& inward,
                        ChangeRecord* change) {
  // A front running exactly along mesh faces or through edges (a tip at the depth of a grid
  // plane) is moved by frontShift() into the cut surface (the tip's path toward the base, the
  // base's toward the tip, a stroke's end ahead of it): then it crosses face interiors on one side
  // only. Edge crossings closer than that to the front are not made (see sweep()), so the points
  // of every tet still describe one surface ending at the moved front.
  const Vec3 shift = inward.norm() > 0 ? Vec3(frontShift() * inward.normalized()) : Vec3::Zero();
  std::array<Vec3, 2> seg = front;  // moved by the shift below
  // The cut surface's normal here (zero when the blade has not moved: no wound band then).
  Vec3 normal = (seg[1] - seg[0]).cross(inward);
  if (normal.norm() > 1e-12 * mean_edge_ * mean_edge_) normal.normalize();
  else normal = Vec3::Zero();
  seg[0] += shift;
  seg[1] += shift;
  Vec3 lo = seg[0].cwiseMin(seg[1]), hi = seg[0].cwiseMax(seg[1]);
  std::vector<Coarse>& near = front_near_;
  coarseNear(lo, hi, &near);
  // The faces in increasing order of their (oriented) triples, each once, as a std::set would
  // give them; the first orientation of a face met in that order is the one taken.
  // Only a face whose box meets the segment's (grown by far more than the crossing test's
  // rounding margin) can be crossed; both orientations of a face pass or fail alike.
  const Vec3 slack = Vec3::Constant(1e-6 * mean_edge_ + 1e-6 * (seg[1] - seg[0]).norm());
  const Vec3 seg_lo = lo - slack, seg_hi = hi + slack;
  std::vector<std::array<int, 3>>& faces = face_scratch_;
  faces.clear();
  for (const Coarse& c : near) {
    const TetVerts tv = cornersOf(c);
    for (const auto& f : kTetFace) {
      const Vec3 &a = mesh_->current(tv[f[0]]), &b = mesh_->current(tv[f[1]]),
                 &d = mesh_->current(tv[f[2]]);
      if ((a.cwiseMin(b).cwiseMin(d).array() > seg_hi.array()).any() ||
          (a.cwiseMax(b).cwiseMax(d).array() < seg_lo.array()).any())
        continue;
      faces.push_back({tv[f[0]], tv[f[1]], tv[f[2]]});
    }
  }
  std::sort(faces.begin(), faces.end());
  faces.erase(std::unique(faces.begin(), faces.end(), sameVertices<3>), faces.end());
  std::vector<std::array<int, 3>>& done = front_done_;  // few
  done.clear();
  for (const auto& face : faces) {
    const std::array<int, 3> key = sortedFace(face[0], face[1], face[2]);
    if (std::any_of(done.begin(), done.end(),
                    [&](const std::array<int, 3>& d) { return sameVertices(d, key); }))
      continue;
    done.push_back(key);
    const Triangle tri{mesh_->current(face[0]), mesh_->current(face[1]), mesh_->current(face[2])};
    double s;
    Vec3 bary;
    if (segmentCrossesTriangle(seg[0], seg[1], tri, 1e-9, &s, &bary) &&
        !woundAround(seg[0] + s * (seg[1] - seg[0]), {face[0], face[1], face[2]}, normal))
      registerFacePoint(face, bary, change);
  }
}

void Cutter::setWoundFlag(int v, unsigned char flag) {
  growSlots(&wound_flag_, static_cast<std::size_t>(v) + 1, {});
  wound_flag_[v] |= flag;
}

bool Cutter::mayJoin(int u, int v) const {
  const double length = (mesh_->current(u) - mesh_->current(v)).norm();
  const int ends = (onWound(u) ? 1 : 0) + (onWound(v) ? 1 : 0);
  return (ends == 2 && length <= 2.0 * wound_snap_distance_) ||
         (ends == 1 && length <= wound_snap_distance_);
}

bool Cutter::woundFacing(int v, const Vec3& normal) const {
  // True when a boundary face at v lies within 30 degrees of the plane with this normal.
  if (mesh_->boundaryFacesAt(v) == 0) return false;  // (no face to look at)
  for (int t : mesh_->vertexTets(v)) {
    const TetVerts& tv = mesh_->tet(t);
    for (int f = 0; f < 4; ++f) {
      if (tv[f] == v || mesh_->neighbor(t, f) >= 0) continue;
      const Vec3& a = mesh_->current(tv[kTetFace[f][0]]);
      const Vec3 n = (mesh_->current(tv[kTetFace[f][1]]) - a)
                         .cross(mesh_->current(tv[kTetFace[f][2]]) - a);
      const double len = n.norm();
      if (len > 0 && std::abs(n.dot(normal)) > 0.866 * len) return true;
    }
  }
  return false;
}

bool Cutter::woundAround(const Vec3& x, const Corners& verts, const Vec3& normal,
                         int* standing) const {
  if (standing) *standing = -1;
  // A crossing of an edge or face near one of its vertices, or (a face) near one of its edges,
  // that lies on an earlier cut stands for that vertex or edge: the blade follows that cut there
  // (coming back along its own wound, which the tissue may have moved since, or a tip at the
  // depth of snapped vertices), and a point beside it would only cut a sliver off along the wound.
  // Near: the snap distance, or the wound's band where its wall runs along this cut (woundFacing).
  // Only the edge's or face's own vertices count: a cut going on next to the wall it has just
  // opened behind the blade must not stop there.
  const int n = static_cast<int>(verts.size());
  for (int k = 0; k < n; ++k) {
    const int u = verts[k];
    if (!onWound(u)) continue;
    const Vec3& p = mesh_->current(u);
    if (nearWound(u, (x - p).norm(), normal)) {
      if (standing) *standing = u;
      return true;
    }
    if (n < 3) continue;
    const int w = verts[(k + 1) % n];
    if (onWound(w) && nearWound(u, distanceToSegment(x, p, mesh_->current(w)), normal))
      return true;
  }
  return false;
}

bool Cutter::nearWound(int v, double distance, const Vec3& normal) const {
  if (!onWound(v)) return false;
  if (distance < snap_distance_) return true;
  return distance < wound_snap_distance_ && normal.norm() > 0 && woundFacing(v, normal);
}

std::string Cutter::step(const std::optional<BladeSegment>& blade, ChangeRecord* change) {
  const auto start = std::chrono::steady_clock::now();
  std::string warning;
  refusal_.clear();
  swept_valid_ = false;
  // Before this tick's searches (the blade's, and the last one of a stroke), the grid follows
  // the tissue where it moved; the whole grid is rebuilt only when replaced tets' dead entries
  // pile up (rebuilds on drift took 4-6 ms a tick on the sagging 20k organ).
  if (blade || previous_) {
    refiled_.clear();
    const long long scans = grid_.scans();
    grid_.refresh(*mesh_, told_motion_ ? moved_ : HUGE_VAL, &refiled_);
    counts_.grid_scans += grid_.scans() - scans;
    moved_ = 0.0;
    if (grid_.cluttered()) {
      rebuildGrid();
    } else {
      joinNearCache(refiled_);
    }
  }
  // The blade moves on in its stroke; unswept; only the kept features it reached tested.
  bool swept = false, quiet = false, targeted = false;
  auto endStroke = [&] {
    crossFront({{previous_->base, previous_->tip}}, last_motion_, change);
    finalizeLeft(std::nullopt, change, true);
    stood_for_.clear();
  };
  if (!blade) {
    if (previous_) endStroke();
  } else if (!previous_) {
    last_motion_ = Vec3::Zero();
    crossFront({{blade->base, blade->tip}}, Vec3::Zero(), change);
    stroke_start_ = true;
  } else if ((blade->base - previous_->base).norm() > options_.max_jump ||
             (blade->tip - previous_->tip).norm() > options_.max_jump) {
    std::ostringstream msg;
    msg << "the blade jumped "
        << std::max((blade->base - previous_->base).norm(), (blade->tip - previous_->tip).norm())
        << " m in one tick (over cut/max_jump = " << options_.max_jump
        << " m): treated as lifted and put down again, no cut across the gap";
    warning = msg.str();
    ++counts_.lifts;
    endStroke();
    last_motion_ = Vec3::Zero();
    crossFront({{blade->base, blade->tip}}, Vec3::Zero(), change);
    stroke_start_ = true;
  } else {
    swept = true;
    // A quiet tick (see CutterOptions::skip_quiet) is not swept; the sweep's bounds still count
    // the blade's move (see sweepQuery()), and the next sweep starts where it left the blade.
    const double step =
        std::max((blade->base - previous_->base).norm(), (blade->tip - previous_->tip).norm());
    if (quiet_unsorted_) sortQuiet();
    // Where this tick's moves reach the quiet reach, the features near the blade where the last
    // tick left it are taken anew instead of sweeping this tick for that alone: that tick left
    // nothing a sweep would act on (it was swept, or it was quiet), so this one is quiet if it
    // reaches none of them. The gaps they are taken from are first taken anew where this
    // tick's sweep would have done so (see sweepQuery()), from the same blade: as it would.
    if (options_.skip_quiet && quiet_valid_ && told_motion_ && !stroke_start_ &&
        !(quiet_moved_ + step < quiet_reach_)) {
      roomAround(*previous_);
      if (gapsRetaken(*previous_, step)) retakeGaps(*previous_);
      ++counts_.quiet_refreshes;
      quiet_valid_ = quietReach(*previous_) > 0.0;
      quiet_moved_ = 0.0;
    }
    // A tick that reaches at most one kept vertex tests only the kept features it reached, as
    // the sweep and the fronts would and in their order: that vertex, then the edges (in the
    // sweep's order, see crossEdges()), then the fronts' faces (their own search then). The
    // sweep and the fronts would act on no other feature.
    const bool watchable = options_.skip_quiet && quiet_valid_ && told_motion_ &&
                           !stroke_start_ && quiet_moved_ + step < quiet_reach_;
    quiet = watchable && watchedQuiet(*previous_, *blade, quiet_moved_ + step, &reached_);
    targeted = watchable && !quiet && !reached_.more;
    quiet_moved_ += step;
    if (quiet) ++counts_.quiet_ticks;
    if (targeted) ++counts_.feature_ticks;
    if ((quiet || targeted) && !options_.check_quiet) {
      gap_blade_ += step;
      gap_last_ = *blade;
    }
    // The tip's and the base's paths this tick, each moved toward the other end.
    auto fronts = [&] {
      crossFront({{previous_->tip, blade->tip}}, blade->base - blade->tip, change);
      crossFront({{previous_->base, blade->base}}, blade->tip - blade->base, change);
    };
    if (targeted) {
      sweep(*previous_, *blade, change, &reached_);
      if (reached_.faces) fronts();
    }
    // What a sweep may change, to check that a quiet tick's, or a targeted one's after its
    // features, would have changed none of it.
    const bool check = (quiet || targeted) && options_.check_quiet;
    const int slots = mesh_->vertexSlots();
    const std::size_t pending = pending_.size(), kept = kept_off_.size(), stood = stood_for_.size();
    const std::vector<unsigned char> flags = check ? wound_flag_ : std::vector<unsigned char>{};
    // Sweep and fronts only add points and mark tets pending; no tet is replaced until
    // finalizeLeft(), so the fronts may reuse the sweep's search.
    const bool full = !(quiet || targeted) || check;
    if (full) sweep(*previous_, *blade, change);
    const Vec3 motion = 0.5 * ((blade->base - previous_->base) + (blade->tip - previous_->tip));
    if (motion.norm() > 1e-9 * mean_edge_) last_motion_ = motion;
    const auto tris = sweptTriangles(*previous_, *blade);
    if (triangleArea(tris[0]) + triangleArea(tris[1]) > 1e-12 * mean_edge_ * mean_edge_)
      stroke_start_ = false;
    if (full) fronts();
    swept_valid_ = false;
    if (check && (mesh_->vertexSlots() != slots || pending_.size() != pending ||
                  kept_off_.size() != kept || stood_for_.size() != stood || wound_flag_ != flags))
      throw std::logic_error(
          quiet ? "Cutter: the sweep of a tick left unswept as quiet changed the cut"
                : "Cutter: the sweep of a tick that tested its reached features alone changed "
                  "the cut");
  }
  previous_ = blade;
  finalizeLeft(blade, change);
  // After a tick swept because the quiet reach ran out (or was not known), the features near
  // the blade are taken anew; one swept for a kept feature keeps them while half the reach is
  // left, and one that acted on its kept features alone keeps them until the reach runs out (the
  // cut's state changed, which only makes features inert; tets a change adds joined them). A lift
  // or a new stroke looks afresh.
  if (swept && !quiet && !targeted && options_.skip_quiet &&
      !(quiet_valid_ && quiet_moved_ < 0.5 * quiet_reach_)) {
    roomAround(*blade);
    quiet_valid_ = quietReach(*blade) > 0.0;
    quiet_moved_ = 0.0;
  } else if (!swept) {
    quiet_valid_ = false;
  }
  if (!refusal_.empty())
    warning += std::string(warning.empty() ? "" : "; ") +
               "a replacement was refused and the cut left closed there (" + refusal_ + ")";
  counts_.time_ms +=
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
  return warning;
}

std::string Cutter::validate() const {
  for (const auto& [pid, p] : pending_) {
    double sum = 0.0;
    for (int t : p.pieces) {
      if (t >= mesh_->tetSlots() || !mesh_->tetAlive(t))
        return "pending tet " + std::to_string(pid) + " has a dead piece " + std::to_string(t);
      if (pending_of_[t] != pid)
        return "piece " + std::to_string(t) + " does not know its pending tet " +
               std::to_string(pid);
      sum += mesh_->restVolume(t);
    }
    const auto& c = p.cut.corner;
    const double whole =
        signedVolume(mesh_->rest(c[0]), mesh_->rest(c[1]), mesh_->rest(c[2]), mesh_->rest(c[3]));
    // Round-off of a point's position (a face point is a weighted sum of coordinates 3 cm from
    // the origin) grows with the edges, not with the volume: in a sliver (1.2e-18 m^3 with
    // 0.4 mm edges, made by cuts crossing near each other) the exact cone from its centroid
    // overshoots by 1.2e-9 of the whole, computed in exact arithmetic from those positions
    // (random incision 5 on the block, no physics). So the slack counts the edges too.
    double longest = 0.0;
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        longest = std::max(longest, (mesh_->rest(c[i]) - mesh_->rest(c[j])).norm());
    if (std::abs(sum - whole) > 1e-9 * std::abs(whole) + 1e-12 * longest * longest * longest)
      return "pieces of pending tet " + std::to_string(pid) + " do not fill it";
  }
  for (int t = 0; t < static_cast<int>(pending_of_.size()); ++t)
    if (pending_of_[t] >= 0 &&
        (t >= mesh_->tetSlots() || !mesh_->tetAlive(t) || !pending_.count(pending_of_[t])))
      return "tet " + std::to_string(t) + " is marked pending but is not";
  return "";
}

}  // namespace tissue_cut
