#include "tissue_cut/mesh/topology.hpp"

#include <algorithm>
#include <numeric>
#include <set>
#include <utility>
#include <vector>

namespace tissue_cut {

int countPieces(const TetMesh& mesh) {
  std::vector<int> parent(mesh.tetSlots());
  std::iota(parent.begin(), parent.end(), 0);
  auto find = [&](int x) {
    while (parent[x] != x) x = parent[x] = parent[parent[x]];
    return x;
  };
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      const int u = mesh.neighbor(t, f);
      if (u >= 0) parent[find(t)] = find(u);
    }
  }
  int pieces = 0;
  for (int t = 0; t < mesh.tetSlots(); ++t)
    if (mesh.tetAlive(t) && find(t) == t) ++pieces;
  return pieces;
}

int boundaryEulerCharacteristic(const TetMesh& mesh) {
  std::set<int> vertices;
  std::set<std::pair<int, int>> edges;
  int faces = 0;
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0) continue;
      ++faces;
      const TetVerts& tv = mesh.tet(t);
      for (int k = 0; k < 3; ++k) {
        const int a = tv[kTetFace[f][k]], b = tv[kTetFace[f][(k + 1) % 3]];
        vertices.insert(a);
        edges.insert({std::min(a, b), std::max(a, b)});
      }
    }
  }
  return static_cast<int>(vertices.size()) - static_cast<int>(edges.size()) + faces;
}

double boundaryRestArea(const TetMesh& mesh) {
  double area = 0.0;
  for (int t = 0; t < mesh.tetSlots(); ++t) {
    if (!mesh.tetAlive(t)) continue;
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0) continue;
      const TetVerts& tv = mesh.tet(t);
      const Vec3& a = mesh.rest(tv[kTetFace[f][0]]);
      const Vec3& b = mesh.rest(tv[kTetFace[f][1]]);
      const Vec3& c = mesh.rest(tv[kTetFace[f][2]]);
      area += 0.5 * (b - a).cross(c - a).norm();
    }
  }
  return area;
}

}  // namespace tissue_cut
