// CollapseQueue: the paper's on-the-fly edge collapse. Tets a cut creates with quality Q < tau
// queue their shortest edge, lowest Q first; each tick the queue is worked off within a time
// budget, skipping edges next to tets still being cut.
#pragma once

#include <functional>
#include <queue>
#include <unordered_set>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"

namespace tissue_cut {

struct CollapseCounts {
  int collapsed_edges = 0;
  int removed_tetrahedra = 0;  ///< #RmT
  int rejected_link = 0, rejected_inversion = 0, rejected_quality = 0, rejected_boundary = 0;
  double time_ms = 0.0;  ///< t.EC
};

class CollapseQueue {
 public:
  /// tau: quality threshold; budget_us: work per call of process() [us], 0 = unbounded.
  CollapseQueue(TetMesh* mesh, double tau, double budget_us);

  /// Queues the shortest edge of every added tet of `change` whose rest Q is below tau, when
  /// `created_by_cut` says the tet was made by a cut.
  void queueFrom(const ChangeRecord& change, const std::function<bool(int)>& created_by_cut);

  /// Works the queue within the budget. `busy(v)` tells vertices that must not move (next to a
  /// tet still being cut): their edges wait. Edges of tets `created_by_cut` around a collapsed
  /// vertex are queued again. Appends the changes to `change`.
  void process(const std::function<bool(int)>& busy, const std::function<bool(int)>& created_by_cut,
               ChangeRecord* change);

  /// Queued edges, those waiting for a busy neighbourhood included (some may have gone stale).
  int pending() const { return static_cast<int>(heap_.size() + waiting_.size()); }
  const CollapseCounts& counts() const { return counts_; }
  void setTau(double tau) { tau_ = tau; }
  void setBudget(double budget_us) { budget_us_ = budget_us; }
  void clear();

 private:
  struct Entry {
    double quality;
    int a, b;
    long long stamp;  // the sum of the two vertices' stamps when queued
    bool operator<(const Entry& o) const { return quality > o.quality; }  // min-heap
  };
  struct Key {  // an entry's edge and stamp: the same one is never queued twice
    int a, b;
    long long stamp;
    bool operator==(const Key& o) const { return a == o.a && b == o.b && stamp == o.stamp; }
  };
  struct KeyHash {
    std::size_t operator()(const Key& k) const {
      return std::hash<long long>()((static_cast<long long>(k.a) * 1000003LL + k.b) * 1000003LL +
                                    k.stamp);
    }
  };
  static Key keyOf(const Entry& e) { return {std::min(e.a, e.b), std::max(e.a, e.b), e.stamp}; }
  void queueTet(int t);
  long long stampOf(int a, int b) const;

  TetMesh* mesh_;
  double tau_, budget_us_;
  std::priority_queue<Entry> heap_;
  std::vector<long long> vertex_stamp_;  // bumped when a vertex's star changes
  std::vector<Entry> waiting_;           // busy this tick, back in the heap next tick
  std::unordered_set<Key, KeyHash> queued_;  // keys in heap_ or waiting_
  CollapseCounts counts_;
};

}  // namespace tissue_cut
