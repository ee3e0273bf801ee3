// Cases that once broke the mesh, replayed through Tissue::step with physics on.
#include <gtest/gtest.h>

#include "tissue_cut/cut/scalpel_path.hpp"
#include "tissue_cut/tissue.hpp"

using namespace tissue_cut;

namespace {

/// Live vertices that no tet holds (validate() finds them too, at a higher cost per tick).
int isolatedVertices(const TetMesh& mesh) {
  int n = 0;
  for (int v = 0; v < mesh.vertexSlots(); ++v)
    if (mesh.vertexAlive(v) && mesh.vertexTets(v).empty()) ++n;
  return n;
}

}  // namespace

// Back along an incision through the deformed block: a pending tet that once needed a centroid
// vertex was later subdivided without it, leaving the centroid in no tet (found by the soak run).
TEST(CutRegressions, ACentroidVertexNoLongerUsedLeavesTheMesh) {
  Config config;
  config.collapse.enabled = false;  // deterministic: the collapse budget is in microseconds
  Tissue tissue(config, loadTissueMesh(config));
  const ScalpelPath path =
      ScalpelPath::read(std::string(TISSUE_CUT_SOURCE_DIR) + "/test/data/back_and_forth_block.csv");
  const double dt = 1.0 / config.rate;
  const long ticks = std::lround((path.endTime() - path.startTime()) / dt);
  for (long k = 1; k <= ticks + 1; ++k) {
    std::optional<BladeSegment> blade;
    if (k <= ticks) {
      const ToolPose p = path.at(path.startTime() + k * dt);
      blade = bladeFromPose(p.position, p.orientation, config.cut.blade_length);
    }
    tissue.step(blade, dt);
    ASSERT_EQ(isolatedVertices(tissue.mesh()), 0) << "tick " << k;
    if (k % 200 == 0 || k > ticks - 300) {
      ASSERT_EQ(tissue.validate(), "") << "tick " << k;
    }
  }
  EXPECT_GT(tissue.cutter().counts().cut_tetrahedra, 300);
  EXPECT_NEAR(tissue.mesh().restVolume(), 0.1 * 0.06 * 0.03, 1e-9);
}
