// Surface buffers for drawing: the mesh's boundary triangles as flat float arrays, the layout a
// triangle-list marker (or any GPU vertex buffer) takes, rebuilt in place at the display rate.
#pragma once

#include <array>
#include <vector>

#include "tissue_cut/mesh/tet_mesh.hpp"

namespace tissue_cut {

/// Three corners per boundary triangle, each with its own position, normal and colour (a
/// triangle soup: no index buffer). Vectors keep their capacity between calls.
struct SurfaceBuffers {
  std::vector<float> positions;  ///< 9 per triangle: x y z of corners 0, 1, 2 [m], current
  std::vector<float> normals;    ///< 9 per triangle: unit per-vertex normals, outward
  std::vector<float> colors;     ///< 12 per triangle: r g b a of corners 0, 1, 2, in [0, 1]
  int triangles = 0;
  std::vector<Vec3> vertex_normal;  ///< scratch: area-weighted normal per vertex slot
};

/// Colours of the surface: `tissue` for the original surface, `cut` for faces of flagged tets.
struct SurfaceColors {
  std::array<float, 4> tissue{0.85f, 0.45f, 0.45f, 1.0f};
  std::array<float, 4> cut{0.65f, 0.1f, 0.1f, 1.0f};
};

/// Inputs: mesh (live tets, current positions); cut_flag: optional per-tet-slot flag (e.g.
/// Tissue::cutRegion()), boundary faces of flagged tets take colors.cut. Output: *out holds
/// every boundary face (a face without a neighbour) as a triangle oriented outward, with
/// per-vertex normals (area-weighted over the boundary faces around each vertex; cut lips are
/// separate vertices, so each lip keeps its own normal). Allocates only when the surface grew.
void buildSurfaceBuffers(const TetMesh& mesh, SurfaceBuffers* out,
                         const std::vector<unsigned char>* cut_flag = nullptr,
                         const SurfaceColors& colors = {});

}  // namespace tissue_cut
