#include "tissue_cut/cut/split_table.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

namespace tissue_cut {

namespace {

using Tri = std::array<int, 3>;

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
  bool positive(const std::vector<TetVerts>& tets) const {
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
  bool valid(const std::vector<TetVerts>& tets) const {
    if (!positive(tets)) return false;
    double sum = 0.0;
    for (const TetVerts& t : tets)
      sum += signedVolume(rest(t[0]), rest(t[1]), rest(t[2]), rest(t[3]));
    return std::abs(sum - rest_volume) <= 1e-9 * rest_volume;
  }
};

std::vector<Tri> allFaceTriangles(const TetCut& cut) {
  std::vector<Tri> out;
  for (int f = 0; f < 4; ++f) {
    auto tris = faceTriangles(cut, f);
    out.insert(out.end(), tris.begin(), tris.end());
  }
  return out;
}

std::vector<TetVerts> coneFrom(int apex, const std::vector<Tri>& triangles) {
  std::vector<TetVerts> tets;
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
  std::vector<int> free_corners;
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
  std::map<int, int> side_of;
  for (int c = 0; c < 4; ++c) side_of[cut.corner[c]] = side[c];
  std::vector<int> polygon;  // the cut polygon's vertices
  std::vector<int> polygon_edges;
  for (int c = 0; c < 4; ++c)
    if (cut.on_cut[c]) polygon.push_back(cut.corner[c]);
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) {
      side_of[cut.edge_point[e]] = 0;
      polygon.push_back(cut.edge_point[e]);
      polygon_edges.push_back(e);
    }
  // The cut polygon (a triangle, or a quad with either diagonal: the one that lets both sides be
  // coned is taken), then each side coned from the first of its vertices that gives only valid
  // tets (the smallest id, when the quad diagonals run through it as in Dompierre et al.).
  std::vector<std::vector<Tri>> cut_options;
  if (polygon.size() == 3) {
    cut_options.push_back({{polygon[0], polygon[1], polygon[2]}});
  } else if (polygon.size() == 4 && polygon_edges.size() == 4) {
    std::vector<int> order{0};
    std::vector<bool> used(4, false);
    used[0] = true;
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
      cut_options.push_back({{q[shift], q[(shift + 1) % 4], q[(shift + 2) % 4]},
                             {q[shift], q[(shift + 2) % 4], q[(shift + 3) % 4]}});
  } else {
    return false;
  }
  int plus_corner = -1;
  for (int c = 0; c < 4; ++c)
    if (side[c] > 0) plus_corner = cut.corner[c];
  const std::vector<Tri> faces = allFaceTriangles(cut);
  for (std::vector<Tri> cut_tris : cut_options) {
    // Orient the cut triangles outward from the + side: a + corner must see them positively.
    for (Tri& t : cut_tris)
      if (signedVolume(check.rest(plus_corner), check.rest(t[0]), check.rest(t[1]),
                       check.rest(t[2])) < 0)
        std::swap(t[1], t[2]);
    TetSplit split;
    split.kind = SplitKind::kComplete;
    bool ok = true;
    for (int s : {1, -1}) {
      std::vector<Tri> region;
      for (const Tri& t : faces) {
        int lo = 1, hi = -1;
        for (int v : t) {
          lo = std::min(lo, side_of[v]);
          hi = std::max(hi, side_of[v]);
        }
        if (lo < 0 && hi > 0) return false;  // a face triangle across the cut: not a plane cut
        if ((s > 0 && hi > 0) || (s < 0 && lo < 0)) region.push_back(t);
      }
      for (const Tri& t : cut_tris) region.push_back(s > 0 ? t : Tri{t[0], t[2], t[1]});
      std::set<int> vertices;
      for (const Tri& t : region) vertices.insert(t.begin(), t.end());
      std::vector<TetVerts> best;
      for (int apex : vertices) {
        auto tets = coneFrom(apex, region);
        if (check.positive(tets)) {
          best = std::move(tets);
          break;
        }
      }
      if (best.empty()) {
        ok = false;
        break;
      }
      split.tets.insert(split.tets.end(), best.begin(), best.end());
    }
    if (!ok) continue;
    split.cut_faces = cut_tris;
    if (!check.valid(split.tets)) continue;
    *out = std::move(split);
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
  std::vector<int> edges;
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) edges.push_back(e);
  if (edges.size() > 3) return false;

  auto onFace = [](int e, int f) {
    auto fs = edgeFaces(e);
    return fs[0] == f || fs[1] == f;
  };
  std::vector<int> path;
  bool found = edges.empty();
  std::sort(edges.begin(), edges.end());
  if (!found) do {
      if (!onFace(edges.front(), F1) || !onFace(edges.back(), F2)) continue;
      std::set<int> used{F1, F2};
      bool ok = true;
      for (std::size_t i = 0; i + 1 < edges.size() && ok; ++i) {
        const int g = commonFace(edges[i], edges[i + 1]);
        ok = g >= 0 && used.insert(g).second;
      }
      if (ok) {
        path = edges;
        found = true;
        break;
      }
    } while (std::next_permutation(edges.begin(), edges.end()));
  if (!found) return false;

  TetSplit split;
  split.kind = SplitKind::kPartial;
  split.tets = coneFrom(f1, allFaceTriangles(cut));
  std::vector<int> chain;
  for (int e : path) chain.push_back(cut.edge_point[e]);
  chain.push_back(f2);
  if (path.empty()) split.kind = SplitKind::kCone;  // a front with no cut surface here
  for (std::size_t i = 0; i + 1 < chain.size(); ++i)
    split.cut_faces.push_back({f1, chain[i], chain[i + 1]});
  if (!check.valid(split.tets)) return false;
  *out = std::move(split);
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

// Traces the cut left on the faces: face-triangle edges joining two cut points across a face.
std::vector<std::array<int, 2>> faceTraces(const TetCut& cut) {
  std::set<std::array<int, 2>> traces;
  for (const Tri& t : allFaceTriangles(cut))
    for (int k = 0; k < 3; ++k) {
      const int x = t[k], y = t[(k + 1) % 3];
      if (isCutPoint(cut, x) && isCutPoint(cut, y) && !onSameTetEdge(cut, x, y))
        traces.insert({std::min(x, y), std::max(x, y)});
    }
  return {traces.begin(), traces.end()};
}

bool coneFromAPoint(const TetCut& cut, const Checker& check, TetSplit* out) {
  std::vector<int> apexes;
  for (int f = 0; f < 4; ++f)
    if (cut.face_point[f] >= 0) apexes.push_back(cut.face_point[f]);
  for (int c = 0; c < 4; ++c) apexes.push_back(cut.corner[c]);
  for (int e = 0; e < 6; ++e)
    if (cut.edge_point[e] >= 0) apexes.push_back(cut.edge_point[e]);
  const auto triangles = allFaceTriangles(cut);
  for (int apex : apexes) {
    auto tets = coneFrom(apex, triangles);
    if (check.valid(tets)) {
      out->kind = SplitKind::kCone;
      out->tets = std::move(tets);
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

std::vector<std::array<int, 3>> faceTriangles(const TetCut& cut, int f) {
  const int A = kTetFace[f][0], B = kTetFace[f][1], C = kTetFace[f][2];
  const int a = cut.corner[A], b = cut.corner[B], c = cut.corner[C];
  const int mA = cut.edge_point[tetEdgeIndex(B, C)];  // opposite a
  const int mB = cut.edge_point[tetEdgeIndex(C, A)];
  const int mC = cut.edge_point[tetEdgeIndex(A, B)];
  std::vector<Tri> out;
  if (cut.face_point[f] >= 0) {
    const int fp = cut.face_point[f];
    std::vector<int> ring;
    for (int v : {a, mC, b, mA, c, mB})
      if (v >= 0) ring.push_back(v);
    for (std::size_t i = 0; i < ring.size(); ++i)
      out.push_back({ring[i], ring[(i + 1) % ring.size()], fp});
    return out;
  }
  const int k = (mA >= 0) + (mB >= 0) + (mC >= 0);
  if (k == 0) return {{a, b, c}};
  if (k == 1) {
    if (mA >= 0) return {{a, b, mA}, {a, mA, c}};
    if (mB >= 0) return {{b, c, mB}, {b, mB, a}};
    return {{c, a, mC}, {c, mC, b}};
  }
  if (k == 3) return {{a, mC, mB}, {b, mA, mC}, {c, mB, mA}, {mC, mA, mB}};
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
  out.push_back({X, p, q});
  if (p < q) {  // p on XY sees Z
    out.push_back({p, Y, Z});
    out.push_back({p, Z, q});
  } else {  // q on ZX sees Y
    out.push_back({p, Y, q});
    out.push_back({Y, Z, q});
  }
  return out;
}

TetSplit splitTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                  int steiner) {
  const Checker check(cut, rest, current);
  TetSplit out;
  if (!cut.hasPoints()) {
    // Only corners on the cut: along a face, or merely touched.
    if (splitComplete(cut, check, &out)) return out;
    out.kind = SplitKind::kUntouched;
    out.tets = {cut.corner};
    return out;
  }
  if (splitComplete(cut, check, &out)) return out;
  if (splitPartial(cut, check, &out)) return out;
  const auto traces = faceTraces(cut);
  if (traces.empty() && coneFromAPoint(cut, check, &out)) return out;
  if (steiner < 0) {
    out.kind = SplitKind::kNeedsSteiner;
    return out;
  }
  out.kind = SplitKind::kTent;
  out.tets = coneFrom(steiner, allFaceTriangles(cut));
  for (const auto& t : traces) out.cut_faces.push_back({steiner, t[0], t[1]});
  return out;
}

TetSplit subdivideTet(const TetCut& cut, const PositionFn& rest, const PositionFn& current,
                      int steiner) {
  TetSplit out;
  if (!cut.hasPoints()) {
    out.kind = SplitKind::kUntouched;
    out.tets = {cut.corner};
    return out;
  }
  const Checker check(cut, rest, current);
  if (coneFromAPoint(cut, check, &out)) return out;
  if (steiner < 0) {
    out.kind = SplitKind::kNeedsSteiner;
    return out;
  }
  out.kind = SplitKind::kCone;
  out.tets = coneFrom(steiner, allFaceTriangles(cut));
  return out;
}

}  // namespace tissue_cut
