// Mesh reading and writing: every bad file is refused with a message that names the file, where
// and what; every format reads, writes and reads back to the same mesh.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <clocale>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "tissue_cut/mesh/mesh_io.hpp"
#include "tissue_cut/tissue.hpp"

// Gmsh 4.8 leaks a few objects of its own when it classifies and remeshes an STL surface
// (discreteFace::_createGeometryFromSTL and friends); they are not ours to fix, and a sanitizer
// build should still fail on leaks in this project.
extern "C" const char* __lsan_default_suppressions() { return "leak:libgmsh.so\n"; }

namespace tissue_cut {
namespace {

const std::string kSourceDir = TISSUE_CUT_SOURCE_DIR;
const std::string kMeshes = kSourceDir + "/meshes/";
const std::string kData = kSourceDir + "/test/data/";
const std::string kBad = kSourceDir + "/test/data/bad/";

double totalVolume(const MeshData& mesh) {
  double volume = 0;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    const Eigen::Vector3d a = mesh.V.row(mesh.T(t, 0));
    const Eigen::Vector3d b = mesh.V.row(mesh.T(t, 1));
    const Eigen::Vector3d c = mesh.V.row(mesh.T(t, 2));
    const Eigen::Vector3d d = mesh.V.row(mesh.T(t, 3));
    volume += (b - a).dot((c - a).cross(d - a)) / 6.0;
  }
  return volume;
}

double smallestTetVolume(const MeshData& mesh) {
  double smallest = std::numeric_limits<double>::infinity();
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    const Eigen::Vector3d a = mesh.V.row(mesh.T(t, 0));
    const Eigen::Vector3d b = mesh.V.row(mesh.T(t, 1));
    const Eigen::Vector3d c = mesh.V.row(mesh.T(t, 2));
    const Eigen::Vector3d d = mesh.V.row(mesh.T(t, 3));
    smallest = std::min(smallest, (b - a).dot((c - a).cross(d - a)) / 6.0);
  }
  return smallest;
}

// A fresh directory for written files, removed afterwards.
class ScratchDir {
 public:
  ScratchDir() {
    std::string pattern = (std::filesystem::temp_directory_path() / "test_mesh_io_XXXXXX").string();
    path_ = mkdtemp(pattern.data()) ? pattern : std::string();
  }
  ~ScratchDir() {
    std::error_code ignored;
    if (!path_.empty()) std::filesystem::remove_all(path_, ignored);
  }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  bool ok() const { return !path_.empty(); }

 private:
  std::string path_;
};

MeshWriteData toWriteData(const MeshData& mesh) {
  MeshWriteData data;
  data.V = mesh.V;
  data.T = mesh.T;
  return data;
}

// ---------------------------------------------------------------------------------------------
// Bad files.

struct BadFile {
  std::string path;                    // under test/data/bad/ unless absolute
  std::vector<std::string> fragments;  // each must occur in the message
  std::string named = "";              // file the message starts with; default: basename of path
  std::size_t max_tets = MeshReadOptions{}.max_tets;
};

std::ostream& operator<<(std::ostream& out, const BadFile& bad) { return out << bad.path; }

class BadFileTest : public testing::TestWithParam<BadFile> {};

TEST_P(BadFileTest, IsRefusedWithFileNameWhereAndWhat) {
  const BadFile& bad = GetParam();
  const std::string path = bad.path.front() == '/' ? bad.path : kBad + bad.path;
  const std::string named =
      bad.named.empty() ? std::filesystem::path(path).filename().string() : bad.named;
  MeshReadOptions options;
  options.max_tets = bad.max_tets;
  try {
    readMesh(path, options);
    FAIL() << path << " was read";
  } catch (const MeshIOError& error) {
    const std::string message = error.what();
    EXPECT_EQ(message.rfind(named + ": ", 0), 0u) << message;
    for (const std::string& fragment : bad.fragments) {
      EXPECT_NE(message.find(fragment), std::string::npos)
          << "\"" << fragment << "\" missing from: " << message;
    }
  }
}

INSTANTIATE_TEST_SUITE_P(
    Gmsh22, BadFileTest,
    testing::Values(BadFile{"msh22_empty.msh", {"empty"}},
                    BadFile{"msh22_garbage.msh", {"line 1", "$MeshFormat"}},
                    BadFile{"msh22_malformed.msh", {"line 9", "not a number"}},
                    BadFile{"msh22_truncated.msh", {"line 17", "truncated"}},
                    BadFile{"msh22_nonfinite.msh", {"line 9", "non-finite"}},
                    BadFile{"msh22_out_of_range.msh",
                            {"line 21", "tet 2", "node tag 99", "out of range"}},
                    BadFile{"msh22_zero_volume.msh", {"tet 4", "zero volume"}},
                    BadFile{"msh22_count_mismatch.msh", {"line 15"}},
                    BadFile{"msh22_duplicated_line.msh", {"line 25", "$EndElements"}},
                    BadFile{"msh22_no_header.msh", {"line 1", "$MeshFormat"}},
                    BadFile{"msh22_unclosed.msh", {"line 15", "$EndNodes"}},
                    BadFile{"msh_version40.msh", {"line 2", "not supported"}},
                    BadFile{"msh22_binary_truncated.msh", {"byte offset", "truncated"}},
                    BadFile{"msh22_binary_block_size.msh", {"byte offset 360", "element block"}},
                    BadFile{"msh22_binary_nonfinite.msh", {"byte offset", "non-finite"}},
                    BadFile{kData + "cube_v22.msh", {"limit"}, "", 5},
                    BadFile{kData + "cube_v22_binary.msh", {"limit"}, "", 5},
                    BadFile{"does_not_exist.msh", {"no such file"}},
                    BadFile{"mesh.xyz", {"unknown extension"}}));

INSTANTIATE_TEST_SUITE_P(
    Gmsh41, BadFileTest,
    testing::Values(BadFile{"msh41_empty.msh", {"empty"}},
                    BadFile{"msh41_garbage.msh", {"line 4", "section"}},
                    BadFile{"msh41_malformed.msh", {"line 24"}},
                    BadFile{"msh41_truncated.msh", {"line 32", "truncated"}},
                    BadFile{"msh41_nonfinite.msh", {"line 24", "non-finite"}},
                    BadFile{"msh41_out_of_range.msh", {"line 38", "tet 2", "out of range"}},
                    BadFile{"msh41_zero_volume.msh", {"tet 4", "zero volume"}},
                    BadFile{"msh41_tag_range.msh", {"line 10", "tag range"}},
                    BadFile{"msh41_bounding.msh", {"line 7", "not defined"}},
                    BadFile{"msh41_binary_truncated.msh", {"byte offset", "truncated"}},
                    BadFile{"msh41_binary_huge_count.msh", {"byte offset 251", "number of nodes"}},
                    BadFile{"msh41_binary_nonfinite.msh", {"byte offset", "non-finite"}},
                    BadFile{kData + "cube_v41.msh", {"limit"}, "", 5},
                    BadFile{kData + "cube_v41_binary.msh", {"limit"}, "", 5}));

INSTANTIATE_TEST_SUITE_P(
    TetGen, BadFileTest,
    testing::Values(
        BadFile{"tetgen_empty.ele", {"empty"}, "tetgen_empty.node"},
        BadFile{"tetgen_garbage.ele", {"line 1", "not an integer"}, "tetgen_garbage.node"},
        BadFile{"tetgen_malformed.node", {"line 5", "not an integer"}, "tetgen_malformed.ele"},
        BadFile{"tetgen_truncated.ele", {"truncated"}},
        BadFile{"tetgen_nonfinite.node", {"line 8", "non-finite"}},
        BadFile{"tetgen_out_of_range.ele", {"line 5", "tet 2", "node 99", "out of range"}},
        BadFile{
            "tetgen_zero_volume.node", {"tet 4 (line 7)", "zero volume"}, "tetgen_zero_volume.ele"},
        BadFile{"tetgen_extra_line.node", {"line 12", "more data"}},
        BadFile{"tetgen_bad_numbering.node", {"line 6", "point number"}},
        BadFile{"tetgen_missing_ele.node", {"no such file"}, "tetgen_missing_ele.ele"},
        BadFile{kData + "cube.node", {"limit"}, "cube.ele", 5}));

INSTANTIATE_TEST_SUITE_P(
    Vtk, BadFileTest,
    testing::Values(BadFile{"vtk_empty.vtk", {"empty"}},
                    BadFile{"vtk_garbage.vtk", {"line 1", "not a VTK"}},
                    BadFile{"vtk_malformed.vtk", {"line 9", "not a number"}},
                    BadFile{"vtk_truncated.vtk", {"line 23", "truncated"}},
                    BadFile{"vtk_nonfinite.vtk", {"line 9", "non-finite"}},
                    BadFile{"vtk_out_of_range.vtk", {"tet 2 (cell 3)", "out of range"}},
                    BadFile{"vtk_zero_volume.vtk", {"tet 4 (cell 5)", "zero volume"}},
                    BadFile{"vtk_cells_size.vtk", {"line 23", "CELLS"}},
                    BadFile{"vtk_polydata.vtk", {"line 4", "UNSTRUCTURED_GRID"}},
                    BadFile{"vtk_binary_truncated.vtk", {"byte offset", "truncated"}},
                    BadFile{"vtk_binary_nonfinite.vtk", {"byte offset", "non-finite"}},
                    BadFile{"vtk_binary_out_of_range.vtk", {"tet 2 (cell 3)", "out of range"}},
                    BadFile{"vtk_binary_zero_volume.vtk", {"tet 4 (cell 5)", "zero volume"}},
                    BadFile{"vtk_binary_cell_count.vtk", {"byte offset", "100000 points"}},
                    BadFile{"vtk_binary_garbage.vtk", {"byte offset", "unexpected keyword"}},
                    BadFile{kData + "cube_ascii.vtk", {"limit"}, "", 5},
                    BadFile{kData + "cube_binary.vtk", {"limit"}, "", 5}));

INSTANTIATE_TEST_SUITE_P(
    Stl, BadFileTest,
    testing::Values(BadFile{"stl_empty.stl", {"empty"}},
                    BadFile{"stl_garbage.stl", {"byte offset 80", "facets"}},
                    BadFile{"stl_malformed.stl", {"line 7", "endloop"}},
                    BadFile{"stl_truncated.stl", {"byte offset 80", "truncated"}},
                    BadFile{"stl_ascii_truncated.stl", {"line 8", "truncated"}},
                    BadFile{"stl_nonfinite.stl", {"line 6", "non-finite"}},
                    BadFile{"stl_open.stl", {"facet 4", "not a closed surface"}},
                    BadFile{"stl_degenerate.stl", {"facet 12 (line 86)", "degenerate"}},
                    BadFile{kData + "cube.stl", {"limit"}, "", 100},
                    BadFile{kData + "cube_binary.stl", {"limit"}, "", 100}));

TEST(ReadMesh, RefusesAnUnusableStlMeshSize) {
  MeshReadOptions options;
  options.stl_mesh_size = -1;
  EXPECT_THROW(readMesh(kData + "cube.stl", options), MeshIOError);
}

// ---------------------------------------------------------------------------------------------
// Good files.

TEST(ReadMesh, DropsUnusedVerticesAndKeepsFileOrder) {
  // The cube files list the 8 corners in order, then a point no tet uses, and one triangle.
  for (const char* name :
       {"cube_v22.msh", "cube_v22_binary.msh", "cube_v41.msh", "cube_v41_binary.msh", "cube.node",
        "cube_ascii.vtk", "cube_binary.vtk"}) {
    SCOPED_TRACE(name);
    const MeshData mesh = readMesh(kData + name);
    ASSERT_EQ(mesh.V.rows(), 8);
    ASSERT_EQ(mesh.T.rows(), 6);
    for (int i = 0; i < 8; ++i) {
      EXPECT_EQ(mesh.V.row(i), Eigen::RowVector3d(i & 1, (i >> 1) & 1, (i >> 2) & 1));
    }
    EXPECT_EQ(mesh.reoriented, 0);
    EXPECT_NEAR(totalVolume(mesh), 1.0, 1e-14);
    EXPECT_GT(smallestTetVolume(mesh), 0.0);
  }
}

// The median of |a - b| over the mesh's edges a-b: how far apart in the arrays neighbours are.
double medianEdgeGap(const MeshData& mesh) {
  std::vector<std::pair<int, int>> edges;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j)
        edges.emplace_back(std::min(mesh.T(t, i), mesh.T(t, j)),
                           std::max(mesh.T(t, i), mesh.T(t, j)));
  std::sort(edges.begin(), edges.end());
  edges.erase(std::unique(edges.begin(), edges.end()), edges.end());
  std::vector<int> gaps;
  for (const auto& [a, b] : edges) gaps.push_back(b - a);
  std::nth_element(gaps.begin(), gaps.begin() + gaps.size() / 2, gaps.end());
  return gaps[gaps.size() / 2];
}

// Each tet as its corners' coordinates in order, sorted: the mesh whatever its numbering.
std::vector<std::array<double, 12>> tetsByCoordinates(const MeshData& mesh) {
  std::vector<std::array<double, 12>> out;
  for (Eigen::Index t = 0; t < mesh.T.rows(); ++t) {
    std::array<double, 12> c;
    for (int i = 0; i < 4; ++i)
      for (int k = 0; k < 3; ++k) c[3 * i + k] = mesh.V(mesh.T(t, i), k);
    out.push_back(c);
  }
  std::sort(out.begin(), out.end());
  return out;
}

// The same vertex and tet arrays, numbering included.
void expectSameArrays(const MeshData& a, const MeshData& b) {
  EXPECT_EQ(a.V, b.V);
  EXPECT_EQ(a.T, b.T);
}

TEST(SpatialOrder, IsTheSameMeshWithNeighboursCloseInTheArrays) {
  // TetGen numbers the surface's vertices first and the inside's after.
  const MeshData file = readMesh(kData + "sphere_tetgen.node");
  const MeshData ordered = spatiallyOrdered(file);
  ASSERT_EQ(ordered.V.rows(), file.V.rows());
  ASSERT_EQ(ordered.T.rows(), file.T.rows());
  EXPECT_EQ(ordered.reoriented, file.reoriented);
  // The same tets, corner for corner (so each keeps its orientation and volume), and every
  // vertex once.
  EXPECT_EQ(tetsByCoordinates(ordered), tetsByCoordinates(file));
  std::vector<std::array<double, 3>> a, b;
  for (Eigen::Index v = 0; v < file.V.rows(); ++v) {
    a.push_back({file.V(v, 0), file.V(v, 1), file.V(v, 2)});
    b.push_back({ordered.V(v, 0), ordered.V(v, 1), ordered.V(v, 2)});
  }
  std::sort(a.begin(), a.end());
  std::sort(b.begin(), b.end());
  EXPECT_EQ(a, b);
  EXPECT_GT(smallestTetVolume(ordered), 0.0);
  EXPECT_NEAR(totalVolume(ordered), totalVolume(file), 1e-12 * totalVolume(file));
  // Neighbours close in the arrays; tets in the order of their lowest vertex.
  const double before = medianEdgeGap(file), after = medianEdgeGap(ordered);
  EXPECT_LT(after, 0.2 * before) << "median edge gap " << before << " -> " << after;
  for (Eigen::Index t = 1; t < ordered.T.rows(); ++t)
    EXPECT_LE(ordered.T.row(t - 1).minCoeff(), ordered.T.row(t).minCoeff()) << "tet " << t;
  // Renumbering again changes nothing.
  expectSameArrays(spatiallyOrdered(ordered), ordered);
}

TEST(SpatialOrder, IsWhatTheTissueLoadsUnlessTheFileOrderIsAskedFor) {
  Config config;
  config.mesh = kData + "sphere_tetgen.node";
  const MeshData file = readMesh(config.mesh);
  const MeshData spatial = loadTissueMesh(config);
  expectSameArrays(spatial, spatiallyOrdered(file));
  EXPECT_NE(spatial.T, file.T);
  config.mesh_order = "file";
  expectSameArrays(loadTissueMesh(config), file);
}

TEST(SpatialOrder, ChangesOnlyByLoadingAMesh) {
  // The running model's numbering stays: a live change is refused by name, the config kept.
  Config config;
  config.mesh = kData + "sphere_tetgen.node";
  Tissue tissue(config, loadTissueMesh(config));
  Config changed = config;
  changed.mesh_order = "file";
  EXPECT_EQ(tissue.reconfigure(changed), "mesh_order: changes only by loading a mesh");
  EXPECT_EQ(tissue.config().mesh_order, "spatial");
}

TEST(ReadMesh, FlipsNegativelyOrientedTetsAndCountsThem) {
  for (const char* name : {"cube_flipped.node", "cube_flipped.ele", "cube_flipped.vtk"}) {
    SCOPED_TRACE(name);
    const MeshData mesh = readMesh(kData + name);
    EXPECT_EQ(mesh.reoriented, 3);
    EXPECT_GT(smallestTetVolume(mesh), 0.0);
    EXPECT_NEAR(totalVolume(mesh), 1.0, 1e-14);
  }
}

TEST(ReadMesh, FlipsTetsOfAWrittenFile) {
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  MeshData mesh = readMesh(kMeshes + "ellipsoid_v22.msh");
  const double volume = totalVolume(mesh);
  for (Eigen::Index t = 0; t < mesh.T.rows(); t += 3) std::swap(mesh.T(t, 0), mesh.T(t, 1));
  for (const char* name : {"flipped.msh", "flipped.vtk", "flipped.node"}) {
    SCOPED_TRACE(name);
    writeMesh(dir.file(name), toWriteData(mesh));
    const MeshData back = readMesh(dir.file(name));
    EXPECT_EQ(back.reoriented, (mesh.T.rows() + 2) / 3);
    EXPECT_GT(smallestTetVolume(back), 0.0);
    EXPECT_NEAR(totalVolume(back), volume, 1e-12 * volume);
  }
}

TEST(ReadMesh, TenNodeTetsKeepTheirCorners) {
  // Same mesh with and without midside nodes: identical once the midside nodes are dropped.
  const std::pair<const char*, const char*> pairs[] = {
      {"sphere_tet10_v22.msh", "sphere_v22.msh"},
      {"sphere_tet10_v41.msh", "sphere_v41.msh"},
      {"sphere_tet10.vtk", "sphere_ascii.vtk"},
      {"sphere_tet10_tetgen.ele", "sphere_tetgen.ele"},
  };
  for (const auto& [quadratic, linear] : pairs) {
    SCOPED_TRACE(quadratic);
    const MeshData tet10 = readMesh(kData + quadratic);
    const MeshData tet4 = readMesh(kData + linear);
    ASSERT_EQ(tet10.T.rows(), tet4.T.rows());
    const double volume = totalVolume(tet4);
    EXPECT_NEAR(totalVolume(tet10), volume, 1e-12 * volume);
    EXPECT_EQ(tet10.V.rows(), tet4.V.rows());
    EXPECT_GT(smallestTetVolume(tet10), 0.0);
  }
}

TEST(ReadMesh, EveryEncodingOfTheSameMeshReadsTheSame) {
  const MeshData reference = readMesh(kData + "sphere_v22.msh");
  for (const char* name : {"sphere_v22_binary.msh", "sphere_v41.msh", "sphere_v41_binary.msh",
                           "sphere_ascii.vtk", "sphere_v42_binary.vtk", "sphere_v51_ascii.vtk"}) {
    SCOPED_TRACE(name);
    const MeshData mesh = readMesh(kData + name);
    ASSERT_EQ(mesh.T.rows(), reference.T.rows());
    ASSERT_EQ(mesh.V.rows(), reference.V.rows());
    EXPECT_EQ(mesh.T, reference.T);
    // VTK's own ASCII writer (sphere_v51_ascii.vtk) keeps about 11 significant digits.
    EXPECT_LT((mesh.V - reference.V).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(ReadMesh, StlSurfacesAreFilledWithTets) {
  for (const char* name : {"capsule.stl", "capsule_binary.stl"}) {
    SCOPED_TRACE(name);
    const MeshData mesh = readMesh(kMeshes + name);
    EXPECT_GT(mesh.T.rows(), 500);
    EXPECT_GT(smallestTetVolume(mesh), 0.0);
    // Capsule of radius 0.05 m, cylinder 0.2 m long (in metres): a faceted copy is a little
    // smaller.
    const double exact = 1e-3 * (M_PI * 0.25 * 2 + 4.0 / 3.0 * M_PI * 0.125);
    EXPECT_NEAR(totalVolume(mesh), exact, 0.1 * exact);
  }
  MeshReadOptions coarse;
  coarse.stl_mesh_size = 0.5;
  const MeshData fine = readMesh(kData + "cube_binary.stl");
  const MeshData mesh = readMesh(kData + "cube.stl", coarse);
  EXPECT_LT(mesh.T.rows(), fine.T.rows());
  EXPECT_NEAR(totalVolume(mesh), 1.0, 1e-9);
  EXPECT_NEAR(totalVolume(fine), 1.0, 1e-9);
}

TEST(ReadMesh, ExtensionsAreCaseInsensitive) {
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  std::filesystem::copy_file(kData + "cube_v41.msh", dir.file("CUBE.MSH"));
  EXPECT_EQ(readMesh(dir.file("CUBE.MSH")).T.rows(), 6);
  std::filesystem::copy_file(kData + "cube.node", dir.file("cube.NODE"));
  std::filesystem::copy_file(kData + "cube.ele", dir.file("cube.ELE"));
  EXPECT_EQ(readMesh(dir.file("cube.ELE")).T.rows(), 6);
}

TEST(ReadMesh, ThreadsShareGmshSafely) {
  std::vector<std::thread> threads;
  std::vector<Eigen::Index> counts(6, 0);
  const char* names[] = {"ellipsoid_v22.msh", "holed_block_v41.msh", "capsule.stl"};
  for (std::size_t i = 0; i < counts.size(); ++i) {
    threads.emplace_back([&counts, &names, i] {
      try {
        counts[i] = readMesh(kMeshes + names[i % 3]).T.rows();
      } catch (const MeshIOError&) {
        counts[i] = -1;
      }
    });
  }
  for (std::thread& thread : threads) thread.join();
  for (std::size_t i = 0; i < counts.size(); ++i) {
    EXPECT_GT(counts[i], 0) << names[i % 3];
    EXPECT_EQ(counts[i], counts[i % 3]);
  }
}

TEST(ReadMesh, LeavesTheProcessLocaleAlone) {
  // Gmsh sets the numeric locale to "C" when it starts; readMesh() must undo that.
  const std::string before = std::setlocale(LC_ALL, nullptr);
  ASSERT_NE(std::setlocale(LC_ALL, "C.UTF-8"), nullptr);
  readMesh(kMeshes + "ellipsoid_v22.msh");
  readMesh(kData + "cube.stl");
  EXPECT_STREQ(std::setlocale(LC_NUMERIC, nullptr), "C.UTF-8");
  std::setlocale(LC_ALL, before.c_str());
}

// ---------------------------------------------------------------------------------------------
// Round trips.

class RoundTripTest : public testing::TestWithParam<std::string> {};

TEST_P(RoundTripTest, WritesAndReadsBackTheSameMesh) {
  const MeshData mesh = readMesh(GetParam());
  ASSERT_GT(mesh.T.rows(), 0);
  const double volume = totalVolume(mesh);
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  for (const char* name : {"out.vtk", "out.node", "out.msh"}) {
    SCOPED_TRACE(name);
    writeMesh(dir.file(name), toWriteData(mesh));
    const MeshData back = readMesh(dir.file(name));
    ASSERT_EQ(back.T.rows(), mesh.T.rows());
    EXPECT_EQ(back.V, mesh.V);  // bit for bit: written with 17 significant digits
    EXPECT_EQ(back.T, mesh.T);
    EXPECT_EQ(back.reoriented, 0);
    EXPECT_NEAR(totalVolume(back), volume, 1e-12 * volume);
  }
}

INSTANTIATE_TEST_SUITE_P(
    ProjectMeshes, RoundTripTest,
    testing::Values(kMeshes + "ellipsoid_v22.msh", kMeshes + "holed_block_v41.msh",
                    kMeshes + "sphere_tetgen.node", kMeshes + "beam_ascii.vtk",
                    kMeshes + "beam_binary.vtk", kMeshes + "capsule.stl",
                    kMeshes + "capsule_binary.stl", kData + "sphere_v22_binary.msh",
                    kData + "sphere_v41_binary.msh", kData + "sphere_v42_binary.vtk",
                    kData + "sphere_v51_ascii.vtk", kData + "sphere_tet10_v41.msh",
                    kData + "sphere_tet10_tetgen.ele"));

// ---------------------------------------------------------------------------------------------
// Writing.

TEST(WriteMesh, WritesTheTetGenPairForEitherName) {
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  const MeshData mesh = readMesh(kData + "cube.node");
  writeMesh(dir.file("pair.ele"), toWriteData(mesh));
  EXPECT_TRUE(std::filesystem::exists(dir.file("pair.node")));
  EXPECT_TRUE(std::filesystem::exists(dir.file("pair.ele")));
  EXPECT_EQ(readMesh(dir.file("pair.node")).T, mesh.T);
}

TEST(WriteMesh, VtkCarriesRestQualityAndCutRegion) {
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  const MeshData mesh = readMesh(kData + "cube_ascii.vtk");
  MeshWriteData data = toWriteData(mesh);
  data.rest = mesh.V * 2.0;
  data.quality = Eigen::VectorXd::LinSpaced(mesh.T.rows(), 0.1, 0.9);
  data.cut_region = Eigen::VectorXi::Zero(mesh.T.rows());
  data.cut_region[2] = 1;
  writeMesh(dir.file("data.vtk"), data);
  std::ifstream in(dir.file("data.vtk"));
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(text.rfind("# vtk DataFile Version 2.0\n", 0), 0u);
  for (const char* expected :
       {"POINTS 8 double\n", "CELLS 6 30\n", "CELL_TYPES 6\n",
        "POINT_DATA 8\nVECTORS rest double\n",
        "CELL_DATA 6\nFIELD FieldData 2\nquality 1 6 double\n0.10000000000000001\n",
        "cut_region 1 6 int\n0\n0\n1\n"}) {
    EXPECT_NE(text.find(expected), std::string::npos) << expected;
  }
  const MeshData back = readMesh(dir.file("data.vtk"));
  EXPECT_EQ(back.V, mesh.V);
  EXPECT_EQ(back.T, mesh.T);
}

TEST(WriteMesh, RefusesInconsistentDataUnknownExtensionsAndUnwritablePaths) {
  ScratchDir dir;
  ASSERT_TRUE(dir.ok());
  const MeshWriteData good = toWriteData(readMesh(kData + "cube_v22.msh"));
  MeshWriteData bad_id = good;
  bad_id.T(1, 2) = 8;
  MeshWriteData bad_quality = good;
  bad_quality.quality = Eigen::VectorXd::Ones(2);
  MeshWriteData bad_point = good;
  bad_point.V(3, 0) = std::numeric_limits<double>::quiet_NaN();
  const auto message = [](const std::string& path, const MeshWriteData& data) {
    try {
      writeMesh(path, data);
    } catch (const MeshIOError& error) {
      return std::string(error.what());
    }
    return std::string("written");
  };
  EXPECT_EQ(message(dir.file("m.vtk"), bad_id).rfind("m.vtk: not written: tet 1", 0), 0u);
  EXPECT_NE(message(dir.file("m.vtk"), bad_quality).find("quality"), std::string::npos);
  EXPECT_NE(message(dir.file("m.msh"), bad_point).find("vertex 3"), std::string::npos);
  EXPECT_NE(message(dir.file("m.obj"), good).find("unknown extension"), std::string::npos);
  EXPECT_EQ(message(dir.file("missing_dir/m.vtk"), good).rfind("m.vtk: cannot write", 0), 0u);
}

}  // namespace
}  // namespace tissue_cut
