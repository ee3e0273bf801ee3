#include "tissue_cut/remesh/link_condition.hpp"

#include <algorithm>
#include <array>
#include <stdexcept>
#include <string>
#include <vector>

namespace tissue_cut {

namespace {

// The dummy vertex closing the mesh. Vertex ids are non-negative, so it never meets a real one,
// and it sorts first in every simplex.
constexpr int kOmega = -1;

using Edge = std::array<int, 2>;
using Triangle = std::array<int, 3>;

// A link as sorted, duplicate-free lists of simplices, each simplex with sorted vertices.
struct Link {
  std::vector<int> vertices;
  std::vector<Edge> edges;
  std::vector<Triangle> triangles;
  void clear() {
    vertices.clear();
    edges.clear();
    triangles.clear();
  }
};

Edge sorted(int x, int y) { return x < y ? Edge{x, y} : Edge{y, x}; }

Triangle sorted(int x, int y, int z) {
  Triangle t{x, y, z};
  std::sort(t.begin(), t.end());
  return t;
}

template <typename T>
void makeSet(std::vector<T>* v) {
  std::sort(v->begin(), v->end());
  v->erase(std::unique(v->begin(), v->end()), v->end());
}

// Whether the intersection of the sorted sets x and y is exactly `expected` (sorted), without
// building it.
template <typename T>
bool intersectionIs(const std::vector<T>& x, const std::vector<T>& y,
                    const std::vector<T>& expected) {
  auto i = x.begin(), j = y.begin();
  auto k = expected.begin();
  while (i != x.end() && j != y.end()) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      if (k == expected.end() || *k != *i) return false;
      ++k;
      ++i;
      ++j;
    }
  }
  return k == expected.end();
}

int localIndex(const TetVerts& tv, int v) {
  return static_cast<int>(std::find(tv.begin(), tv.end(), v) - tv.begin());
}

// Lk(v) in the mesh closed by ω, into *out (its buffers are reused).
void vertexLink(const TetMesh& mesh, int v, Link* out) {
  Link& link = *out;
  link.clear();
  for (int t : mesh.vertexTets(v)) {
    const TetVerts& tv = mesh.tet(t);
    const int i = localIndex(tv, v);
    // Face i of the tet is the triangle opposite v; its edges and vertices come with it.
    const int x = tv[kTetFace[i][0]], y = tv[kTetFace[i][1]], z = tv[kTetFace[i][2]];
    link.triangles.push_back(sorted(x, y, z));
    link.edges.push_back(sorted(x, y));
    link.edges.push_back(sorted(y, z));
    link.edges.push_back(sorted(x, z));
    link.vertices.insert(link.vertices.end(), {x, y, z});
    for (int f = 0; f < 4; ++f) {
      if (f == i || mesh.neighbor(t, f) >= 0) continue;
      // Boundary face v p q: the cone ω v p q puts ω p q, ω p, ω q and ω into Lk(v).
      int p = -1, q = -1;
      for (int k : kTetFace[f]) {
        if (tv[k] == v) continue;
        (p < 0 ? p : q) = tv[k];
      }
      link.triangles.push_back(sorted(kOmega, p, q));
      link.edges.push_back(Edge{kOmega, p});
      link.edges.push_back(Edge{kOmega, q});
      link.vertices.push_back(kOmega);
    }
  }
  makeSet(&link.vertices);
  makeSet(&link.edges);
  makeSet(&link.triangles);
}

// Lk(ab) in the mesh closed by ω. It has no triangles: that would need a 5-simplex, or a boundary
// simplex holding a, b and two more vertices.
void edgeLink(const TetMesh& mesh, int a, int b, const std::vector<int>& star, Link* out) {
  Link& link = *out;
  link.clear();
  for (int t : star) {
    const TetVerts& tv = mesh.tet(t);
    const int ia = localIndex(tv, a), ib = localIndex(tv, b);
    int other[2], n = 0;
    for (int k = 0; k < 4; ++k)
      if (k != ia && k != ib) other[n++] = tv[k];
    link.edges.push_back(sorted(other[0], other[1]));
    link.vertices.insert(link.vertices.end(), {other[0], other[1]});
    // Faces holding ab are the ones opposite the two other vertices.
    for (int k = 0; k < 4; ++k) {
      if (k == ia || k == ib || mesh.neighbor(t, k) >= 0) continue;
      const int x = tv[k] == other[0] ? other[1] : other[0];
      link.edges.push_back(Edge{kOmega, x});
      link.vertices.push_back(kOmega);
    }
  }
  makeSet(&link.vertices);
  makeSet(&link.edges);
}

}  // namespace

const char* toString(CollapseRefusal refusal) {
  switch (refusal) {
    case CollapseRefusal::kNone:
      return "none";
    case CollapseRefusal::kLink:
      return "link";
    case CollapseRefusal::kBoundary:
      return "boundary";
    case CollapseRefusal::kInversion:
      return "inversion";
    case CollapseRefusal::kQuality:
      return "quality";
  }
  return "unknown";
}

bool isBoundaryVertex(const TetMesh& mesh, int v) {
  for (int t : mesh.vertexTets(v)) {
    const int i = localIndex(mesh.tet(t), v);
    for (int f = 0; f < 4; ++f)
      if (f != i && mesh.neighbor(t, f) < 0) return true;
  }
  return false;
}

bool isBoundaryEdge(const TetMesh& mesh, int a, int b) {
  for (int t : mesh.edgeTets(a, b)) {
    const TetVerts& tv = mesh.tet(t);
    const int ia = localIndex(tv, a), ib = localIndex(tv, b);
    for (int f = 0; f < 4; ++f)
      if (f != ia && f != ib && mesh.neighbor(t, f) < 0) return true;
  }
  return false;
}

bool linkConditionHolds(const TetMesh& mesh, int a, int b) {
  const bool live = a >= 0 && b >= 0 && a < mesh.vertexSlots() && b < mesh.vertexSlots() &&
                    a != b && mesh.vertexAlive(a) && mesh.vertexAlive(b);
  const std::vector<int> star = live ? mesh.edgeTets(a, b) : std::vector<int>{};
  if (star.empty())
    throw std::invalid_argument("linkConditionHolds: (" + std::to_string(a) + ", " +
                                std::to_string(b) + ") is not an edge of the mesh");
  // The links' buffers are kept between calls (the queue checks thousands of edges a cut).
  thread_local Link la, lb, lab;
  vertexLink(mesh, a, &la);
  vertexLink(mesh, b, &lb);
  edgeLink(mesh, a, b, star, &lab);
  // Lk(ab) is always inside both links, so equality fails exactly when the ends share more.
  static const std::vector<Triangle> kNone;
  return intersectionIs(la.vertices, lb.vertices, lab.vertices) &&
         intersectionIs(la.edges, lb.edges, lab.edges) &&
         intersectionIs(la.triangles, lb.triangles, kNone);
}

}  // namespace tissue_cut
