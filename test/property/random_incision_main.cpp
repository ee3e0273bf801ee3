// random_incision: writes the random incision of one seed as a cut_replay path CSV, so that a
// property-test case can be replayed (and checked by other tools) from the command line.
//   random_incision --mesh FILE|block --seed N --out PATH.csv
// Prints "blade_length rate description" (the --blade-length and --rate to replay it with).
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <string>

#include "random_incision.hpp"
#include "tissue_cut/mesh/block.hpp"

int main(int argc, char** argv) {
  std::string mesh_path, out;
  long long seed = -1;
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string a = argv[i];
    if (a == "--mesh") {
      mesh_path = argv[i + 1];
    } else if (a == "--seed") {
      char* end = nullptr;
      seed = std::strtoll(argv[i + 1], &end, 10);
      if (*end != '\0' || seed < 0) seed = -1;
    } else if (a == "--out") {
      out = argv[i + 1];
    }
  }
  if (mesh_path.empty() || seed < 0 || out.empty() || argc != 7) {
    std::cerr << "usage: random_incision --mesh FILE|block --seed N --out PATH.csv\n";
    return 1;
  }
  try {
    const tissue_cut::MeshData mesh =
        mesh_path == "block" ? tissue_cut::makeBlock() : tissue_cut::readMesh(mesh_path);
    const auto incision =
        tissue_cut::property::randomIncision(mesh, static_cast<std::uint64_t>(seed));
    std::ofstream f(out);
    f << tissue_cut::property::incisionCsv(incision);
    if (!f) throw std::runtime_error(out + ": cannot write");
    std::printf("%.17g %g %s\n", incision.blade_length, incision.rate,
                incision.description.c_str());
  } catch (const std::exception& e) {
    std::cerr << "random_incision: " << e.what() << "\n";
    return 2;
  }
  return 0;
}
