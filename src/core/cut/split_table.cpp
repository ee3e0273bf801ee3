#include "tissue_cut/cut/split_table.hpp"

#include <algorithm>
#include <cmath>

#include "tissue_cut/mesh/inline_vector.hpp"

namespace tissue_cut {

namespace {

// The lists a split builds are short and bounded by the tet: in place, not on the heap (on the
// 20k bench replay they had made ~120 allocations for each cut tet). A face has at most 6
// triangles (a face point fanning its three corners and three edge points), a tet's faces 24; a
// side of a complete cut is coned over at most 16 face triangles and 2 cut triangles.
using Tri = std::array<int, 3>;
using Tris = InlineVector<Tri, 24>;
using Tets = InlineVector<TetVerts, 48>;

bool holds(const Tri& t, int v) { return t[0] == v || t[1] == v || t[2] == v; }

// The two faces holding local edge e: those opposite the two corners not on it.
std::array<int, 2> edgeFaces(int e) {
  std::array<int, 2> out{};
  int n = 0;
  for (int c = 0; c < 4; ++c)
    if (c != kTetEdge[e][0] && c != kTetEdge[e][1]) out[n++] = c;
  return out;
}

// The face two distinct edges share, or -1 when they are opposite.
int commonFace(int e1, int e2) {
  for (int f1 : edgeFaces(e1))
    for (int f2 : edgeFaces(e2))
      if (f1 == f2) return f1;
  return -1;
}

struct Checker {
  const TetCut& cut;
  const PositionFn& rest;
  const PositionFn& current;
  double rest_volume, current_volume;

  Checker(const TetCut& c, const PositionFn& r, const PositionFn& cur)
      : cut(c), rest(r), current(cur) {
    const TetVerts& v = c.corner;
    rest_volume = signedVolume(r(v[0]), r(v[1]), r(v[2]), r(v[3]));
    current_volume = signedVolume(cur(v[0]), cur(v[1]), cur(v[2]), cur(v[3]));
  }

  // Every tet positive (rest, and current unless the tet is inverted there already): enough for
  // one side of a cut, which is only part of the tet. A cone whose apex lies on an edge of the
  // triangle it is joined to is flat, but round-off of the absolute coordinates leaves it about
  // 1e-12 of a small tet's volume (a 0.3 mm tet 5 cm from the origin); real pieces are far
  // larger (cut points stay 5% away from corners), hence the margin.
  static constexpr double kFlat = 1e-9;
  // The faces of the tet a point lies on, as bits (corner: the three faces holding it; edge
  // point: the two faces holding its edge; face point: its face; a centroid: none).
  int faceMask(int v) const {
    for (int c = 0; c < 4; ++c)
      if (cut.corner[c] == v) return 0xF & ~(1 << c);
    for (int e = 0; e < 6; ++e)
      if (cut.edge_point[e] == v) return 0xF & ~(1 << kTetEdge[e][0]) & ~(1 << kTetEdge[e][1]);
    for (int f = 0; f < 4; ++f)
      if (cut.face_point[f] == v) return 1 << f;
    return 0;
  }
  template <typename TetList>
  bool positive(const TetList& tets) const {
    for (const TetVerts& t : tets) {
      // Four points on one face of the tet are flat, whatever round-off makes of their volume
      // (a cone from a corner over a face point's fan on a face holding that corner: in a
      // micrometre tet the rounding passed the margin and the cone overlapped the neighbour).
      if (faceMask(t[0]) & faceMask(t[1]) & faceMask(t[2]) & faceMask(t[3])) return false;
      if (!(signedVolume(rest(t[0]), rest(t[1]), rest(t[2]), rest(t[3])) > kFlat * rest_volume))
        return false;
      if (current_volume > 0 && !(signedVolume(current(t[0]), current(t[1]), current(t[2]),
                                               current(t[3])) > kFlat * current_volume))
        return false;
    }
    return true;
  }

  // Positive and adding up to the whole: a wrong decomposition overlaps and overshoots.
  template <typename TetList>
  bool valid(const TetList& tets) const {
    if (!positive(tets)) return false;
    double sum = 0.0;
    for (const TetVerts& t : tets)
      sum += signedVolume(rest(t[0]), rest(t[1]), rest(t[2]), rest(t[3]));
    return std::abs(sum - rest_volume) <= 1e-9 * rest_volume;
  }
};

void appendFaceTriangles(const TetCut& cut, int f, Tris* out);

Tris allFaceTriangles(const TetCut& cut) {
  Tris out;
  for (int f = 0; f < 4; ++f) appendFaceTriangles(cut, f, &out);
  return out;
}

template <typename TriList>
Tets coneFrom(int apex, const TriList& triangles) {
  Tets tets;
  for (const Tri& t : triangles)
    if (!holds(t, apex)) tets.push_back({apex, t[0], t[1], t[2]});
  return tets;
}

// --- complete cuts: a plane-like cut separating the corners into two sides.
bool splitComplete(const TetCut& cut, const Checker& check, TetSplit* out) {
  for (int f = 0; f < 4; ++f)
    if (cut.face_point[f] >= 0) return false;
  // A corner on the cut has no cut edge.
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0 && (cut.on_cut[kTetEdge[e][0]] || cut.on_cut[kTetEdge[e][1]]))
      return false;
  InlineVector<int, 4> free_corners;
  for (int c = 0; c < 4; ++c)
    if (!cut.on_cut[c]) free_corners.push_back(c);
  std::array<int, 4> side{0, 0, 0, 0};
  bool found = false;
  const int n = static_cast<int>(free_corners.size());
  for (int mask = 0; mask < (1 << n) && !found; mask += 2) {  // first free corner stays on +
    for (int k = 0; k < n; ++k) side[free_corners[k]] = (mask >> k) & 1 ? -1 : 1;
    found = true;
    for (int e = 0; e < 6 && found; ++e) {
      const int i = kTetEdge[e][0], j = kTetEdge[e][1];
      if (cut.on_cut[i] || cut.on_cut[j]) continue;
      found = (cut.edge_point[e] >= 0) == (side[i] != side[j]);
    }
  }
  if (!found) return false;
  if (cut.numEdgePoints() == 0) {
    if (n == 1) {  // three corners on the cut: it runs along the face opposite the fourth
      const int f = free_corners[0];
      out->kind = SplitKind::kAlongFace;
      out->tets = {cut.corner};
      out->cut_faces = {
          {cut.corner[kTetFace[f][0]], cut.corner[kTetFace[f][1]], cut.corner[kTetFace[f][2]]}};
    } else {
      out->kind = SplitKind::kUntouched;
      out->tets = {cut.corner};
    }
    return true;
  }

  // Side of every vertex of the tet's points: corners by their side, cut points 0.
  auto side_of = [&](int v) {
    for (int c = 0; c < 4; ++c)
      if (cut.corner[c] == v) return side[c];
    return 0;
  };
  InlineVector<int, 10> polygon;  // the cut polygon's vertices
  InlineVector<int, 6> polygon_edges;
  for (int c = 0; c < 4; ++c)
    if (cut.on_cut[c]) polygon.push_back(cut.corner[c]);
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) {
      polygon.push_back(cut.edge_point[e]);
      polygon_edges.push_back(e);
    }
  // The cut polygon (a triangle, or a quad with either diagonal: the one that lets both sides be
  // coned is taken), then each side coned from the first of its vertices that gives only valid
  // tets (the smallest id, when the quad diagonals run through it as in Dompierre et al.).
  using CutTris = InlineVector<Tri, 2>;
  InlineVector<CutTris, 2> cut_options;
  if (polygon.size() == 3) {
    cut_options.push_back({Tri{polygon[0], polygon[1], polygon[2]}});
  } else if (polygon.size() == 4 && polygon_edges.size() == 4) {
    InlineVector<int, 4> order{0};
    std::array<bool, 4> used{true, false, false, false};
    while (order.size() < 4) {
      int next = -1;
      for (int k = 0; k < 4 && next < 0; ++k)
        if (!used[k] && commonFace(polygon_edges[order.back()], polygon_edges[k]) >= 0) next = k;
      if (next < 0) return false;
      used[next] = true;
      order.push_back(next);
    }
    int q[4];
    for (int k = 0; k < 4; ++k) q[k] = polygon[order[k]];
    const int m = static_cast<int>(std::min_element(q, q + 4) - q);
    for (int shift : {m, (m + 1) % 4})
      cut_options.push_back({Tri{q[shift], q[(shift + 1) % 4], q[(shift + 2) % 4]},
                             Tri{q[shift], q[(shift + 2) % 4], q[(shift + 3) % 4]}});
  } else {
    return false;
  }
  int plus_corner = -1;
  for (int c = 0; c < 4; ++c)
    if (side[c] > 0) plus_corner = cut.corner[c];
  const Tris faces = allFaceTriangles(cut);
  for (CutTris cut_tris : cut_options) {
    // Orient the cut triangles outward from the + side: a + corner must see them positively.
    for (Tri& t : cut_tris)
      if (signedVolume(check.rest(plus_corner), check.rest(t[0]), check.rest(t[1]),
                       check.rest(t[2])) < 0)
        std::swap(t[1], t[2]);
    Tets split_tets;
    bool ok = true;
    for (int s : {1, -1}) {
      InlineVector<Tri, 26> region;
      for (const Tri& t : faces) {
        int lo = 1, hi = -1;
        for (int v : t) {
          lo = std::min(lo, side_of(v));
          hi = std::max(hi, side_of(v));
        }
        if (lo < 0 && hi > 0) return false;  // a face triangle across the cut: not a plane cut
        if ((s > 0 && hi > 0) || (s < 0 && lo < 0)) region.push_back(t);
      }
      for (const Tri& t : cut_tris) region.push_back(s > 0 ? t : Tri{t[0], t[2], t[1]});
      // The region's vertices, ascending.
      InlineVector<int, 78> vertices;
      for (const Tri& t : region)
        for (int v : t) vertices.push_back(v);
      std::sort(vertices.begin(), vertices.end());
      const int* vertices_end = std::unique(vertices.begin(), vertices.end());
      Tets best;
      for (const int* apex = vertices.begin(); apex != vertices_end; ++apex) {
        const Tets tets = coneFrom(*apex, region);
        if (check.positive(tets)) {
          best = tets;
          break;
        }
      }
      if (best.empty()) {
        ok = false;
        break;
      }
      for (const TetVerts& t : best) split_tets.push_back(t);
    }
    if (!ok) continue;
    if (!check.valid(split_tets)) continue;
    out->kind = SplitKind::kComplete;
    out->tets.assign(split_tets.begin(), split_tets.end());
    out->cut_faces.assign(cut_tris.begin(), cut_tris.end());
    return true;
  }
  return false;
}

// --- partial cuts: the front crossed two faces; the cut crossed a path of edges between them.
bool splitPartial(const TetCut& cut, const Checker& check, TetSplit* out) {
  if (cut.numFacePoints() != 2) return false;
  int faces[2], n = 0;
  for (int f = 0; f < 4; ++f)
    if (cut.face_point[f] >= 0) faces[n++] = f;
  if (cut.face_point[faces[1]] < cut.face_point[faces[0]]) std::swap(faces[0], faces[1]);
  const int F1 = faces[0], F2 = faces[1];
  const int f1 = cut.face_point[F1], f2 = cut.face_point[F2];
  InlineVector<int, 6> edges;
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) edges.push_back(e);
  if (edges.size() > 3) return false;

  auto onFace = [](int e, int f) {
    auto fs = edgeFaces(e);
    return fs[0] == f || fs[1] == f;
  };
  InlineVector<int, 6> path;
  bool found = edges.empty();
  // (edges is ascending as made, so next_permutation goes through every order)
  if (!found) do {
      if (!onFace(edges[0], F1) || !onFace(edges.back(), F2)) continue;
      int used = (1 << F1) | (1 << F2);  // faces, as bits
      bool ok = true;
      for (std::size_t i = 0; i + 1 < edges.size() && ok; ++i) {
        const int g = commonFace(edges[i], edges[i + 1]);
        ok = g >= 0 && !(used & (1 << g));
        if (ok) used |= 1 << g;
      }
      if (ok) {
        path = edges;
        found = true;
        break;
      }
    } while (std::next_permutation(edges.begin(), edges.end()));
  if (!found) return false;

  const Tets tets = coneFrom(f1, allFaceTriangles(cut));
  if (!check.valid(tets)) return false;
  InlineVector<int, 7> chain;
  for (int e : path) chain.push_back(cut.edge_point[e]);
  chain.push_back(f2);
  // (path empty: a front with no cut surface here)
  out->kind = path.empty() ? SplitKind::kCone : SplitKind::kPartial;
  out->tets.assign(tets.begin(), tets.end());
  out->cut_faces.clear();
  out->cut_faces.reserve(chain.size() - 1);
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    out->cut_faces.push_back({f1, chain[i], chain[i + 1]});
  return true;
}

bool isCutPoint(const TetCut& cut, int v) {
  for (int c = 0; c < 4; ++c)
    if (cut.corner[c] == v) return cut.on_cut[c];
  return true;  // every non-corner vertex of the faces is an edge or face point
}

// Local corner index of a global id, or -1.
int cornerIndex(const TetCut& cut, int v) {
  for (int c = 0; c < 4; ++c)
    if (cut.corner[c] == v) return c;
  return -1;
}

// Two points on one edge of the tet (a corner and its edge's point, or two corners).
bool onSameTetEdge(const TetCut& cut, int x, int y) {
  const int cx = cornerIndex(cut, x), cy = cornerIndex(cut, y);
  if (cx >= 0 && cy >= 0) return true;
  if (cx < 0 && cy < 0) return false;
  const int corner = cx >= 0 ? cx : cy, point = cx >= 0 ? y : x;
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] == point) return kTetEdge[e][0] == corner || kTetEdge[e][1] == corner;
  return false;
}

// Traces the cut left on the faces: face-triangle edges joining two cut points across a face,
// each once, ascending.
using Traces = InlineVector<std::array<int, 2>, 72>;
Traces faceTraces(const TetCut& cut) {
  Traces traces;
  for (const Tri& t : allFaceTriangles(cut))
    for (int k = 0; k < 3; ++k) {
      const int x = t[k], y = t[(k + 1) % 3];
      if (isCutPoint(cut, x) && isCutPoint(cut, y) && !onSameTetEdge(cut, x, y))
        traces.push_back({std::min(x, y), std::max(x, y)});
    }
  std::sort(traces.begin(), traces.end());
  Traces once;
  for (const auto& t : traces)
    if (once.empty() || once.back() != t) once.push_back(t);
  return once;
}

bool coneFromAPoint(const TetCut& cut, const Checker& check, TetSplit* out) {
  InlineVector<int, 14> apexes;
  for (int f = 0; f < 4; ++f)
    if (cut.face_point[f] >= 0) apexes.push_back(cut.face_point[f]);
  for (int c = 0; c < 4; ++c) apexes.push_back(cut.corner[c]);
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) apexes.push_back(cut.edge_point[e]);
  const auto triangles = allFaceTriangles(cut);
  for (int apex : apexes) {
    const Tets tets = coneFrom(apex, triangles);
    if (check.valid(tets)) {
      out->kind = SplitKind::kCone;
      out->tets.assign(tets.begin(), tets.end());
      out->cut_faces.clear();
      return true;
    }
  }
  return false;
}

}  // namespace

int TetCut::numEdgePoints() const {
  return static_cast<int>(
      std::count_if(edge_point.begin(), edge_point.end(), [](int v) { return v >= 0; }));
}

int TetCut::numFacePoints() const {
  return static_cast<int>(
      std::count_if(face_point.begin(), face_point.end(), [](int v) { return v >= 0; }));
}

const char* splitKindName(SplitKind kind) {
  switch (kind) {
    case SplitKind::kUntouched:
      return "untouched";
    case SplitKind::kAlongFace:
      return "along-face";
    case SplitKind::kComplete:
      return "complete";
    case SplitKind::kPartial:
      return "partial";
    case SplitKind::kCone:
      return "cone";
    case SplitKind::kTent:
      return "tent";
    case SplitKind::kNeedsSteiner:
      return "needs-steiner";
  }
  return "?";
}

int tetEdgeIndex(int i, int j) {
  for (int e = 0; e < 6; ++e)
    if ((kTetEdge[e][0] == i && kTetEdge[e][1] == j) ||
        (kTetEdge[e][0] == j && kTetEdge[e][1] == i))
      return e;
  return -1;
}

namespace {

void appendFaceTriangles(const TetCut& cut, int f, Tris* out) {
  const int A = kTetFace[f][0], B = kTetFace[f][1], C = kTetFace[f][2];
  const int a = cut.corner[A], b = cut.corner[B], c = cut.corner[C];
  const int mA = cut.edge_point[tetEdgeIndex(B, C)];  // opposite a
  const int mB = cut.edge_point[tetEdgeIndex(C, A)];
  const int mC = cut.edge_point[tetEdgeIndex(A, B)];
  if (cut.face_point[f] >= 0) {
    const int fp = cut.face_point[f];
    InlineVector<int, 6> ring;
    for (int v : {a, mC, b, mA, c, mB})
      if (v >= 0) ring.push_back(v);
    for (std::size_t i = 0; i < ring.size(); ++i)
      out->push_back({ring[i], ring[(i + 1) % ring.size()], fp});
    return;
  }
  const int k = (mA >= 0) + (mB >= 0) + (mC >= 0);
  if (k == 0) {
    out->push_back({a, b, c});
    return;
  }
  if (k == 1) {
    if (mA >= 0) {
      out->push_back({a, b, mA});
      out->push_back({a, mA, c});
    } else if (mB >= 0) {
      out->push_back({b, c, mB});
      out->push_back({b, mB, a});
    } else {
      out->push_back({c, a, mC});
      out->push_back({c, mC, b});
    }
    return;
  }
  if (k == 3) {
    out->push_back({a, mC, mB});
    out->push_back({b, mA, mC});
    out->push_back({c, mB, mA});
    out->push_back({mC, mA, mB});
    return;
  }
  // Two points: split off the corner X they share, then the quad (p, Y, Z, q) by the diagonal
  // from the older point (smaller id) to the corner opposite its edge. That is how the face was
  // split when only the older point existed, so a neighbour that was replaced back then (its
  // face split by the older point alone, then the newer) still matches.
  int X, Y, Z, p, q;
  if (mA < 0) {
    X = a, Y = b, Z = c, p = mC, q = mB;
  } else if (mB < 0) {
    X = b, Y = c, Z = a, p = mA, q = mC;
  } else {
    X = c, Y = a, Z = b, p = mB, q = mA;
  }
  out->push_back({X, p, q});
  if (p < q) {  // p on XY sees Z
    out->push_back({p, Y, Z});
    out->push_back({p, Z, q});
  } else {  // q on ZX sees Y
    out->push_back({p, Y, q});
    out->push_back({Y, Z, q});
  }
}

}  // namespace

std::vector<std::array<int, 3>> faceTriangles(const TetCut& cut, int f) {
  Tris tris;
  appendFaceTriangles(cut, f, &tris);
  return {tris.begin(), tris.end()};
}

namespace {

// *out as a TetSplit{} is, its lists' room kept.
void emptySplit(TetSplit* out) {
  out->kind = SplitKind::kUntouched;
  out->tets.clear();
  out->cut_faces.clear();
}

}  // namespace

void splitTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current, int steiner,
              TetSplit* out) {
  const Checker check(cut, rest, current);
  emptySplit(out);
  if (!cut.hasPoints()) {
    // Only corners on the cut: along a face, or merely touched.
    if (splitComplete(cut, check, out)) return;
    out->kind = SplitKind::kUntouched;
    out->tets.assign(1, cut.corner);
    return;
  }
  if (splitComplete(cut, check, out)) return;
  if (splitPartial(cut, check, out)) return;
  const auto traces = faceTraces(cut);
  if (traces.empty() && coneFromAPoint(cut, check, out)) return;
  if (steiner < 0) {
    out->kind = SplitKind::kNeedsSteiner;
    return;
  }
  out->kind = SplitKind::kTent;
  const Tets tets = coneFrom(steiner, allFaceTriangles(cut));
  out->tets.assign(tets.begin(), tets.end());
  out->cut_faces.reserve(traces.size());
  for (const auto& t : traces) out->cut_faces.push_back({steiner, t[0], t[1]});
}

TetSplit splitTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                  int steiner) {
  TetSplit out;
  splitTet(cut, rest, current, steiner, &out);
  return out;
}

void subdivideTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                  int steiner, TetSplit* out) {
  emptySplit(out);
  if (!cut.hasPoints()) {
    out->kind = SplitKind::kUntouched;
    out->tets.assign(1, cut.corner);
    return;
  }
  const Checker check(cut, rest, current);
  if (coneFromAPoint(cut, check, out)) return;
  if (steiner < 0) {
    out->kind = SplitKind::kNeedsSteiner;
    return;
  }
  out->kind = SplitKind::kCone;
  const Tets tets = coneFrom(steiner, allFaceTriangles(cut));
  out->tets.assign(tets.begin(), tets.end());
}

TetSplit subdivideTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                      int steiner) {
  TetSplit out;
  subdivideTet(cut, rest, current, steiner, &out);
  return out;
}

}  // namespace tissue_cut
