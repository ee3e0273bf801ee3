// CollapseQueue: the paper's on-the-fly edge collapse. Tets a cut creates with quality Q < tau
// are queued, lowest Q first; each tick the queue is worked off within a time budget, skipping
// tets next to tets still being cut. A tet's six edges are checked (each both ways where allowed)
// and the collapse leaving the best worst quality is taken. Our extensions: when none may go, the
// best flip among tets made by cuts (2-3, edge removal, 2-2: see flips.hpp), else a move of one
// of its vertices (see vertex_smoothing.hpp); both often let a collapse through later. An edge
// or vertex refused is not checked again until its neighbourhood changes.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <queue>
#include <vector>

#include "tissue_cut/mesh/stamped_table.hpp"
#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"
#include "tissue_cut/remesh/flips.hpp"

namespace tissue_cut {

struct CollapseCounts {
  int collapsed_edges = 0;
  int removed_tetrahedra = 0;  ///< #RmT: net tets removed by collapses and flips
  int rejected_link = 0, rejected_inversion = 0, rejected_quality = 0, rejected_boundary = 0;
  int smoothed_vertices = 0;  ///< accepted smoothing moves
  int flips = 0;              ///< accepted flips (2-3, edge removal, 2-2)
  int stopped = 0;            ///< tets whose work stopped at the budget (finished later)
  int deferred_ticks = 0;     ///< ticks with tets queued that the tick's deadline left no time
  double time_ms = 0.0;       ///< t.EC
};

class CollapseQueue {
 public:
  /// tau: quality threshold; budget_us: work per call of process() [us], 0 = unbounded.
  CollapseQueue(TetMesh* mesh, double tau, double budget_us);

  /// Queues every added tet of `change` whose rest Q is below tau, when `created_by_cut` says the
  /// tet was made by a cut.
  void queueFrom(const ChangeRecord& change, const std::function<bool(int)>& created_by_cut);

  /// Works the queue within the budget. `busy(v)` tells vertices that must not move (next to a
  /// tet still being cut): tets holding them wait. Tets `created_by_cut` around a collapsed or
  /// moved vertex are queued again. Appends the changes to `change`. `busy_changed` false says
  /// that busy() answers as on the last call: the tets that waited then are not looked at again.
  /// `limit_us` >= 0 caps this call's work below its budget, hard: no tet starts once it is
  /// spent, and the first tet stops between its steps too (0: no work at all this call).
  /// `budget_us` > 0 is this call's budget instead of the queue's own.
  void process(const std::function<bool(int)>& busy, const std::function<bool(int)>& created_by_cut,
               ChangeRecord* change, bool busy_changed = true, double limit_us = -1.0,
               double budget_us = 0.0);

  /// Sizes the queue's per-tet and per-vertex state for the mesh as it is now (as its first
  /// call would): optional, the answers are the same; the first tick does not pay for it.
  void prepare();

  /// Counts a tick that gave the queue no time (see Config::Collapse::deadline), if it held tets.
  void deferred() {
    if (pending() > 0) ++counts_.deferred_ticks;
  }

  /// Queued tets, those waiting for a busy neighbourhood included (some may have gone stale).
  int pending() const {
    return static_cast<int>(heap_.size() + waiting_.size() + (resume_ ? 1 : 0));
  }
  const CollapseCounts& counts() const { return counts_; }
  void setTau(double tau) { tau_ = tau; }
  void setBudget(double budget_us) { budget_us_ = budget_us; }
  /// What following the call's changes will cost its caller afterwards [us per tet removed or
  /// added] (the physics and the cutter update their state for them): under a limit, the work
  /// stops once its time plus that reaches the limit, so that the tick ends by its deadline.
  void setFollowCost(double us_per_tet) { follow_us_per_tet_ = us_per_tet; }
  /// Under a limit, each step after a call's first is taken only if the time it is likely to
  /// take fits before the limit too: the 99th percentile of the last kRecentSteps steps' times
  /// measured under a limit (their own and their changes' follow cost) [us]; 0 before any.
  double stepReserve() const;
  /// The clock the budget is measured on [us, any origin]; null (the default): the steady clock.
  /// A test gives one that advances a fixed step a reading, so that it knows where a budget ends.
  void setBudgetClock(std::function<double()> now_us) { budget_clock_ = std::move(now_us); }
  /// Boundary collapses may tilt the boundary faces that move by up to `shape_tolerance` (relative
  /// to the larger of each face's longest edge and `length_floor` [m], see checkCollapse), as long
  /// as the net rest volume they change stays within `volume_budget` [m^3]. With a length floor,
  /// no boundary vertex collapsed away may end up further than shape_tolerance * length_floor from
  /// the surface, however many operations reach its place. Default 0, 0, 0: the boundary keeps
  /// its shape exactly.
  void setShapeTolerance(double shape_tolerance, double volume_budget, double length_floor = 0.0) {
    shape_tolerance_ = shape_tolerance;
    volume_budget_ = volume_budget;
    length_floor_ = length_floor;
  }
  /// Net rest volume changed so far by boundary collapses [m^3].
  double volumeChanged() const { return volume_changed_; }
  /// Smoothing on or off (on by default); `pinned(v)` names vertices that must never move (e.g.
  /// fixed by the physics), on top of the busy ones.
  void setSmoothing(bool enabled, std::function<bool(int)> pinned = nullptr) {
    smoothing_ = enabled;
    pinned_ = std::move(pinned);
  }
  /// Flips on or off (on by default); `may_join(u, v)` (null: always) tells which new edges a
  /// flip may make.
  void setFlips(bool enabled, std::function<bool(int, int)> may_join = nullptr) {
    flips_ = enabled;
    may_join_ = std::move(may_join);
  }
  void clear();

 private:
  // A tet's work, in order: its collapses, its flips, then its vertices' smoothing.
  static constexpr int kCollapsePhase = 0, kFlipPhase = 1, kSmoothingPhase = 2;
  struct Entry {
    double quality;
    int tet;
    TetVerts verts;   // the tet when queued (its slot may be reused)
    long long stamp;  // the sum of its vertices' stamps when queued
    int phase = kCollapsePhase;  // where a tet stopped at the budget resumes
  };
  void queueTet(int t);
  long long stampOf(int a, int b) const;
  long long stampOf(const TetVerts& tv) const;
  void touched(int v, const std::function<bool(int)>& created_by_cut);
  // The best accepted collapse of an edge of tv, if any.
  bool collapseBest(const TetVerts& tv, const std::function<bool(int)>& created_by_cut,
                    ChangeRecord* change);
  // The flip of a face or edge of tet t raising the worst Q most, among tets made by cuts whose
  // vertices are not busy.
  bool flipBest(int t, const std::function<bool(int)>& busy,
                const std::function<bool(int)>& created_by_cut, ChangeRecord* change);
  // Smooths the first vertex of tv that can be; stops (setting *stopped) before trying another
  // vertex once `stop` (bool()) says so. (A template: as a std::function, process()'s lambda was
  // too big to be held in place.)
  template <typename Stop>
  bool smoothAny(const TetVerts& tv, const std::function<bool(int)>& created_by_cut,
                 ChangeRecord* change, const Stop& stop, bool* stopped);
  static long long keyOf(int a, int b);
  bool alreadyRefused(int a, int b) const;
  void refused(int a, int b);

  TetMesh* mesh_;
  double tau_, budget_us_;
  double follow_us_per_tet_ = 0.0;
  // The last steps' times under a limit [us] (a ring; see stepReserve()), and how many so far.
  static constexpr std::size_t kRecentSteps = 64;
  std::array<double, kRecentSteps> recent_steps_{};
  std::size_t steps_measured_ = 0;
  std::function<double()> budget_clock_;
  // The heap holds each entry's quality and its place in entries_ (16 bytes moved by each of the
  // heap's steps instead of the entry's 48): the same comparisons, so the same order, ties
  // included.
  struct HeapItem {
    double quality;
    int entry;
    bool operator<(const HeapItem& o) const { return quality > o.quality; }  // min-heap
  };
  std::priority_queue<HeapItem> heap_;
  std::vector<Entry> entries_;    // the heap's entries, by place
  std::vector<int> free_places_;  // places in entries_ of entries popped
  void push(const Entry& e);
  // The entry's tet is gone (its slot may hold another tet), or its neighbourhood changed since
  // it was queued.
  bool gone(const Entry& e) const {
    return !mesh_->tetAlive(e.tet) || !sameVertices(mesh_->tet(e.tet), e.verts);
  }
  bool stale(const Entry& e) const { return e.stamp != stampOf(e.verts); }
  const Entry& top() const { return entries_[heap_.top().entry]; }
  void pop() {
    free_places_.push_back(heap_.top().entry);
    heap_.pop();
  }
  // A tet whose work stopped at the budget: the next call works it first (taken off the heap
  // once, so the heap's order is as if it had not stopped).
  std::optional<Entry> resume_;
  std::vector<long long> vertex_stamp_;               // bumped when a vertex's star changes
  std::vector<Entry> waiting_;                        // busy this tick, back in the heap next tick
  // Edge or vertex (keyOf()) -> its stamp when refused, in one pass of the table until clear()
  // begins another (open addressing: a refusal takes nothing from the heap unless the table
  // grows).
  StampedTable<long long> refused_;
  std::vector<std::pair<TetVerts, long long>> queued_;  // per tet slot: the entry in the heap
  std::vector<int> moves_;  // smoothing moves per vertex (bounded: no cycling)
  std::vector<unsigned> around_seen_;  // touched()'s: per vertex slot, the call that marked it
  unsigned around_call_ = 0;
  // A collapse's, flip's or move's record, emptied before each use.
  ChangeRecord step_change_;
  // flipBest()'s: the candidate tried, the best so far, the flip's vertices (kept for their room).
  FlipCandidate flip_candidate_, flip_best_;
  std::vector<int> flip_verts_;
  // Where the cut left the surface: the rest positions of boundary vertices collapsed away, each
  // kept by the vertex that took its place. Collapses and 2-2 flips keep every such point within
  // shape_tolerance_ * length_floor_ of the surface around the vertex holding it, so the surface
  // never drifts further than that from the cut's, however many operations reach a place.
  // Per vertex slot (empty: none).
  std::vector<std::vector<Vec3>> ghosts_;
  const std::vector<Vec3>& ghostsOf(int v) const {
    static const std::vector<Vec3> none;
    return static_cast<std::size_t>(v) < ghosts_.size() ? ghosts_[v] : none;
  }
  using Triangle = std::array<Vec3, 3>;
  // ghostsKept()'s buffers, kept so that a check allocates nothing once they have grown.
  mutable std::vector<Triangle> faces_scratch_;
  mutable std::vector<Vec3> points_scratch_;
  mutable std::vector<int> flip_ghost_verts_;  // ghostsKept(flip)'s vertices
  mutable std::vector<int> ghost_neighbours_;  // ghostsKept(removed, survivor)'s, met so far
  void boundaryFacesAround(int v, int removed, int survivor, const FlipCandidate* flip,
                           std::vector<Triangle>* out) const;
  bool ghostsNear(const std::vector<Vec3>& points, const std::vector<Triangle>& faces) const;
  bool ghostsKept(int removed, int survivor) const;
  bool ghostsKept(const FlipCandidate& flip) const;
  void moveGhosts(int removed, int survivor);
  bool smoothing_ = true, flips_ = true;
  double shape_tolerance_ = 0.0, volume_budget_ = 0.0, volume_changed_ = 0.0, length_floor_ = 0.0;
  std::function<bool(int)> pinned_;
  std::function<bool(int, int)> may_join_;
  CollapseCounts counts_;
};

}  // namespace tissue_cut
