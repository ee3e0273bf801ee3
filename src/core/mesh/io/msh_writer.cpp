// Gmsh .msh 2.2 ASCII, written here: the format is simple and the Gmsh API would need a model.
#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {

void writeGmsh22Mesh(const std::string& path, const MeshWriteData& data) {
  std::string out = "$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n";
  appendInteger(out, data.V.rows());
  out += '\n';
  for (Eigen::Index v = 0; v < data.V.rows(); ++v) {
    appendInteger(out, v + 1);
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      appendReal(out, data.V(v, k));
    }
    out += '\n';
  }
  out += "$EndNodes\n$Elements\n";
  appendInteger(out, data.T.rows());
  out += '\n';
  for (Eigen::Index t = 0; t < data.T.rows(); ++t) {
    // Element type 4 (4-node tet), physical group 1, elementary volume 1.
    appendInteger(out, t + 1);
    out += " 4 2 1 1";
    for (int k = 0; k < 4; ++k) {
      out += ' ';
      appendInteger(out, data.T(t, k) + 1);
    }
    out += '\n';
  }
  out += "$EndElements\n";
  writeWholeFile(path, out);
}

}  // namespace tissue_cut::mesh_io
