// Surface buffers: every boundary face once, outward unit normals, the cut's own colour.
#include <gtest/gtest.h>

#include <cmath>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/surface.hpp"

using namespace tissue_cut;

namespace {

Vec3 corner(const SurfaceBuffers& s, int tri, int k) {
  const float* p = &s.positions[9 * tri + 3 * k];
  return Vec3(p[0], p[1], p[2]);
}

}  // namespace

TEST(Surface, BlockSurfaceIsItsBoundaryFacesWithOutwardUnitNormals) {
  const MeshData block = makeBlock();  // 0.1 x 0.06 x 0.03 m around (0, 0, 0.015)
  const TetMesh mesh(block.V, block.T);
  SurfaceBuffers s;
  buildSurfaceBuffers(mesh, &s);
  ASSERT_EQ(s.triangles, mesh.numBoundaryFaces());
  ASSERT_EQ(s.positions.size(), 9u * s.triangles);
  ASSERT_EQ(s.colors.size(), 12u * s.triangles);
  double area = 0.0;
  const Vec3 centre(0.0, 0.0, 0.015);
  for (int t = 0; t < s.triangles; ++t) {
    const Vec3 a = corner(s, t, 0), b = corner(s, t, 1), c = corner(s, t, 2);
    const Vec3 n = (b - a).cross(c - a);
    area += 0.5 * n.norm();
    EXPECT_GT(n.dot((a + b + c) / 3.0 - centre), 0.0) << "triangle " << t << " faces inward";
    for (int k = 0; k < 3; ++k) {
      const float* u = &s.normals[9 * t + 3 * k];
      EXPECT_NEAR(std::sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]), 1.0, 1e-5);
      EXPECT_GT(Vec3(u[0], u[1], u[2]).dot(corner(s, t, k) - centre), 0.0);
    }
  }
  EXPECT_NEAR(area, 2.0 * (0.1 * 0.06 + 0.1 * 0.03 + 0.06 * 0.03), 1e-6);
}

TEST(Surface, FacesOfFlaggedTetsTakeTheCutColour) {
  const MeshData block = makeBlock();
  const TetMesh mesh(block.V, block.T);
  std::vector<unsigned char> flag(mesh.tetSlots(), 0);
  int flagged_faces = 0;
  for (int t = 0; t < mesh.tetSlots(); t += 7) {
    flag[t] = 1;
    for (int f = 0; f < 4; ++f) flagged_faces += mesh.neighbor(t, f) < 0;
  }
  SurfaceBuffers s;
  SurfaceColors colors;
  buildSurfaceBuffers(mesh, &s, &flag, colors);
  int cut_faces = 0;
  for (int t = 0; t < s.triangles; ++t) cut_faces += s.colors[12 * t] == colors.cut[0];
  EXPECT_GT(flagged_faces, 0);
  EXPECT_EQ(cut_faces, flagged_faces);
  // A second build reuses the buffers and gives the same surface.
  const std::vector<float> first = s.positions;
  buildSurfaceBuffers(mesh, &s, &flag, colors);
  EXPECT_EQ(s.positions, first);
}
