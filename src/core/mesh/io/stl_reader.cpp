// Closed STL surfaces, parsed and checked here, then filled with tets by Gmsh.
//
// The facets are handed to Gmsh through its API as one discrete surface (corners welded where
// their coordinates are equal), not as a file: Gmsh's STL parser guesses ASCII or binary from
// the first bytes and trusts the facet count, and nothing here needs it.
#include <gmsh.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numeric>
#include <tuple>

#include "gmsh_session.hpp"
#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {
namespace {

constexpr std::size_t kBinaryHeaderBytes = 80;
constexpr std::size_t kBinaryFacetBytes = 50;
// Surface patches meet at sharper angles than this are kept apart as separate surfaces; the
// curvature of a smooth organ surface between neighbouring facets stays well below it.
constexpr double kFeatureAngleDegrees = 40.0;
// Facets below this fraction of the squared bounding-box diagonal have no usable normal.
constexpr double kZeroAreaRelative = 1e-12;

struct StlFacets {
  std::vector<double> corners;     // 9 per facet
  std::vector<std::size_t> where;  // line (ASCII) or byte offset (binary) of each facet
  bool binary = false;
};

std::string facetRef(const StlFacets& facets, std::size_t facet) {
  const std::size_t where = facets.where[facet];
  return "facet " + std::to_string(facet) + " (" +
         (facets.binary ? byteRef(where) : lineRef(where)) + ")";
}

float littleEndianFloat(const std::string& bytes, std::size_t offset) {
  unsigned char raw[4];
  std::memcpy(raw, bytes.data() + offset, 4);
  if (kHostIsBigEndian) {
    std::swap(raw[0], raw[3]);
    std::swap(raw[1], raw[2]);
  }
  float value;
  std::memcpy(&value, raw, 4);
  return value;
}

std::uint32_t binaryFacetCount(const std::string& bytes) {
  std::uint32_t count = 0;
  for (int k = 3; k >= 0; --k) {
    count = (count << 8) | static_cast<unsigned char>(bytes[kBinaryHeaderBytes + k]);
  }
  return count;
}

void parseBinaryStl(const MeshFile& file, StlFacets& facets) {
  const std::size_t count = binaryFacetCount(file.bytes);
  facets.binary = true;
  facets.corners.resize(9 * count);
  facets.where.resize(count);
  for (std::size_t f = 0; f < count; ++f) {
    const std::size_t record = kBinaryHeaderBytes + 4 + kBinaryFacetBytes * f;
    facets.where[f] = record;
    for (std::size_t k = 0; k < 9; ++k) {
      // Each record: normal (3 floats, ignored), 3 corners (9 floats), attribute (2 bytes).
      const float x = littleEndianFloat(file.bytes, record + 12 + 4 * k);
      if (!std::isfinite(x)) {
        throwMeshIOError(file.name, byteRef(record + 12 + 4 * k),
                         "facet " + std::to_string(f) + ": non-finite coordinate");
      }
      facets.corners[9 * f + k] = x;
    }
  }
}

class AsciiStlParser {
 public:
  AsciiStlParser(const MeshFile& file, StlFacets& facets)
      : file_(file), facets_(facets), lines_(file.bytes) {}

  void parse() {
    std::string_view line;
    bool in_solid = false;
    while (nextDataLine(line)) {
      if (!in_solid) {
        if (!keywordIs(0, "solid")) fail("expected \"solid\", found " + excerpt(line));
        in_solid = true;
      } else if (keywordIs(0, "facet")) {
        parseFacet();
      } else if (keywordIs(0, "endsolid")) {
        in_solid = false;
      } else {
        fail("expected \"facet\" or \"endsolid\", found " + excerpt(line));
      }
    }
    if (in_solid) {
      throwMeshIOError(file_.name, lineRef(lines_.lineNumber()),
                       "truncated: the file ends inside a solid (no \"endsolid\")");
    }
  }

 private:
  [[noreturn]] void fail(const std::string& what) const {
    throwMeshIOError(file_.name, lineRef(lines_.lineNumber()), what);
  }

  bool nextDataLine(std::string_view& line) {
    while (lines_.next(line)) {
      splitFields(line, fields_);
      if (!fields_.empty()) return true;
    }
    return false;
  }

  bool keywordIs(std::size_t i, std::string_view keyword) const {
    return i < fields_.size() && equalsIgnoringCase(fields_[i], keyword);
  }

  void expectLine(std::string_view first, std::string_view second, const char* what) {
    std::string_view line;
    if (!nextDataLine(line)) {
      fail(std::string("truncated: the file ends inside a facet, before ") + what);
    }
    const std::size_t count = second.empty() ? 1 : 2;
    if (fields_.size() != count || !keywordIs(0, first) || (count == 2 && !keywordIs(1, second))) {
      fail(std::string("expected ") + what + ", found " + excerpt(line));
    }
  }

  void parseFacet() {
    // The normal is recomputed by Gmsh; it only has to be there.
    if (fields_.size() != 5 || !keywordIs(1, "normal")) {
      fail("expected \"facet normal nx ny nz\"");
    }
    facets_.where.push_back(lines_.lineNumber());
    expectLine("outer", "loop", "\"outer loop\"");
    for (int corner = 0; corner < 3; ++corner) {
      std::string_view line;
      if (!nextDataLine(line)) fail("truncated: the file ends inside a facet");
      if (fields_.size() != 4 || !keywordIs(0, "vertex")) {
        fail("expected \"vertex x y z\", found " + excerpt(line));
      }
      for (std::size_t k = 1; k <= 3; ++k) {
        double x = 0;
        if (!parseReal(fields_[k], x)) fail(excerpt(fields_[k]) + " is not a number");
        if (!std::isfinite(x)) fail("non-finite coordinate " + excerpt(fields_[k]));
        facets_.corners.push_back(x);
      }
    }
    expectLine("endloop", "", "\"endloop\"");
    expectLine("endfacet", "", "\"endfacet\"");
  }

  const MeshFile& file_;
  StlFacets& facets_;
  LineCursor lines_;
  std::vector<std::string_view> fields_;
};

StlFacets parseStl(const MeshFile& file) {
  StlFacets facets;
  const std::string& bytes = file.bytes;
  const bool sized_as_binary =
      bytes.size() >= kBinaryHeaderBytes + 4 &&
      (bytes.size() - kBinaryHeaderBytes - 4) % kBinaryFacetBytes == 0 &&
      binaryFacetCount(bytes) == (bytes.size() - kBinaryHeaderBytes - 4) / kBinaryFacetBytes;
  const std::size_t text_start = bytes.find_first_not_of(" \t\r\n");
  // A NUL byte never occurs in ASCII STL, often in binary STL, whose header may also start
  // with "solid".
  const bool starts_as_ascii = text_start != std::string::npos &&
                               equalsIgnoringCase(bytes.substr(text_start, 5), "solid") &&
                               bytes.find('\0') == std::string::npos;
  // Binary files may also start with "solid"; the exact size settles it.
  if (sized_as_binary) {
    parseBinaryStl(file, facets);
  } else if (starts_as_ascii) {
    AsciiStlParser(file, facets).parse();
  } else if (bytes.size() < kBinaryHeaderBytes + 4) {
    throwMeshIOError(file.name, "",
                     "neither ASCII STL (no \"solid\" at the start) nor binary STL (shorter than "
                     "the 84-byte header)");
  } else {
    const std::uint64_t count = binaryFacetCount(bytes);
    throwMeshIOError(file.name, byteRef(kBinaryHeaderBytes),
                     "binary STL declares " + std::to_string(count) + " facets, which take " +
                         std::to_string(kBinaryHeaderBytes + 4 + kBinaryFacetBytes * count) +
                         " bytes; the file has " + std::to_string(bytes.size()) +
                         " (truncated or not an STL file)");
  }
  if (facets.where.empty()) throwMeshIOError(file.name, "", "no facets");
  return facets;
}

// The facets as a surface mesh: corners with equal coordinates are one vertex.
struct ClosedSurface {
  std::vector<double> xyz;             // 3 per vertex
  std::vector<std::size_t> triangles;  // 3 per facet, 0-based
  double enclosed_volume = 0;          // valid when consistently oriented
  bool consistently_oriented = true;
  double diagonal = 0;
};

ClosedSurface weldAndCheck(const MeshFile& file, const StlFacets& facets) {
  const std::size_t num_corners = facets.corners.size() / 3;
  const auto corner = [&](std::size_t c) { return &facets.corners[3 * c]; };
  std::vector<std::size_t> order(num_corners);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) {
    return std::lexicographical_compare(corner(a), corner(a) + 3, corner(b), corner(b) + 3);
  });
  ClosedSurface surface;
  surface.triangles.resize(num_corners);
  for (std::size_t i = 0; i < num_corners; ++i) {
    if (i == 0 || !std::equal(corner(order[i]), corner(order[i]) + 3, corner(order[i - 1]))) {
      surface.xyz.insert(surface.xyz.end(), corner(order[i]), corner(order[i]) + 3);
    }
    surface.triangles[order[i]] = surface.xyz.size() / 3 - 1;
  }

  double low[3] = {surface.xyz[0], surface.xyz[1], surface.xyz[2]};
  double high[3] = {low[0], low[1], low[2]};
  for (std::size_t v = 0; v < surface.xyz.size() / 3; ++v) {
    for (int k = 0; k < 3; ++k) {
      low[k] = std::min(low[k], surface.xyz[3 * v + k]);
      high[k] = std::max(high[k], surface.xyz[3 * v + k]);
    }
  }
  surface.diagonal =
      std::sqrt((high[0] - low[0]) * (high[0] - low[0]) + (high[1] - low[1]) * (high[1] - low[1]) +
                (high[2] - low[2]) * (high[2] - low[2]));

  const std::size_t num_facets = facets.where.size();
  const double min_double_area = 2 * kZeroAreaRelative * surface.diagonal * surface.diagonal;
  struct Edge {
    std::size_t low, high, facet;
    bool forward;
  };
  std::vector<Edge> edges;
  edges.reserve(3 * num_facets);
  for (std::size_t f = 0; f < num_facets; ++f) {
    const std::size_t* t = &surface.triangles[3 * f];
    if (t[0] == t[1] || t[1] == t[2] || t[0] == t[2]) {
      throwMeshIOError(file.name, facetRef(facets, f), "degenerate facet: two corners coincide");
    }
    const double* a = &surface.xyz[3 * t[0]];
    const double* b = &surface.xyz[3 * t[1]];
    const double* c = &surface.xyz[3 * t[2]];
    const double ab[3] = {b[0] - a[0], b[1] - a[1], b[2] - a[2]};
    const double ac[3] = {c[0] - a[0], c[1] - a[1], c[2] - a[2]};
    const double n[3] = {ab[1] * ac[2] - ab[2] * ac[1], ab[2] * ac[0] - ab[0] * ac[2],
                         ab[0] * ac[1] - ab[1] * ac[0]};
    if (!(std::sqrt(n[0] * n[0] + n[1] * n[1] + n[2] * n[2]) > min_double_area)) {
      throwMeshIOError(file.name, facetRef(facets, f), "degenerate facet: zero area");
    }
    surface.enclosed_volume +=
        (a[0] * (b[1] * c[2] - b[2] * c[1]) + a[1] * (b[2] * c[0] - b[0] * c[2]) +
         a[2] * (b[0] * c[1] - b[1] * c[0])) /
        6.0;
    for (int k = 0; k < 3; ++k) {
      const std::size_t from = t[k];
      const std::size_t to = t[(k + 1) % 3];
      edges.push_back({std::min(from, to), std::max(from, to), f, from < to});
    }
  }
  std::sort(edges.begin(), edges.end(), [](const Edge& a, const Edge& b) {
    return std::tie(a.low, a.high, a.facet) < std::tie(b.low, b.high, b.facet);
  });
  for (std::size_t i = 0; i < edges.size();) {
    std::size_t j = i;
    while (j < edges.size() && edges[j].low == edges[i].low && edges[j].high == edges[i].high) ++j;
    if (j - i != 2) {
      const double* p = &surface.xyz[3 * edges[i].low];
      const double* q = &surface.xyz[3 * edges[i].high];
      char detail[256];
      std::snprintf(detail, sizeof(detail),
                    "not a closed surface: the edge (%g, %g, %g)-(%g, %g, %g) belongs to %zu "
                    "facet(s), not 2",
                    p[0], p[1], p[2], q[0], q[1], q[2], j - i);
      throwMeshIOError(file.name, facetRef(facets, edges[i].facet), detail);
    }
    if (edges[i].forward == edges[i + 1].forward) surface.consistently_oriented = false;
    i = j;
  }
  return surface;
}

// Rough tet count of filling `volume` with tets of edge `size`: a regular tet of edge h has
// volume h^3 / (6 sqrt 2). Gmsh's tets are a little smaller, so this errs low.
double estimatedTets(double volume, double size) {
  return volume / (size * size * size / (6.0 * std::sqrt(2.0)));
}

}  // namespace

RawTetMesh readStlSurfaceAsTets(const MeshFile& file, const MeshReadOptions& options) {
  if (!(options.stl_mesh_size >= 0) || !std::isfinite(options.stl_mesh_size)) {
    throwMeshIOError(file.name, "", "MeshReadOptions::stl_mesh_size must be finite and >= 0");
  }
  const StlFacets facets = parseStl(file);
  const ClosedSurface surface = weldAndCheck(file, facets);
  const double size = options.stl_mesh_size > 0 ? options.stl_mesh_size : surface.diagonal / 20;
  const double volume = surface.consistently_oriented
                            ? std::abs(surface.enclosed_volume)
                            : surface.diagonal * surface.diagonal * surface.diagonal;
  const double estimate = estimatedTets(volume, size);
  if (estimate > static_cast<double>(options.max_tets)) {
    throwMeshIOError(file.name, "",
                     "mesh size " + std::to_string(size) + " would give about " +
                         std::to_string(static_cast<long long>(estimate)) +
                         " tets, more than the limit of " + std::to_string(options.max_tets) +
                         " (MeshReadOptions::max_tets)");
  }

  std::vector<std::size_t> node_tags;
  std::vector<double> coordinates;
  std::vector<std::size_t> tet_tags;
  std::vector<std::size_t> tet_nodes;
  {
    GmshSession session(file.name);
    session.run("tetrahedralise the surface", [&] {
      const int facets_entity = gmsh::model::addDiscreteEntity(2);
      std::vector<std::size_t> vertex_tags(surface.xyz.size() / 3);
      std::iota(vertex_tags.begin(), vertex_tags.end(), std::size_t{1});
      gmsh::model::mesh::addNodes(2, facets_entity, vertex_tags, surface.xyz);
      std::vector<std::size_t> triangle_nodes(surface.triangles.size());
      for (std::size_t i = 0; i < triangle_nodes.size(); ++i) {
        triangle_nodes[i] = surface.triangles[i] + 1;
      }
      gmsh::model::mesh::addElementsByType(facets_entity, 2, {}, triangle_nodes);
      // Patches that can be reparametrised get remeshed at the requested size.
      gmsh::model::mesh::classifySurfaces(kFeatureAngleDegrees * M_PI / 180.0, true, true, M_PI);
      gmsh::model::mesh::createGeometry();
      gmsh::vectorpair surfaces;
      gmsh::model::getEntities(surfaces, 2);
      std::vector<int> surface_tags;
      for (const auto& dim_tag : surfaces) surface_tags.push_back(dim_tag.second);
      const int shell = gmsh::model::geo::addSurfaceLoop(surface_tags);
      gmsh::model::geo::addVolume({shell});
      gmsh::model::geo::synchronize();
      session.setOption("Mesh.MeshSizeMin", 0);
      session.setOption("Mesh.MeshSizeMax", size);
      session.setOption("Mesh.MeshSizeFromCurvature", 0);
      session.setOption("Mesh.MeshSizeFromPoints", 0);
      session.setOption("Mesh.MeshSizeExtendFromBoundary", 1);
      session.setOption("Mesh.Algorithm", 6);    // Frontal-Delaunay surfaces
      session.setOption("Mesh.Algorithm3D", 1);  // Delaunay volumes
      session.setOption("Mesh.ElementOrder", 1);
      gmsh::model::mesh::generate(3);
      std::vector<double> parametric;
      gmsh::model::mesh::getNodes(node_tags, coordinates, parametric, -1, -1, false, false);
      gmsh::model::mesh::getElementsByType(4, tet_tags, tet_nodes);
    });
  }
  if (tet_nodes.size() != 4 * tet_tags.size() || coordinates.size() != 3 * node_tags.size()) {
    throwMeshIOError(file.name, "", "Gmsh returned inconsistent mesh arrays");
  }
  if (tet_tags.empty()) {
    throwMeshIOError(file.name, "",
                     "Gmsh made no tetrahedra from the surface (self-intersecting?)");
  }
  if (tet_tags.size() > options.max_tets) throwTetLimit(file.name, "", tet_tags.size(), options);

  // Vertices in node tag order; Gmsh lists them by entity.
  std::vector<std::size_t> order(node_tags.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](std::size_t a, std::size_t b) { return node_tags[a] < node_tags[b]; });
  RawTetMesh raw;
  raw.xyz.resize(coordinates.size());
  std::vector<std::pair<std::size_t, std::int32_t>> position(node_tags.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    std::copy_n(&coordinates[3 * order[i]], 3, &raw.xyz[3 * i]);
    position[i] = {node_tags[order[i]], static_cast<std::int32_t>(i)};
  }
  raw.corners.resize(tet_nodes.size());
  for (std::size_t i = 0; i < tet_nodes.size(); ++i) {
    const auto it = std::lower_bound(position.begin(), position.end(),
                                     std::make_pair(tet_nodes[i], std::int32_t{-1}));
    if (it == position.end() || it->first != tet_nodes[i]) {
      throwMeshIOError(file.name, "", "Gmsh returned a tet with an unknown node");
    }
    raw.corners[i] = it->second;
  }
  return raw;
}

}  // namespace tissue_cut::mesh_io
