#include "tissue_cut/remesh/collapse_queue.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>

#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/statistics.hpp"
#include "tissue_cut/remesh/vertex_smoothing.hpp"

namespace tissue_cut {

namespace {
// A smoothing move must raise its star's worst Q by this much, and a vertex moves at most
// kMaxMoves times: the queue cannot cycle.
constexpr double kMinSmoothingGain = 1e-3;
constexpr int kMaxMoves = 16;
// Under a limit, the step reserve is this percentile of the recent steps' times (of the last
// 64: the longest). At the 90th, one step in ten ran past the reserve, and ticks the queue had
// filled to the deadline (0.9 ms) ended up to 0.14 ms after it: on the 20k organ on one core,
// 2-4 of the 11 ticks over the 99th percentile. At the 99th, 28 alternating replays: tick p99
// 0.910 -> 0.885 ms (median), lower in 21 of 28 pairs; 33-34 collapses either way.
constexpr int kReservePercent = 99;
// A flip must raise the worst Q of the tets it replaces by this much.
constexpr double kMinFlipGain = 1e-3;
// queued_'s entry for a tet slot not in the heap as it is now.
const std::pair<TetVerts, long long> kNotQueued{TetVerts{-1, -1, -1, -1}, -1};
}  // namespace

CollapseQueue::CollapseQueue(TetMesh* mesh, double tau, double budget_us)
    : mesh_(mesh), tau_(tau), budget_us_(budget_us) {}

void CollapseQueue::clear() {
  steps_measured_ = 0;
  heap_ = {};
  entries_.clear();
  free_places_.clear();
  resume_.reset();
  waiting_.clear();
  vertex_stamp_.clear();
  moves_.clear();
  refused_.begin();
  queued_.clear();
  volume_changed_ = 0.0;
  ghosts_.clear();
  counts_ = CollapseCounts{};
}

void CollapseQueue::prepare() {
  growSlots(&queued_, mesh_->tetSlots(), kNotQueued);
  growSlots(&vertex_stamp_, mesh_->vertexSlots(), {});
  growSlots(&moves_, mesh_->vertexSlots(), {});
}

long long CollapseQueue::stampOf(int a, int b) const {
  auto at = [&](int v) {
    return v < static_cast<int>(vertex_stamp_.size()) ? vertex_stamp_[v] : 0LL;
  };
  return at(a) + at(b);
}

long long CollapseQueue::stampOf(const TetVerts& tv) const {
  return stampOf(tv[0], tv[1]) + stampOf(tv[2], tv[3]);
}

void CollapseQueue::push(const Entry& e) {
  int place;
  if (free_places_.empty()) {
    place = static_cast<int>(entries_.size());
    entries_.push_back(e);
  } else {
    place = free_places_.back();
    free_places_.pop_back();
    entries_[place] = e;
  }
  heap_.push({e.quality, place});
}

void CollapseQueue::queueTet(int t) {
  if (!mesh_->tetAlive(t)) return;
  const TetVerts& tv = mesh_->tet(t);
  const long long stamp = stampOf(tv);
  growSlots(&queued_, mesh_->tetSlots(), kNotQueued);
  // Already queued as it is.
  if (sameVertices(queued_[t].first, tv) && queued_[t].second == stamp) return;
  const double q = restQuality(*mesh_, t);
  if (!(q < tau_)) return;
  push({q, t, tv, stamp});
  queued_[t] = {tv, stamp};
}

void CollapseQueue::touched(int s, const std::function<bool(int)>& created_by_cut) {
  // Everything around s changed: old entries there go stale, its bad tets requeue.
  growSlots(&vertex_stamp_, mesh_->vertexSlots(), {});
  // Each vertex of its star once, found by a mark (in any order: each stamp goes up by one; a
  // sort to make the list unique had cost more than the rest of the call).
  nextStamp(&around_seen_, &around_call_, mesh_->vertexSlots());
  for (int t : mesh_->vertexTets(s))
    for (int v : mesh_->tet(t))
      if (around_seen_[v] != around_call_) {
        around_seen_[v] = around_call_;
        ++vertex_stamp_[v];
      }
  for (int t : mesh_->vertexTets(s))
    if (created_by_cut(t)) queueTet(t);
}

long long CollapseQueue::keyOf(int a, int b) {
  // b < 0: vertex a's smoothing
  const long long lo = b < 0 ? a : std::min(a, b), hi = b < 0 ? -1 : std::max(a, b);
  return (lo << 32) ^ (hi & 0xffffffffLL);
}

bool CollapseQueue::alreadyRefused(int a, int b) const {
  const auto key = static_cast<std::uint64_t>(keyOf(a, b));
  return refused_.contains(key) && refused_.at(key) == stampOf(a, b < 0 ? a : b);
}

void CollapseQueue::refused(int a, int b) {
  refused_.put(static_cast<std::uint64_t>(keyOf(a, b)), stampOf(a, b < 0 ? a : b));
}

bool CollapseQueue::collapseBest(const TetVerts& tv, const std::function<bool(int)>& created_by_cut,
                                 ChangeRecord* change) {
  // Every edge of the tet, each both ways where allowed (see checkCollapse); the one leaving the
  // best worst quality goes, shorter first among equals.
  CollapseCheck best;
  double best_length = 0.0;
  // The tet is live (its entry is neither gone nor stale): its edges are edges. Which corners
  // lie on the boundary, found when first asked.
  std::array<signed char, 4> on_boundary{-1, -1, -1, -1};
  auto boundary = [&](int k) {
    if (on_boundary[k] < 0) on_boundary[k] = isBoundaryVertex(*mesh_, tv[k]) ? 1 : 0;
    return on_boundary[k] == 1;
  };
  for (const auto& edge : kTetEdge) {
    const int a = tv[edge[0]], b = tv[edge[1]];
    if (alreadyRefused(a, b)) continue;  // nothing changed around it since it was refused
    CollapseCheck check = checkCollapseKnown(*mesh_, a, b, boundary(edge[0]), boundary(edge[1]),
                                             shape_tolerance_, length_floor_, true);
    if (check.refusal == CollapseRefusal::kNone && shape_tolerance_ > 0.0 &&
        std::abs(volume_changed_ + check.volume_change) > volume_budget_)
      check.refusal = CollapseRefusal::kBoundary;  // the rest volume would drift too far
    if (check.refusal == CollapseRefusal::kNone && !ghostsKept(check.removed, check.survivor))
      check.refusal = CollapseRefusal::kBoundary;  // the surface would drift from the cut's
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
    if (check.refusal != CollapseRefusal::kNone) {
      refused(a, b);
      continue;
    }
    const double length = (mesh_->rest(a) - mesh_->rest(b)).norm();
    if (best.removed < 0 || check.worst_after > best.worst_after + 1e-12 ||
        (check.worst_after > best.worst_after - 1e-12 && length < best_length)) {
      best = check;
      best_length = length;
    }
  }
  if (best.removed < 0) return false;
  moveGhosts(best.removed, best.survivor);
  ChangeRecord& local = step_change_;
  local.clear();
  mesh_->mergeVertices(best.removed, best.survivor, &local);
  if (shape_tolerance_ > 0.0) volume_changed_ += best.volume_change;
  ++counts_.collapsed_edges;
  counts_.removed_tetrahedra +=
      static_cast<int>(local.removed_tets.size()) - static_cast<int>(local.added_tets.size());
  change->append(local);
  touched(best.survivor, created_by_cut);
  return true;
}

bool CollapseQueue::flipBest(int t, const std::function<bool(int)>& busy,
                             const std::function<bool(int)>& created_by_cut, ChangeRecord* change) {
  const TetVerts tv = mesh_->tet(t);
  auto allowedTets = [&](const int* tets, int n) {
    for (int i = 0; i < n; ++i) {
      // Only the cut region is re-made: a flip's tets count as made by the cut.
      if (!created_by_cut(tets[i])) return false;
      for (int v : mesh_->tet(tets[i]))
        if (busy(v)) return false;
    }
    return true;
  };
  auto allowed = [&](const FlipCandidate& c) {
    return allowedTets(c.removed.data(), static_cast<int>(c.removed.size()));
  };
  FlipCandidate &best = flip_best_, &candidate = flip_candidate_;
  bool found = false;
  auto consider = [&](bool legal) {
    if (!legal || !allowed(candidate)) return;
    if (candidate.volume_change != 0.0 &&
        std::abs(volume_changed_ + candidate.volume_change) > volume_budget_)
      return;  // a 2-2 flip of a slightly bent pair: within the collapses' volume budget
    if (candidate.volume_change != 0.0 && !ghostsKept(candidate)) return;
    if (!found || candidate.worst_after > best.worst_after) best = candidate;
    found = true;
  };
  for (int f = 0; f < 4; ++f) consider(flip23(*mesh_, t, f, kMinFlipGain, &candidate, may_join_));
  for (const auto& edge : kTetEdge) {
    const int a = tv[edge[0]], b = tv[edge[1]];
    const EdgeTets ring = edgeTetsOf(*mesh_, a, b);  // both flips' tets, found once
    // Both would remove exactly these tets: not looked at where those may not go.
    if (ring.count > kMaxEdgeRing || !allowedTets(ring.tets.data(), ring.count)) continue;
    consider(removeEdge(*mesh_, a, b, ring, kMinFlipGain, &candidate, may_join_));
    consider(flip22(*mesh_, a, b, ring, shape_tolerance_, kMinFlipGain, &candidate,
                    length_floor_));
  }
  if (!found) return false;
  ChangeRecord& local = step_change_;
  local.clear();
  const std::vector<int> added = applyFlip(mesh_, best, &local);
  ++counts_.flips;
  volume_changed_ += best.volume_change;
  counts_.removed_tetrahedra +=
      static_cast<int>(best.removed.size()) - static_cast<int>(best.added.size());
  change->append(local);
  // Their vertices once each, in increasing order (touched() marks vertices itself).
  std::vector<int>& verts = flip_verts_;
  verts.clear();
  for (int a : added)
    for (int v : mesh_->tet(a)) verts.push_back(v);
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  for (int v : verts) touched(v, created_by_cut);
  return true;
}

void CollapseQueue::boundaryFacesAround(int v, int removed, int survivor, const FlipCandidate* flip,
                                        std::vector<Triangle>* out) const {
  // v's boundary faces as they will be: `removed` on `survivor` (faces through both go), or the
  // flip's tets replaced by its new ones.
  auto add = [&](const TetVerts& tv, int f) {
    std::array<int, 3> c{tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]};
    bool had_removed = false, had_survivor = false;
    for (int& x : c) {
      if (x == removed) {
        x = survivor;
        had_removed = true;
      } else if (x == survivor) {
        had_survivor = true;
      }
    }
    if (had_removed && had_survivor) return;
    out->push_back({mesh_->rest(c[0]), mesh_->rest(c[1]), mesh_->rest(c[2])});
  };
  if (mesh_->boundaryFacesAt(v) > 0)  // (else its star has none)
    for (int t : mesh_->vertexTets(v)) {
      if (flip && std::find(flip->removed.begin(), flip->removed.end(), t) != flip->removed.end())
        continue;
      for (int f = 0; f < 4; ++f)
        if (mesh_->tet(t)[f] != v && mesh_->neighbor(t, f) < 0) add(mesh_->tet(t), f);
    }
  if (!flip) return;
  // The flip's new tets: their faces not shared between them are the ones the removed tets
  // had outside; those the removed tets had on the boundary are the boundary faces now.
  for (const TetVerts& tv : flip->added) {
    if (std::find(tv.begin(), tv.end(), v) == tv.end()) continue;
    for (int f = 0; f < 4; ++f) {
      if (tv[f] == v) continue;
      const std::array<int, 3> face{tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]};
      bool shared = false, outside = false;
      for (const TetVerts& other : flip->added)
        if (&other != &tv && std::all_of(face.begin(), face.end(), [&](int x) {
              return std::find(other.begin(), other.end(), x) != other.end();
            }))
          shared = true;
      if (shared) continue;
      // Inside the body when some tet outside the flip has this face.
      for (int t : mesh_->vertexTets(face[0]))
        if (std::find(flip->removed.begin(), flip->removed.end(), t) == flip->removed.end() &&
            std::all_of(face.begin(), face.end(), [&](int x) {
              const TetVerts& w = mesh_->tet(t);
              return std::find(w.begin(), w.end(), x) != w.end();
            }))
          outside = true;
      if (!outside) add(tv, f);
    }
  }
}

bool CollapseQueue::ghostsNear(const std::vector<Vec3>& points,
                               const std::vector<Triangle>& faces) const {
  const double limit = shape_tolerance_ * length_floor_;
  for (const Vec3& p : points) {
    // A face whose box, grown by the limit and far more than the distance's rounding, leaves p
    // out lies further than the limit: only the others are measured (the same answers).
    const double margin = limit * (1.0 + 1e-6) + 1e-9 * p.cwiseAbs().maxCoeff();
    const Vec3 lo = p.array() - margin, hi = p.array() + margin;
    bool near = false;
    for (const Triangle& f : faces) {
      if ((f[0].cwiseMax(f[1]).cwiseMax(f[2]).array() < lo.array()).any() ||
          (f[0].cwiseMin(f[1]).cwiseMin(f[2]).array() > hi.array()).any())
        continue;
      if (pointTriangleDistance(p, f[0], f[1], f[2]) <= limit) {
        near = true;
        break;
      }
    }
    if (!near) return false;
  }
  return true;
}

bool CollapseQueue::ghostsKept(int removed, int survivor) const {
  if (length_floor_ <= 0.0 || shape_tolerance_ <= 0.0 || !isBoundaryVertex(*mesh_, removed))
    return true;
  std::vector<Triangle>& faces = faces_scratch_;
  faces.clear();
  boundaryFacesAround(removed, removed, survivor, nullptr, &faces);
  boundaryFacesAround(survivor, removed, survivor, nullptr, &faces);
  std::vector<Vec3>& points = points_scratch_;
  points.assign(1, mesh_->rest(removed));
  for (int v : {removed, survivor}) {
    const std::vector<Vec3>& kept = ghostsOf(v);
    points.insert(points.end(), kept.begin(), kept.end());
  }
  if (!ghostsNear(points, faces)) return false;
  // Neighbours whose faces through `removed` move keep their own points near their new faces:
  // each once, in the order first met (a neighbour is in several of the star's tets).
  std::vector<int>& met = ghost_neighbours_;
  met.clear();
  for (int t : mesh_->vertexTets(removed)) {
    for (int u : mesh_->tet(t)) {
      if (u == removed || u == survivor) continue;
      const std::vector<Vec3>& kept = ghostsOf(u);
      if (kept.empty() || std::find(met.begin(), met.end(), u) != met.end()) continue;
      met.push_back(u);
      faces.clear();
      boundaryFacesAround(u, removed, survivor, nullptr, &faces);
      if (!ghostsNear(kept, faces)) return false;
    }
  }
  return true;
}

bool CollapseQueue::ghostsKept(const FlipCandidate& flip) const {
  if (length_floor_ <= 0.0 || shape_tolerance_ <= 0.0) return true;
  // The removed tets' vertices, each once, ascending (kept lists: no allocation once grown).
  std::vector<int>& verts = flip_ghost_verts_;
  verts.clear();
  for (int t : flip.removed)
    for (int v : mesh_->tet(t)) verts.push_back(v);
  std::sort(verts.begin(), verts.end());
  verts.erase(std::unique(verts.begin(), verts.end()), verts.end());
  std::vector<Triangle>& around = faces_scratch_;
  for (int v : verts) {
    const std::vector<Vec3>& kept = ghostsOf(v);
    if (kept.empty()) continue;
    around.clear();
    boundaryFacesAround(v, -1, -1, &flip, &around);
    if (!ghostsNear(kept, around)) return false;
  }
  return true;
}

void CollapseQueue::moveGhosts(int removed, int survivor) {
  if (length_floor_ <= 0.0 || shape_tolerance_ <= 0.0 || !isBoundaryVertex(*mesh_, removed))
    return;
  growSlots(&ghosts_, mesh_->vertexSlots());
  std::vector<Vec3>& kept = ghosts_[survivor];
  kept.push_back(mesh_->rest(removed));
  std::vector<Vec3>& gone = ghosts_[removed];
  kept.insert(kept.end(), gone.begin(), gone.end());
  gone.clear();  // its room stays for the slot's next vertex
}

template <typename Stop>
bool CollapseQueue::smoothAny(const TetVerts& tv, const std::function<bool(int)>& created_by_cut,
                              ChangeRecord* change, const Stop& stop, bool* stopped) {
  growSlots(&moves_, mesh_->vertexSlots(), {});
  for (int v : tv) {
    if ((pinned_ && pinned_(v)) || moves_[v] >= kMaxMoves || alreadyRefused(v, -1)) continue;
    if (stop()) {
      *stopped = true;
      return false;
    }
    ChangeRecord& local = step_change_;
    local.clear();
    if (!smoothVertex(mesh_, v, kMinSmoothingGain, &local)) {
      refused(v, -1);
      continue;
    }
    ++moves_[v];
    ++counts_.smoothed_vertices;
    change->append(local);
    touched(v, created_by_cut);
    return true;
  }
  return false;
}

void CollapseQueue::queueFrom(const ChangeRecord& change,
                              const std::function<bool(int)>& created_by_cut) {
  for (int t : change.added_tets)
    if (created_by_cut(t)) queueTet(t);
}

double CollapseQueue::stepReserve() const {
  if (steps_measured_ == 0) return 0.0;
  return ringPercentile(recent_steps_, static_cast<long long>(steps_measured_), kReservePercent);
}

void CollapseQueue::process(const std::function<bool(int)>& busy,
                            const std::function<bool(int)>& created_by_cut, ChangeRecord* change,
                            bool busy_changed, double limit_us, double budget_us) {
  const double budget = budget_us > 0.0 ? budget_us : budget_us_;
  const auto start = std::chrono::steady_clock::now();
  // Tets waiting for a busy neighbourhood stay aside while busy() answers as before: they would
  // only wait again (a tet a collapse changed since is queued anew by touched()). When it answers
  // anew, those still busy and current stay aside too: busy() does not change within a call, so
  // each would only go round the heap back to here. The gone are dropped and the stale go back to
  // the heap, as the heap's own tests below would have them.
  // (busy through a reference: std::any_of takes its predicate by value, and a std::function
  // copy per entry cost more than the test.)
  auto anyBusy = [&](const TetVerts& tv) {
    return std::any_of(tv.begin(), tv.end(), [&](int v) { return busy(v); });
  };
  if (busy_changed) {
    std::size_t kept = 0;
    for (const Entry& e : waiting_) {
      if (gone(e)) continue;
      if (!stale(e) && anyBusy(e.verts)) {
        waiting_[kept++] = e;
      } else {
        push(e);
      }
    }
    waiting_.resize(kept);
  }
  auto elapsed_us = [&] {
    return std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - start)
        .count();
  };
  const double budget_start = budget_clock_ ? budget_clock_() : 0.0;
  auto spent_us = [&] { return budget_clock_ ? budget_clock_() - budget_start : elapsed_us(); };
  // At least one tet worked a tick, so that a small budget still makes progress; stale and busy
  // entries cost next to nothing and do not count.
  bool attempted = false;
  const bool limited = limit_us >= 0.0;
  // Under a limit, the time the caller will take to follow this call's changes counts too.
  const std::size_t changed0 = change->added_tets.size() + change->removed_tets.size();
  auto used_us = [&] {
    const std::size_t changed = change->added_tets.size() + change->removed_tets.size();
    return spent_us() + follow_us_per_tet_ * static_cast<double>(changed - changed0);
  };
  // Under a limit, a step is taken only where the time one is likely to take (stepReserve(),
  // taken once a call) still fits before it; the call's first step always is (every call makes
  // progress). A step started just before the limit had run past it: on the 20k organ on one
  // core, 28 of a replay's 1,001 ticks ended 1-65 us past the 0.9 ms deadline, the queue's last
  // step and the follow of its changes after it. Each check measures the step since the last.
  const double reserve = limited ? stepReserve() : 0.0;
  bool stepped = false;  // a step of this call was taken
  double step_start = 0.0;
  bool in_step = false;
  // The time used now; the step in progress, if any, ends here and is measured.
  auto checkpoint = [&] {
    const double now = used_us();
    if (in_step) {
      recent_steps_[steps_measured_++ % kRecentSteps] = now - step_start;
      in_step = false;
    }
    return now;
  };
  auto fits = [&](double now) { return now + (stepped ? reserve : 0.0) < limit_us; };
  auto beginStep = [&](double now) {
    if (!limited) return;
    step_start = now;
    in_step = true;
    stepped = true;
  };
  double now = 0.0;
  while ((resume_ || !heap_.empty()) && (!attempted || budget <= 0 || spent_us() < budget) &&
         (!limited || fits(now = checkpoint()))) {
    const Entry e = resume_ ? *resume_ : top();
    if (resume_) {
      resume_.reset();
    } else {
      pop();
    }
    // Gone: dropped. Stale: queued again as it is now (touched() queues only the tets around the
    // changed vertex itself).
    if (gone(e)) continue;
    if (stale(e)) {
      queueTet(e.tet);
      continue;
    }
    if (anyBusy(e.verts)) {
      waiting_.push_back(e);
      continue;
    }
    queued_[e.tet].second = -1;  // worked: it may be queued again
    const bool first = !attempted;
    attempted = true;
    // A tet's work (six edges both ways, flips, smoothing up to four vertices at ~0.1 ms each)
    // can take longer than the budget. Past it, a tet other than the tick's first stops between
    // steps and is the next call's first, resumed at the step where it stopped (the steps before
    // had failed and would fail again: the refusals they met are remembered, and nothing around
    // the tet changed, or it would have been queued anew). Past the call's limit the first tet
    // stops too; a resumed tet always takes its next step, so every call makes progress.
    auto over = [&] {
      if (!first && budget > 0 && spent_us() >= budget) return true;
      if (!limited) return false;
      const double at = checkpoint();
      if (!fits(at)) return true;
      beginStep(at);
      return false;
    };
    // A resumed tet's step is free: its call's first.
    auto freeStep = [&] {
      if (limited) beginStep(checkpoint());
      return false;
    };
    if (e.phase == kCollapsePhase) {
      beginStep(now);
      if (collapseBest(e.verts, created_by_cut, change)) continue;
    }
    int phase = kFlipPhase;
    bool stopped = false;
    if (flips_ && e.phase <= kFlipPhase) {
      if (e.phase < kFlipPhase) {
        stopped = over();
      } else {
        beginStep(now);  // resumed here: the call's first step
      }
      if (!stopped && flipBest(e.tet, busy, created_by_cut, change)) continue;
    }
    if (!stopped && smoothing_) {
      phase = kSmoothingPhase;
      bool free_step = e.phase == kSmoothingPhase;
      auto stop = [&] { return free_step ? (free_step = false, freeStep()) : over(); };
      smoothAny(e.verts, created_by_cut, change, stop, &stopped);
    }
    if (stopped) {
      ++counts_.stopped;
      resume_ = e;
      resume_->phase = phase;
      queued_[e.tet].second = e.stamp;
      break;
    }
  }
  counts_.time_ms += elapsed_us() / 1000.0;
}

}  // namespace tissue_cut
