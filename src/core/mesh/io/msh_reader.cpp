// Gmsh .msh files: validated by the pre-scan, read by Gmsh, and checked against what the
// pre-scan found, so that a disagreement is reported rather than silently half a mesh.
#include <gmsh.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include "gmsh_session.hpp"
#include "mesh_formats.hpp"
#include "msh_prescan.hpp"

namespace tissue_cut::mesh_io {
namespace {

// Maps tags to their position in file order.
class TagPositions {
 public:
  explicit TagPositions(const std::vector<std::uint64_t>& tags) {
    sorted_.reserve(tags.size());
    for (std::size_t i = 0; i < tags.size(); ++i) {
      sorted_.emplace_back(tags[i], static_cast<std::int32_t>(i));
    }
    std::sort(sorted_.begin(), sorted_.end());
  }

  /// -1 when the tag is unknown.
  std::int32_t find(std::uint64_t tag) const {
    const auto it =
        std::lower_bound(sorted_.begin(), sorted_.end(), std::make_pair(tag, std::int32_t{-1}));
    return it != sorted_.end() && it->first == tag ? it->second : -1;
  }

 private:
  std::vector<std::pair<std::uint64_t, std::int32_t>> sorted_;
};

}  // namespace

RawTetMesh readGmshMesh(const MeshFile& file, const MeshReadOptions& options) {
  MshLayout layout = prescanGmshMesh(file, options);
  if (layout.tet_tags.empty()) {
    throwMeshIOError(file.name, "", "no tetrahedra (element type 4 or 11) in the file");
  }

  ScratchDirectory scratch(file.name);
  const std::string gmsh_path = scratch.path("mesh.msh");
  try {
    writeWholeFile(gmsh_path, layout.gmsh_input);
  } catch (const MeshIOError& error) {
    throwMeshIOError(file.name, "", std::string("cannot hand the mesh to Gmsh: ") + error.what());
  }
  std::string().swap(layout.gmsh_input);

  std::vector<std::size_t> node_tags;
  std::vector<double> coordinates;
  std::vector<std::size_t> linear_tags;
  std::vector<std::size_t> linear_nodes;
  std::vector<std::size_t> quadratic_tags;
  std::vector<std::size_t> quadratic_nodes;
  {
    GmshSession session(file.name);
    session.run("read the mesh", [&] { gmsh::merge(gmsh_path); });
    session.run("list the nodes", [&] {
      std::vector<double> parametric;
      gmsh::model::mesh::getNodes(node_tags, coordinates, parametric, -1, -1, false, false);
    });
    session.run("list the tets", [&] {
      gmsh::model::mesh::getElementsByType(4, linear_tags, linear_nodes);
      gmsh::model::mesh::getElementsByType(11, quadratic_tags, quadratic_nodes);
    });
  }

  const std::size_t num_tets = layout.tet_tags.size();
  if (linear_tags.size() + quadratic_tags.size() != num_tets ||
      linear_nodes.size() != 4 * linear_tags.size() ||
      quadratic_nodes.size() != 10 * quadratic_tags.size() ||
      coordinates.size() != 3 * node_tags.size()) {
    throwMeshIOError(file.name, "",
                     "Gmsh read " + std::to_string(linear_tags.size() + quadratic_tags.size()) +
                         " tets where the file lists " + std::to_string(num_tets));
  }

  RawTetMesh raw;
  const TagPositions node_positions(layout.node_tags);
  raw.xyz.assign(3 * layout.node_tags.size(), std::numeric_limits<double>::quiet_NaN());
  for (std::size_t i = 0; i < node_tags.size(); ++i) {
    const std::int32_t position = node_positions.find(node_tags[i]);
    if (position < 0) {
      throwMeshIOError(
          file.name, "",
          "Gmsh returned node " + std::to_string(node_tags[i]) + ", which the file does not list");
    }
    std::copy_n(&coordinates[3 * i], 3, &raw.xyz[3 * static_cast<std::size_t>(position)]);
  }
  std::vector<double>().swap(coordinates);

  const TagPositions tet_positions(layout.tet_tags);
  raw.corners.assign(4 * num_tets, -1);
  const auto take_tets = [&](const std::vector<std::size_t>& tags,
                             const std::vector<std::size_t>& nodes, std::size_t stride) {
    for (std::size_t e = 0; e < tags.size(); ++e) {
      const std::int32_t tet = tet_positions.find(tags[e]);
      if (tet < 0 || raw.corners[4 * static_cast<std::size_t>(tet)] >= 0) {
        throwMeshIOError(
            file.name, "",
            "Gmsh returned tet " + std::to_string(tags[e]) + ", which the file does not list once");
      }
      for (std::size_t k = 0; k < 4; ++k) {
        const std::int32_t node = node_positions.find(nodes[stride * e + k]);
        if (node < 0 || std::isnan(raw.xyz[3 * static_cast<std::size_t>(node)])) {
          throwMeshIOError(
              file.name,
              "tet " + std::to_string(tet) + " (element " + std::to_string(tags[e]) + ")",
              "Gmsh gave node " + std::to_string(nodes[stride * e + k]) + " without coordinates");
        }
        raw.corners[4 * static_cast<std::size_t>(tet) + k] = node;
      }
    }
  };
  take_tets(linear_tags, linear_nodes, 4);
  take_tets(quadratic_tags, quadratic_nodes, 10);

  raw.origins.assign(layout.tet_tags.begin(), layout.tet_tags.end());
  raw.origin_kind = "element";
  return raw;
}

}  // namespace tissue_cut::mesh_io
