// Small mesh edits the unit tests share.
#pragma once

#include <array>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut::test {

/// Replaces tet t by four tets around a new vertex at the corners' weighted mean (weights sum to
/// 1); the change goes to *change. Returns the new vertex.
inline int splitAt(TetMesh* mesh, int t, const std::array<double, 4>& w, ChangeRecord* change) {
  const TetVerts c = mesh->tet(t);
  const int m = mesh->addVertex({{c[0], w[0]}, {c[1], w[1]}, {c[2], w[2]}, {c[3], w[3]}}, change);
  std::vector<TetVerts> add;
  for (int f = 0; f < 4; ++f) {
    TetVerts piece = c;
    piece[f] = m;
    add.push_back(piece);
  }
  mesh->replaceTets({t}, add, change);
  return m;
}

}  // namespace tissue_cut::test
