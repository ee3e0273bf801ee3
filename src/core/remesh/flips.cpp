#include "tissue_cut/remesh/flips.hpp"

#include <algorithm>
#include <array>

#include "tissue_cut/mesh/inline_vector.hpp"
#include "tissue_cut/mesh/quality.hpp"
#include "tissue_cut/remesh/edge_collapse.hpp"
#include "tissue_cut/remesh/link_condition.hpp"

namespace tissue_cut {

namespace {

// Fills worst_after from `added` (all sound) and decides against min_gain.
bool finish(const TetMesh& mesh, double min_gain, FlipCandidate* c) {
  c->worst_after = 1.0;
  for (const TetVerts& tv : c->added) {
    const double q = soundQualityInMesh(mesh, tv);
    if (q < 0.0) return false;
    c->worst_after = std::min(c->worst_after, q);
  }
  return c->worst_after >= c->worst_before + min_gain;
}

// A candidate being made, one a thread: its lists keep their room from one try to the next (the
// queue tries up to 16 flips on each tet it works), and `out` takes a copy, into lists with
// room of their own, only when the flip is found. Not inlined: its callers then hold a plain
// pointer (each lookup of a thread_local in a shared library is a call).
[[gnu::noinline]] FlipCandidate& freshCandidate() {
  thread_local FlipCandidate cand;
  cand.removed.clear();
  cand.added.clear();
  cand.worst_before = cand.worst_after = cand.volume_change = 0.0;
  return cand;
}

}  // namespace

bool flip23(const TetMesh& mesh, int t, int f, double min_gain, FlipCandidate* out,
            const std::function<bool(int, int)>& may_join) {
  const int u = mesh.neighbor(t, f);
  if (u < 0) return false;  // a boundary face: nothing on the other side
  const TetVerts& tv = mesh.tet(t);
  const int a = tv[kTetFace[f][0]], b = tv[kTetFace[f][1]], c = tv[kTetFace[f][2]], d = tv[f];
  int e = -1;
  for (int v : mesh.tet(u))
    if (v != a && v != b && v != c) e = v;
  if (e < 0 || mesh.hasEdge(d, e)) return false;  // de exists: a flip would fold
  if (may_join && !may_join(d, e)) return false;
  FlipCandidate& cand = freshCandidate();
  cand.removed.assign({t, u});
  cand.worst_before = std::min(restQuality(mesh, t), restQuality(mesh, u));
  // kTetFace orders abc outward of t: d lies below it, e above. Each new tet is one edge of abc
  // with d and e, ordered like (a, b, d, e), which is positive when de crosses abc's inside.
  cand.added.assign({{a, b, d, e}, {b, c, d, e}, {c, a, d, e}});
  if (!finish(mesh, min_gain, &cand)) return false;
  *out = cand;
  return true;
}

EdgeTets edgeTetsOf(const TetMesh& mesh, int a, int b) {
  EdgeTets e;
  e.count = mesh.edgeTets(a, b, e.tets.data(), kMaxEdgeRing);
  return e;
}

bool removeEdge(const TetMesh& mesh, int a, int b, double min_gain, FlipCandidate* out,
                const std::function<bool(int, int)>& may_join) {
  return removeEdge(mesh, a, b, edgeTetsOf(mesh, a, b), min_gain, out, may_join);
}

bool removeEdge(const TetMesh& mesh, int a, int b, const EdgeTets& edge, double min_gain,
                FlipCandidate* out, const std::function<bool(int, int)>& may_join) {
  // The edge's tets, at most kMaxEdgeRing of them (a longer ring is never flipped). The queue asks
  // this of every edge of every tet it works: nothing here allocates until a flip is found.
  const std::array<int, kMaxEdgeRing>& ring_tets = edge.tets;
  const int n = edge.count;
  if (n < 3 || n > kMaxEdgeRing) return false;
  // An edge on the boundary (isBoundaryEdge(), asked of the tets found already).
  for (int i = 0; i < n; ++i)
    if (openAtEdge(mesh, ring_tets[i], a, b)) return false;
  // The ring: around an interior edge every tet shares its two faces through ab with the next
  // one, so the tets' other two vertices chain into one cycle r0 ... r(n-1).
  std::array<std::array<int, 2>, kMaxEdgeRing> pairs;
  for (int i = 0; i < n; ++i) {
    std::array<int, 2> p{-1, -1};
    int k = 0;
    for (int v : mesh.tet(ring_tets[i]))
      if (v != a && v != b && k < 2) p[k++] = v;
    if (k != 2) return false;
    pairs[i] = p;
  }
  std::array<int, kMaxEdgeRing> ring;
  int ring_size = 2;
  ring[0] = pairs[0][0];
  ring[1] = pairs[0][1];
  std::array<char, kMaxEdgeRing> used{};
  used[0] = 1;
  while (ring_size < n) {
    bool extended = false;
    for (int i = 0; i < n && !extended; ++i) {
      if (used[i]) continue;
      for (int k = 0; k < 2 && !extended; ++k)
        if (pairs[i][k] == ring[ring_size - 1]) {
          ring[ring_size++] = pairs[i][1 - k];
          used[i] = 1;
          extended = true;
        }
    }
    if (!extended) return false;
  }
  // The last unused pair must close the cycle; ring vertices must be distinct.
  for (int i = 0; i < n; ++i)
    if (!used[i] && !((pairs[i][0] == ring[n - 1] && pairs[i][1] == ring[0]) ||
                      (pairs[i][1] == ring[n - 1] && pairs[i][0] == ring[0])))
      return false;
  for (int i = 0; i < n; ++i)
    for (int j = i + 1; j < n; ++j)
      if (ring[i] == ring[j]) return false;
  // Counter-clockwise seen from b: every tet (a, b, r_i, r_i+1) is positive.
  if (signedVolume(mesh.rest(a), mesh.rest(b), mesh.rest(ring[0]), mesh.rest(ring[1])) < 0)
    std::reverse(ring.begin(), ring.begin() + n);

  // The flip is taken only where the triangulation's worst Q reaches `needed`. A candidate
  // below it can neither be taken nor decide which triangulation is (see the programme below),
  // so its exact value is not needed: any value below `needed` serves.
  double worst_before = 1.0;
  for (int i = 0; i < n; ++i)
    worst_before = std::min(worst_before, restQuality(mesh, ring_tets[i]));
  const double needed = worst_before + min_gain;
  // Triangle (i, k, j), i < k < j, gives the tets (r_i, r_k, r_j, b) and (r_i, r_j, r_k, a).
  // Its worst Q, or -1 when a tet is unsound, a chord is an edge already or the triangle a face
  // (or a value below `needed`, when the first tet is below it already).
  auto triangle = [&](int i, int k, int j) {
    auto chordFree = [&](int p, int q) {
      return q - p == 1 || (p == 0 && q == n - 1) ||
             ((!may_join || may_join(ring[p], ring[q])) && !mesh.hasEdge(ring[p], ring[q]));
    };
    if (!chordFree(i, k) || !chordFree(k, j) || !chordFree(i, j)) return -1.0;
    if (mesh.faceTet(ring[i], ring[k], ring[j]) >= 0) return -1.0;
    const TetVerts up{ring[i], ring[k], ring[j], b}, down{ring[i], ring[j], ring[k], a};
    const double q_up = soundQualityInMesh(mesh, up);
    if (q_up < 0.0) return -1.0;
    if (q_up < needed) return q_up;
    const double q_down = soundQualityInMesh(mesh, down);
    if (q_down < 0.0) return -1.0;
    return std::min(q_up, q_down);
  };
  // Klincsek's dynamic programme over sub-polygons: the triangulation maximising the worst Q.
  // Where a candidate's sub-polygons already fall below `needed`, its triangle is not measured:
  // the candidate is below `needed` whatever it is. By induction over the sub-polygons' sizes, a
  // sub-polygon's best is at least `needed` exactly when it would be with every triangle
  // measured, and then it has the same value and apex (the candidates below `needed` lose to
  // the best, and the first of equals wins as before); a triangulation is taken only where the
  // whole polygon's best reaches `needed`, so the flip found is the same.
  std::array<std::array<double, kMaxEdgeRing>, kMaxEdgeRing> best;
  std::array<std::array<int, kMaxEdgeRing>, kMaxEdgeRing> apex;
  for (auto& row : best) row.fill(1.0);
  for (auto& row : apex) row.fill(-1);
  for (int len = 2; len < n; ++len)
    for (int i = 0; i + len < n; ++i) {
      const int j = i + len;
      best[i][j] = -1.0;
      for (int k = i + 1; k < j; ++k) {
        const double sub = std::min(best[i][k], best[k][j]);
        const double q = sub < needed ? sub : std::min(sub, triangle(i, k, j));
        if (q > best[i][j]) {
          best[i][j] = q;
          apex[i][j] = k;
        }
      }
    }
  if (!(best[0][n - 1] >= needed)) return false;
  FlipCandidate& cand = freshCandidate();
  cand.removed.assign(ring_tets.begin(), ring_tets.begin() + n);
  cand.worst_before = worst_before;
  InlineVector<std::array<int, 2>, 2 * kMaxEdgeRing> todo;  // (n - 2 splits at most)
  todo.push_back({0, n - 1});
  while (!todo.empty()) {
    const auto [i, j] = todo.back();
    todo.pop_back();
    if (j - i < 2) continue;
    const int k = apex[i][j];
    cand.added.push_back({ring[i], ring[k], ring[j], b});
    cand.added.push_back({ring[i], ring[j], ring[k], a});
    todo.push_back({i, k});
    todo.push_back({k, j});
  }
  if (!finish(mesh, min_gain, &cand)) return false;
  *out = cand;
  return true;
}

bool flip22(const TetMesh& mesh, int a, int b, double shape_tolerance, double min_gain,
            FlipCandidate* out, double length_floor) {
  return flip22(mesh, a, b, edgeTetsOf(mesh, a, b), shape_tolerance, min_gain, out, length_floor);
}

bool flip22(const TetMesh& mesh, int a, int b, const EdgeTets& edge, double shape_tolerance,
            double min_gain, FlipCandidate* out, double length_floor) {
  if (edge.count != 2) return false;  // the edge's tets: exactly two
  const std::array<int, 2> pair_tets{edge.tets[0], edge.tets[1]};
  // The apex x both tets share across their common face abx, and each tet's own vertex c, d.
  const TetVerts &t0 = mesh.tet(pair_tets[0]), &t1 = mesh.tet(pair_tets[1]);
  int x = -1, c = -1, d = -1;
  for (int v : t0)
    if (v != a && v != b && std::find(t1.begin(), t1.end(), v) != t1.end()) x = v;
  if (x < 0) return false;
  for (int v : t0)
    if (v != a && v != b && v != x) c = v;
  for (int v : t1)
    if (v != a && v != b && v != x) d = v;
  if (c < 0 || d < 0 || c == d || mesh.hasEdge(c, d)) return false;
  // abc and abd must both be boundary faces: the face opposite x in each tet.
  for (int k = 0; k < 2; ++k) {
    const int t = pair_tets[k];
    const TetVerts& tv = mesh.tet(t);
    const int f = static_cast<int>(std::find(tv.begin(), tv.end(), x) - tv.begin());
    if (mesh.neighbor(t, f) >= 0) return false;
  }
  // Flat enough: each of c, d near the other triangle's plane.
  const Vec3 &pa = mesh.rest(a), &pb = mesh.rest(b), &pc = mesh.rest(c), &pd = mesh.rest(d);
  if (planeDeviation(pa, pb, pc, pd - pa, length_floor) > shape_tolerance ||
      planeDeviation(pa, pb, pd, pc - pa, length_floor) > shape_tolerance)
    return false;
  // Facing the same way: abc and abd folded onto each other (a crack front, both walls of a cut
  // lying on each other) are "in one plane" too, and cd would close the crack.
  const Vec3& px = mesh.rest(x);
  Vec3 nc = (pb - pa).cross(pc - pa), nd = (pb - pa).cross(pd - pa);
  if (nc.dot(px - pa) > 0) nc = -nc;
  if (nd.dot(px - pa) > 0) nd = -nd;
  if (!(nc.dot(nd) > 0)) return false;
  FlipCandidate& cand = freshCandidate();
  cand.removed.assign(pair_tets.begin(), pair_tets.end());
  cand.worst_before = std::min(restQuality(mesh, pair_tets[0]), restQuality(mesh, pair_tets[1]));
  // Orient cdx so that a lies on its positive side; b then lies on the other.
  TetVerts first{c, d, x, a}, second{c, x, d, b};
  if (signedVolume(mesh.rest(c), mesh.rest(d), mesh.rest(x), mesh.rest(a)) < 0) {
    first = {c, x, d, a};
    second = {c, d, x, b};
  }
  cand.added.assign({first, second});
  if (!finish(mesh, min_gain, &cand)) return false;
  double before = 0.0, after = 0.0;
  for (int t : pair_tets) before += mesh.restVolume(t);
  for (const TetVerts& tv : cand.added)
    after += signedVolume(mesh.rest(tv[0]), mesh.rest(tv[1]), mesh.rest(tv[2]), mesh.rest(tv[3]));
  cand.volume_change = after - before;
  *out = cand;
  return true;
}

std::vector<int> applyFlip(TetMesh* mesh, const FlipCandidate& flip, ChangeRecord* record) {
  return mesh->replaceTets(flip.removed, flip.added, record);
}

}  // namespace tissue_cut
