// libFuzzer target for one mesh reader: the input is written to a file of the format's
// extension and read with readMesh(). Built once per format (TISSUE_CUT_FUZZ_FORMAT = msh, vtk,
// stl or tetgen) by the TISSUE_CUT_FUZZ CMake option; scripts/fuzz builds and runs them.
// A read must either throw MeshIOError or return a mesh that keeps readMesh()'s promises
// (finite coordinates, ids in range, positive volume); anything else aborts, so libFuzzer keeps
// the input. For TetGen the input is the .node file, a line "#ELE", then the .ele file.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "tissue_cut/mesh/mesh_io.hpp"

namespace {

const std::string kFormat = TISSUE_CUT_FUZZ_FORMAT;

const std::string& scratchDirectory() {
  static const std::string dir = [] {
    char templ[] = "/tmp/tissue_cut_fuzz_XXXXXX";
    const char* made = mkdtemp(templ);
    if (!made) std::abort();
    return std::string(made);
  }();
  return dir;
}

void writeFile(const std::string& path, const char* data, std::size_t size) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f.write(data, static_cast<std::streamsize>(size));
  if (!f) std::abort();
}

void check(bool ok, const char* what) {
  if (!ok) {
    std::fprintf(stderr, "readMesh broke its promise: %s\n", what);
    std::abort();
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const char* bytes = reinterpret_cast<const char*>(data);
  std::string path;
  if (kFormat == "tetgen") {
    const std::string all(bytes, size);
    const std::string marker = "#ELE\n";
    const std::size_t at = all.find(marker);
    const std::string node = at == std::string::npos ? all : all.substr(0, at);
    const std::string ele = at == std::string::npos ? "" : all.substr(at + marker.size());
    writeFile(scratchDirectory() + "/m.node", node.data(), node.size());
    writeFile(scratchDirectory() + "/m.ele", ele.data(), ele.size());
    path = scratchDirectory() + "/m.node";
  } else {
    path = scratchDirectory() + "/m." + kFormat;
    writeFile(path, bytes, size);
  }
  tissue_cut::MeshReadOptions options;
  options.max_tets = 20000;  // keeps one input from taking seconds of Gmsh time or gigabytes
  try {
    const tissue_cut::MeshData m = tissue_cut::readMesh(path, options);
    check(m.V.cols() == 3 && m.T.cols() == 4 && m.T.rows() > 0, "array shapes");
    check(m.V.allFinite(), "finite coordinates");
    for (Eigen::Index t = 0; t < m.T.rows(); ++t) {
      for (int k = 0; k < 4; ++k) check(m.T(t, k) >= 0 && m.T(t, k) < m.V.rows(), "ids in range");
      const Eigen::Vector3d a = m.V.row(m.T(t, 0)), b = m.V.row(m.T(t, 1)),
                            c = m.V.row(m.T(t, 2)), d = m.V.row(m.T(t, 3));
      check((b - a).cross(c - a).dot(d - a) > 0, "positive volume");
    }
  } catch (const tissue_cut::MeshIOError&) {
    // A refusal with a message is the expected outcome for most inputs.
  }
  return 0;
}
