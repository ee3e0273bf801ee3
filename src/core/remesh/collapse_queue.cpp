#include "tissue_cut/remesh/collapse_queue.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <set>

#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/remesh/vertex_smoothing.hpp"

namespace tissue_cut {

namespace {
// A smoothing move must raise its star's worst Q by this much, and a vertex moves at most
// kMaxMoves times: the queue cannot cycle.
constexpr double kMinSmoothingGain = 1e-3;
constexpr int kMaxMoves = 8;
}  // namespace

CollapseQueue::CollapseQueue(TetMesh* mesh, double tau, double budget_us)
    : mesh_(mesh), tau_(tau), budget_us_(budget_us) {}

void CollapseQueue::clear() {
  heap_ = {};
  waiting_.clear();
  vertex_stamp_.clear();
  moves_.clear();
  refused_.clear();
  volume_changed_ = 0.0;
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
    heap_.push({q + 1e-9 * k, tv[kTetEdge[e][0]], tv[kTetEdge[e][1]],
                stampOf(tv[kTetEdge[e][0]], tv[kTetEdge[e][1]])});
  }
  // Then its vertices, in case no edge may go: a move may let one go later.
  if (smoothing_)
    for (int k = 0; k < 4; ++k) heap_.push({q + 1e-8 + 1e-9 * k, tv[k], -1, stampOf(tv[k], tv[k])});
}

void CollapseQueue::touched(int s, const std::function<bool(int)>& created_by_cut) {
  // Everything around s changed: old entries there go stale, its bad tets requeue.
  if (static_cast<int>(vertex_stamp_.size()) < mesh_->vertexSlots())
    vertex_stamp_.resize(mesh_->vertexSlots(), 0);
  std::set<int> around;
  for (int t : mesh_->vertexTets(s))
    for (int v : mesh_->tet(t)) around.insert(v);
  for (int v : around) ++vertex_stamp_[v];
  for (int t : mesh_->vertexTets(s))
    if (created_by_cut(t)) queueTet(t);
}

long long CollapseQueue::keyOf(const Entry& e) {
  const long long lo = e.b < 0 ? e.a : std::min(e.a, e.b), hi = e.b < 0 ? -1 : std::max(e.a, e.b);
  return (lo << 32) ^ (hi & 0xffffffffLL);
}

bool CollapseQueue::alreadyRefused(const Entry& e) const {
  const auto it = refused_.find(keyOf(e));
  return it != refused_.end() && it->second == e.stamp;
}

void CollapseQueue::refused(const Entry& e) { refused_[keyOf(e)] = e.stamp; }

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
    if (e.b < 0) {
      if (!mesh_->vertexAlive(e.a) || e.stamp != stampOf(e.a, e.a)) continue;
      if (busy(e.a)) {
        waiting_.push_back(e);
        continue;
      }
      if (pinned_ && pinned_(e.a)) continue;
      if (static_cast<int>(moves_.size()) < mesh_->vertexSlots())
        moves_.resize(mesh_->vertexSlots(), 0);
      if (moves_[e.a] >= kMaxMoves || alreadyRefused(e)) continue;
      attempted = true;
      ChangeRecord local;
      if (!smoothVertex(mesh_, e.a, kMinSmoothingGain, &local)) {
        refused(e);
      } else {
        ++moves_[e.a];
        ++counts_.smoothed_vertices;
        change->append(local);
        touched(e.a, created_by_cut);
      }
      continue;
    }
    if (!mesh_->vertexAlive(e.a) || !mesh_->vertexAlive(e.b)) continue;
    if (e.stamp != stampOf(e.a, e.b)) continue;  // the neighbourhood changed since: stale
    if (mesh_->edgeTets(e.a, e.b).empty()) continue;
    if (busy(e.a) || busy(e.b)) {
      waiting_.push_back(e);
      continue;
    }
    if (alreadyRefused(e)) continue;  // queued by several tets; nothing changed since
    attempted = true;
    CollapseCheck check = checkCollapse(*mesh_, e.a, e.b, shape_tolerance_);
    if (check.refusal == CollapseRefusal::kNone && shape_tolerance_ > 0.0 &&
        std::abs(volume_changed_ + check.volume_change) > volume_budget_)
      check.refusal = CollapseRefusal::kBoundary;  // the rest volume would drift too far
    if (check.refusal != CollapseRefusal::kNone) {
      refused(e);
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
    ChangeRecord local;
    mesh_->mergeVertices(check.removed, check.survivor, &local);
    if (shape_tolerance_ > 0.0) volume_changed_ += check.volume_change;
    ++counts_.collapsed_edges;
    counts_.removed_tetrahedra +=
        static_cast<int>(local.removed_tets.size()) - static_cast<int>(local.added_tets.size());
    change->append(local);
    touched(check.survivor, created_by_cut);
  }
  counts_.time_ms += elapsed_us() / 1000.0;
}

}  // namespace tissue_cut
