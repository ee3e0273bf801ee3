#include "tissue_cut/remesh/collapse_queue.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <set>

#include "tissue_cut/mesh/quality.hpp"

namespace tissue_cut {

CollapseQueue::CollapseQueue(TetMesh* mesh, double tau, double budget_us)
    : mesh_(mesh), tau_(tau), budget_us_(budget_us) {}

void CollapseQueue::clear() {
  heap_ = {};
  waiting_.clear();
  queued_.clear();
  vertex_stamp_.clear();
  counts_ = CollapseCounts{};
}

long long CollapseQueue::stampOf(int a, int b) const {
  auto at = [&](int v) {
    return v < static_cast<int>(vertex_stamp_.size()) ? vertex_stamp_[v] : 0LL;
  };
  return at(a) + at(b);
}

void CollapseQueue::queueTet(int t) {
  if (!mesh_->tetAlive(t)) return;
  const double q = restQuality(*mesh_, t);
  if (!(q < tau_)) return;
  // The shortest edge first (the paper's choice); the others of the same tet follow it, so that a
  // sliver whose shortest edge may not go (it would flatten a neighbour) can still go another way.
  const TetVerts& tv = mesh_->tet(t);
  std::array<std::pair<double, int>, 6> edges;
  for (int e = 0; e < 6; ++e)
    edges[e] = {(mesh_->rest(tv[kTetEdge[e][0]]) - mesh_->rest(tv[kTetEdge[e][1]])).squaredNorm(),
                e};
  std::sort(edges.begin(), edges.end());
  for (int k = 0; k < 6; ++k) {
    const int e = edges[k].second;
    const Entry entry{q + 1e-9 * k, tv[kTetEdge[e][0]], tv[kTetEdge[e][1]],
                      stampOf(tv[kTetEdge[e][0]], tv[kTetEdge[e][1]])};
    // Tets around one edge queue it alike; once is enough (edges next to a cut that has not
    // opened may wait for many ticks, and copies would pile up).
    if (queued_.insert(keyOf(entry)).second) heap_.push(entry);
  }
}

void CollapseQueue::queueFrom(const ChangeRecord& change,
                              const std::function<bool(int)>& created_by_cut) {
  for (int t : change.added_tets)
    if (created_by_cut(t)) queueTet(t);
}

void CollapseQueue::process(const std::function<bool(int)>& busy,
                            const std::function<bool(int)>& created_by_cut, ChangeRecord* change) {
  const auto start = std::chrono::steady_clock::now();
  for (const Entry& e : waiting_) heap_.push(e);
  waiting_.clear();
  auto elapsed_us = [&] {
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
        .count();
  };
  // At least one collapse attempt a tick, so that a small budget still makes progress; stale and
  // busy entries cost next to nothing and do not count.
  bool attempted = false;
  while (!heap_.empty() && (!attempted || budget_us_ <= 0 || elapsed_us() < budget_us_)) {
    const Entry e = heap_.top();
    heap_.pop();
    const bool gone = !mesh_->vertexAlive(e.a) || !mesh_->vertexAlive(e.b) ||
                      e.stamp != stampOf(e.a, e.b)  // the neighbourhood changed since: stale
                      || mesh_->edgeTets(e.a, e.b).empty();
    if (!gone && (busy(e.a) || busy(e.b))) {
      waiting_.push_back(e);  // keeps its place in queued_
      continue;
    }
    queued_.erase(keyOf(e));
    if (gone) continue;
    attempted = true;
    ChangeRecord local;
    CollapseCheck check;
    if (!collapseEdge(mesh_, e.a, e.b, &local, &check)) {
      switch (check.refusal) {
        case CollapseRefusal::kLink:
          ++counts_.rejected_link;
          break;
        case CollapseRefusal::kBoundary:
          ++counts_.rejected_boundary;
          break;
        case CollapseRefusal::kInversion:
          ++counts_.rejected_inversion;
          break;
        case CollapseRefusal::kQuality:
          ++counts_.rejected_quality;
          break;
        case CollapseRefusal::kNone:
          break;
      }
      continue;
    }
    ++counts_.collapsed_edges;
    counts_.removed_tetrahedra +=
        static_cast<int>(local.removed_tets.size()) - static_cast<int>(local.added_tets.size());
    change->append(local);
    // Everything around the survivor changed: old entries there go stale, its bad tets requeue.
    const int s = check.survivor;
    if (static_cast<int>(vertex_stamp_.size()) < mesh_->vertexSlots())
      vertex_stamp_.resize(mesh_->vertexSlots(), 0);
    std::set<int> around;
    for (int t : mesh_->vertexTets(s))
      for (int v : mesh_->tet(t)) around.insert(v);
    for (int v : around) ++vertex_stamp_[v];
    for (int t : mesh_->vertexTets(s))
      if (created_by_cut(t)) queueTet(t);
  }
  counts_.time_ms += elapsed_us() / 1000.0;
}

}  // namespace tissue_cut
