#include "tissue_cut/mesh/block.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace tissue_cut {

MeshData makeBlock(const BlockSpec& spec) {
  const Vec3 size = spec.max - spec.min;
  if (!(size.minCoeff() > 0) || !size.allFinite())
    throw std::invalid_argument("block: the box must have positive finite extent");
  if (!(spec.cell_size > 0) || !std::isfinite(spec.cell_size))
    throw std::invalid_argument("block: cell_size must be positive");
  int n[3];
  double cells = 1.0;
  for (int k = 0; k < 3; ++k) {
    n[k] = std::max(1, static_cast<int>(std::lround(size[k] / spec.cell_size)));
    cells *= n[k];
  }
  if (cells * 6 > 2e6) throw std::invalid_argument("block: cell_size too small (over 2M tets)");

  const int nx = n[0] + 1, ny = n[1] + 1, nz = n[2] + 1;
  auto id = [&](int i, int j, int k) { return i + nx * (j + ny * k); };
  MeshData out;
  out.V.resize(nx * ny * nz, 3);
  for (int k = 0; k < nz; ++k)
    for (int j = 0; j < ny; ++j)
      for (int i = 0; i < nx; ++i) {
        // Grid points exactly on the box faces, so the block has exact extent and volume.
        out.V.row(id(i, j, k)) << spec.min.x() + size.x() * i / n[0],
            spec.min.y() + size.y() * j / n[1], spec.min.z() + size.z() * k / n[2];
      }
  // Kuhn split: one tet per ordering of the axes, walking from corner (0,0,0) to (1,1,1).
  static const int kOrders[6][3] = {{0, 1, 2}, {0, 2, 1}, {1, 0, 2},
                                    {1, 2, 0}, {2, 0, 1}, {2, 1, 0}};
  out.T.resize(static_cast<int>(cells) * 6, 4);
  int row = 0;
  for (int k = 0; k < n[2]; ++k)
    for (int j = 0; j < n[1]; ++j)
      for (int i = 0; i < n[0]; ++i)
        for (const auto& order : kOrders) {
          int c[3] = {i, j, k};
          int verts[4];
          verts[0] = id(c[0], c[1], c[2]);
          for (int s = 0; s < 3; ++s) {
            ++c[order[s]];
            verts[s + 1] = id(c[0], c[1], c[2]);
          }
          const Vec3 a = out.V.row(verts[0]), b = out.V.row(verts[1]), cc = out.V.row(verts[2]),
                     d = out.V.row(verts[3]);
          if (signedVolume(a, b, cc, d) < 0) std::swap(verts[2], verts[3]);
          out.T.row(row++) << verts[0], verts[1], verts[2], verts[3];
        }
  return out;
}

}  // namespace tissue_cut
