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

// Sorted (in std::array's order) and each once.
template <typename T>
void makeSet(std::vector<T>* v) {
  std::sort(v->begin(), v->end(),
            [](const T& x, const T& y) { return compareVertices(x, y) < 0; });
  v->erase(std::unique(v->begin(), v->end(), sameVertices<std::tuple_size<T>::value>), v->end());
}

// The size of the intersection of two sorted sets.
template <typename T>
std::size_t commonCount(const std::vector<T>& x, const std::vector<T>& y) {
  std::size_t n = 0;
  for (auto i = x.begin(), j = y.begin(); i != x.end() && j != y.end();) {
    if (*i < *j) {
      ++i;
    } else if (*j < *i) {
      ++j;
    } else {
      ++n;
      ++i;
      ++j;
    }
  }
  return n;
}

Edge sorted(int x, int y) { return x < y ? Edge{x, y} : Edge{y, x}; }

Triangle sorted(int x, int y, int z) {
  Triangle t{x, y, z};
  std::sort(t.begin(), t.end());
  return t;
}

// A check's scratch, kept per thread: marks on vertex slots (so that comparing the two links
// costs the size of the two stars, with no sorting of whole links) and small lists.
struct Scratch {
  std::vector<unsigned> mark;
  unsigned now = 0;
  std::vector<int> star, common;
  std::vector<Edge> ea, eb, eab;
  std::vector<Triangle> ta, tb;
  // Three fresh mark values: now (a neighbour of a), now + 1 (of both), now + 2 (in Lk(ab)).
  void begin(int slots) {
    growSlots(&mark, slots, 0u);
    if (now > ~0u - 8) {
      std::fill(mark.begin(), mark.end(), 0);
      now = 0;
    }
    now += 3;
  }
};

// The edges and triangles of Lk(v) whose vertices all pass `kept` (ω passes when omega_kept).
template <typename Kept>
void linkPart(const TetMesh& mesh, int v, const Kept& kept, bool omega_kept,
              std::vector<Edge>* edges, std::vector<Triangle>* triangles) {
  edges->clear();
  triangles->clear();
  // The cones over v's boundary faces, where ω is kept and v has any.
  const bool cones = omega_kept && mesh.boundaryFacesAt(v) > 0;
  for (int t : mesh.vertexTets(v)) {
    const TetVerts& tv = mesh.tet(t);
    const int i = localIndex(tv, v);
    // Face i of the tet is the triangle opposite v.
    const int x = tv[kTetFace[i][0]], y = tv[kTetFace[i][1]], z = tv[kTetFace[i][2]];
    const bool kx = kept(x), ky = kept(y), kz = kept(z);
    if (kx && ky) edges->push_back(sorted(x, y));
    if (ky && kz) edges->push_back(sorted(y, z));
    if (kx && kz) edges->push_back(sorted(x, z));
    if (kx && ky && kz) triangles->push_back(sorted(x, y, z));
    if (!cones) continue;
    for (int f = 0; f < 4; ++f) {
      if (f == i || mesh.neighbor(t, f) >= 0) continue;
      // Boundary face v p q: the cone ω v p q puts ω p q, ω p and ω q into Lk(v).
      int p = -1, q = -1;
      for (int k : kTetFace[f]) {
        if (tv[k] == v) continue;
        (p < 0 ? p : q) = tv[k];
      }
      const bool kp = kept(p), kq = kept(q);
      if (kp) edges->push_back(Edge{kOmega, p});
      if (kq) edges->push_back(Edge{kOmega, q});
      if (kp && kq) triangles->push_back(sorted(kOmega, p, q));
    }
  }
  makeSet(edges);
  makeSet(triangles);
}

// The thread's scratch, looked up once a check (linkConditionHolds): in a shared library each
// lookup of a thread_local is a call, and a reference to it inlined there was looked up again at
// each use in the loops.
[[gnu::noinline]] Scratch& threadScratch() {
  thread_local Scratch scratch;
  return scratch;
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

bool isBoundaryVertex(const TetMesh& mesh, int v) { return mesh.boundaryFacesAt(v) > 0; }

bool isBoundaryEdge(const TetMesh& mesh, int a, int b) {
  // A boundary face through the edge is one through each end.
  if (mesh.boundaryFacesAt(a) == 0 || mesh.boundaryFacesAt(b) == 0) return false;
  for (int t : mesh.vertexTets(a))  // the edge's tets, without a list of them
    if (localIndex(mesh.tet(t), b) >= 0 && openAtEdge(mesh, t, a, b)) return true;
  return false;
}

void requireEdge(const TetMesh& mesh, int a, int b, const char* who) {
  const bool live = a >= 0 && b >= 0 && a < mesh.vertexSlots() && b < mesh.vertexSlots() &&
                    a != b && mesh.vertexAlive(a) && mesh.vertexAlive(b);
  if (!live || !mesh.hasEdge(a, b))
    throw std::invalid_argument(std::string(who) + ": (" + std::to_string(a) + ", " +
                                std::to_string(b) + ") is not an edge of the mesh");
}

bool linkConditionHolds(const TetMesh& mesh, int a, int b) {
  requireEdge(mesh, a, b, "linkConditionHolds");
  Scratch& s = threadScratch();
  s.star.resize(mesh.vertexTets(a).size());  // the edge's star is among a's tets
  s.star.resize(mesh.edgeTets(a, b, s.star.data(), static_cast<int>(s.star.size())));
  // Lk(ab) lies in Lk(a) ∩ Lk(b) at every level, so each level holds exactly when the
  // intersection is no larger. A simplex in both links has all its vertices in both, so only
  // the parts of the links on the common vertices are built.
  s.begin(mesh.vertexSlots());
  const unsigned neighbour = s.now, both = s.now + 1, in_ab = s.now + 2;
  const bool a_boundary = mesh.boundaryFacesAt(a) > 0, b_boundary = mesh.boundaryFacesAt(b) > 0;
  for (int t : mesh.vertexTets(a))
    for (int v : mesh.tet(t))
      if (v != a) s.mark[v] = neighbour;
  s.common.clear();
  for (int t : mesh.vertexTets(b)) {
    for (int v : mesh.tet(t))
      if (v != b && s.mark[v] == neighbour) {
        s.mark[v] = both;
        s.common.push_back(v);
      }
  }
  const bool omega_common = a_boundary && b_boundary;
  // Vertices: Lk(ab) has the other two vertices of each tet on ab, and ω when ab lies on a
  // boundary face.
  std::size_t in_link = 0;
  bool ab_boundary = false;
  s.eab.clear();
  for (int t : s.star) {
    const TetVerts& tv = mesh.tet(t);
    const int ia = localIndex(tv, a), ib = localIndex(tv, b);
    int other[2], n = 0;
    for (int k = 0; k < 4; ++k)
      if (k != ia && k != ib) other[n++] = tv[k];
    for (int o : other)
      if (s.mark[o] == both) {
        s.mark[o] = in_ab;
        ++in_link;
      }
    s.eab.push_back(sorted(other[0], other[1]));
    // Faces holding ab are the ones opposite the two other vertices.
    for (int k = 0; k < 4; ++k) {
      if (k == ia || k == ib || mesh.neighbor(t, k) >= 0) continue;
      ab_boundary = true;
      s.eab.push_back(Edge{kOmega, tv[k] == other[0] ? other[1] : other[0]});
    }
  }
  if (in_link != s.common.size() || ab_boundary != omega_common) return false;
  // Edges and triangles, on the common vertices (now those of Lk(ab)).
  auto kept = [&](int v) { return v == kOmega ? omega_common : s.mark[v] == in_ab; };
  linkPart(mesh, a, kept, omega_common, &s.ea, &s.ta);
  linkPart(mesh, b, kept, omega_common, &s.eb, &s.tb);
  makeSet(&s.eab);
  return commonCount(s.ea, s.eb) == s.eab.size() && commonCount(s.ta, s.tb) == 0;
}

}  // namespace tissue_cut
