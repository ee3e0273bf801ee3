#include "tissue_cut/mesh/surface.hpp"

#include <cmath>

namespace tissue_cut {

void buildSurfaceBuffers(const TetMesh& mesh, SurfaceBuffers* out,
                         const std::vector<unsigned char>* cut_flag, const SurfaceColors& colors) {
  const int faces = mesh.numBoundaryFaces();
  out->positions.resize(9 * static_cast<std::size_t>(faces));
  out->normals.resize(9 * static_cast<std::size_t>(faces));
  out->colors.resize(12 * static_cast<std::size_t>(faces));
  out->vertex_normal.assign(mesh.vertexSlots(), Vec3::Zero());
  // Pass 1: positions and colours; the unnormalised face normal (twice the area) goes to each
  // corner's sum, so larger faces weigh more.
  int n = 0;
  for (int t = 0; t < mesh.tetSlots() && n < faces; ++t) {
    if (!mesh.tetAlive(t)) continue;
    const TetVerts& tv = mesh.tet(t);
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0) continue;
      const int v[3] = {tv[kTetFace[f][0]], tv[kTetFace[f][1]], tv[kTetFace[f][2]]};
      const Vec3 &a = mesh.current(v[0]), &b = mesh.current(v[1]), &c = mesh.current(v[2]);
      const Vec3 normal = (b - a).cross(c - a);
      const bool cut = cut_flag && t < static_cast<int>(cut_flag->size()) && (*cut_flag)[t];
      const std::array<float, 4>& rgba = cut ? colors.cut : colors.tissue;
      float* pos = &out->positions[9 * static_cast<std::size_t>(n)];
      float* col = &out->colors[12 * static_cast<std::size_t>(n)];
      for (int k = 0; k < 3; ++k) {
        const Vec3& x = mesh.current(v[k]);
        for (int d = 0; d < 3; ++d) pos[3 * k + d] = static_cast<float>(x[d]);
        for (int d = 0; d < 4; ++d) col[4 * k + d] = rgba[d];
        out->vertex_normal[v[k]] += normal;
      }
      ++n;
    }
  }
  out->triangles = n;
  // Pass 2: each corner takes its vertex's normalised sum.
  n = 0;
  for (int t = 0; t < mesh.tetSlots() && n < faces; ++t) {
    if (!mesh.tetAlive(t)) continue;
    const TetVerts& tv = mesh.tet(t);
    for (int f = 0; f < 4; ++f) {
      if (mesh.neighbor(t, f) >= 0) continue;
      float* nor = &out->normals[9 * static_cast<std::size_t>(n)];
      for (int k = 0; k < 3; ++k) {
        const Vec3& s = out->vertex_normal[tv[kTetFace[f][k]]];
        const double len = s.norm();
        const Vec3 u = len > 0 ? Vec3(s / len) : Vec3::Zero();
        for (int d = 0; d < 3; ++d) nor[3 * k + d] = static_cast<float>(u[d]);
      }
      ++n;
    }
  }
}

}  // namespace tissue_cut
