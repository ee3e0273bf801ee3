// The built-in block: extent, size, quality and validity.
#include <gtest/gtest.h>

#include "tissue_cut/mesh/block.hpp"
#include "tissue_cut/mesh/quality.hpp"

using namespace tissue_cut;

TEST(Block, DefaultFillsTheSpecifiedBox) {
  const MeshData b = makeBlock();
  EXPECT_NEAR(b.V.col(0).minCoeff(), -0.05, 1e-15);
  EXPECT_NEAR(b.V.col(0).maxCoeff(), 0.05, 1e-15);
  EXPECT_NEAR(b.V.col(1).minCoeff(), -0.03, 1e-15);
  EXPECT_NEAR(b.V.col(1).maxCoeff(), 0.03, 1e-15);
  EXPECT_NEAR(b.V.col(2).minCoeff(), 0.0, 1e-15);
  EXPECT_NEAR(b.V.col(2).maxCoeff(), 0.03, 1e-15);
  TetMesh mesh(b.V, b.T);
  EXPECT_NEAR(mesh.restVolume(), 0.1 * 0.06 * 0.03, 1e-15);
}

TEST(Block, DefaultHasBetween3000And10000TetsOfQualityAtLeast04) {
  const MeshData b = makeBlock();
  EXPECT_GE(b.T.rows(), 3000);
  EXPECT_LE(b.T.rows(), 10000);
  TetMesh mesh(b.V, b.T);
  EXPECT_EQ(mesh.reoriented(), 0);
  EXPECT_GE(summarizeQuality(mesh).min, 0.4);
}

TEST(Block, IsAValidClosedMesh) {
  const MeshData b = makeBlock();
  TetMesh mesh(b.V, b.T);
  EXPECT_EQ(mesh.validate(), "");
}

TEST(Block, ResolutionFollowsCellSize) {
  BlockSpec coarse, fine;
  coarse.cell_size = 0.01;
  fine.cell_size = 0.005;
  EXPECT_EQ(makeBlock(coarse).T.rows(), 10 * 6 * 3 * 6);
  EXPECT_EQ(makeBlock(fine).T.rows(), 20 * 12 * 6 * 6);
}

TEST(Block, RefusesAbsurdCellSize) {
  BlockSpec spec;
  spec.cell_size = 0.0;
  EXPECT_THROW(makeBlock(spec), std::invalid_argument);
  spec.cell_size = 1e-5;
  EXPECT_THROW(makeBlock(spec), std::invalid_argument);
}
