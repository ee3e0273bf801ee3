// TetGen .node/.ele pairs.
#include <algorithm>
#include <cctype>
#include <climits>
#include <cmath>
#include <filesystem>
#include <limits>

#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {
namespace {

// More attributes than this per point or tet is a corrupted header, not a mesh.
constexpr std::int64_t kMaxAttributes = 1000;
// Shortest data lines: "0 0 0 0\n" for a point, "0 0 0 0 0\n" for a tet.
constexpr std::size_t kMinPointLine = 8;
constexpr std::size_t kMinTetLine = 10;

// The data lines of a TetGen file: '#' starts a comment, blank lines do not count.
class TetGenLines {
 public:
  explicit TetGenLines(const MeshFile& file) : file_(file), lines_(file.bytes) {}

  /// False at the end of the file.
  bool next() {
    std::string_view line;
    while (lines_.next(line)) {
      splitFields(line.substr(0, line.find('#')), fields_);
      if (!fields_.empty()) return true;
    }
    return false;
  }

  [[noreturn]] void fail(const std::string& what) const {
    throwMeshIOError(file_.name, lineRef(lines_.lineNumber()), what);
  }
  std::size_t size() const { return fields_.size(); }
  std::size_t line() const { return lines_.lineNumber(); }
  std::size_t bytesLeft() const {
    return file_.bytes.size() - std::min(file_.bytes.size(), lines_.offset());
  }

  std::int64_t integer(std::size_t i, std::int64_t min, std::int64_t max, const char* what) const {
    std::int64_t value = 0;
    if (!parseInteger(fields_[i], value)) {
      fail(std::string(what) + ": " + excerpt(fields_[i]) + " is not an integer");
    }
    if (value < min || value > max) {
      fail(std::string(what) + " " + std::to_string(value) + " out of range [" +
           std::to_string(min) + ", " + std::to_string(max) + "]");
    }
    return value;
  }

  double real(std::size_t i, const char* what) const {
    double value = 0;
    if (!parseReal(fields_[i], value)) {
      fail(std::string(what) + ": " + excerpt(fields_[i]) + " is not a number (or beyond double)");
    }
    return value;
  }

  void requireFields(std::size_t count, const std::string& what) const {
    if (fields_.size() != count) {
      fail("expected " + std::to_string(count) + " fields (" + what + "), found " +
           std::to_string(fields_.size()));
    }
  }

  /// Refuses data after the declared records: a duplicated line or a wrong count.
  void expectEnd(std::uint64_t declared, const char* records) {
    if (next()) {
      fail("more data than the " + std::to_string(declared) + " " + records +
           " the header declares");
    }
  }

  /// Refuses the end of the file before `declared` records.
  void requireRecord(std::uint64_t index, std::uint64_t declared, const char* records) {
    if (!next()) {
      throwMeshIOError(file_.name, lineRef(lines_.lineNumber()),
                       "truncated: the header declares " + std::to_string(declared) + " " +
                           records + ", the file ends after " + std::to_string(index));
    }
  }

 private:
  const MeshFile& file_;
  LineCursor lines_;
  std::vector<std::string_view> fields_;
};

std::string withExtension(const std::string& path, const std::string& extension) {
  std::filesystem::path p(path);
  const std::string lower = p.replace_extension(extension).string();
  if (std::filesystem::exists(lower)) return lower;
  std::string upper = extension;
  std::transform(upper.begin(), upper.end(), upper.begin(),
                 [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  const std::string upper_path = p.replace_extension(upper).string();
  return std::filesystem::exists(upper_path) ? upper_path : lower;
}

// Returns the number of the first point (0 or 1), which tet corners count from.
std::int64_t readNodes(const MeshFile& file, RawTetMesh& raw) {
  TetGenLines lines(file);
  if (!lines.next()) {
    throwMeshIOError(file.name, "", "no header line (only comments and blank lines)");
  }
  if (lines.size() > 4) lines.fail("header: expected points, dimension, attributes, markers");
  const std::uint64_t num_points =
      static_cast<std::uint64_t>(lines.integer(0, 1, INT_MAX, "number of points"));
  if (lines.size() > 1 && lines.integer(1, 0, INT_MAX, "dimension") != 3) {
    lines.fail("dimension must be 3");
  }
  const std::int64_t num_attributes =
      lines.size() > 2 ? lines.integer(2, 0, kMaxAttributes, "number of attributes") : 0;
  const std::int64_t num_markers =
      lines.size() > 3 ? lines.integer(3, 0, 1, "boundary marker flag") : 0;
  if (num_points > lines.bytesLeft() / kMinPointLine) {
    lines.fail("truncated: " + std::to_string(num_points) + " points cannot fit in the " +
               std::to_string(lines.bytesLeft()) + " bytes left in the file");
  }
  const std::size_t fields = 4 + static_cast<std::size_t>(num_attributes + num_markers);
  raw.xyz.reserve(3 * num_points);
  std::int64_t first = 0;
  for (std::uint64_t i = 0; i < num_points; ++i) {
    lines.requireRecord(i, num_points, "points");
    lines.requireFields(fields, "point number, x, y, z, attributes, marker");
    const std::int64_t number = lines.integer(0, INT_MIN, INT_MAX, "point number");
    if (i == 0) {
      if (number != 0 && number != 1) lines.fail("the first point must be number 0 or 1");
      first = number;
    } else if (number != first + static_cast<std::int64_t>(i)) {
      lines.fail("point number " + std::to_string(number) + ", expected " +
                 std::to_string(first + static_cast<std::int64_t>(i)));
    }
    for (std::size_t k = 1; k <= 3; ++k) {
      const double x = lines.real(k, "coordinate");
      if (!std::isfinite(x)) lines.fail("non-finite coordinate " + std::to_string(x));
      raw.xyz.push_back(x);
    }
    for (std::size_t k = 4; k < fields; ++k) lines.real(k, "attribute or marker");
  }
  lines.expectEnd(num_points, "points");
  return first;
}

void readTets(const MeshFile& file, const MeshReadOptions& options, std::int64_t first_point,
              RawTetMesh& raw) {
  const std::int64_t num_points = static_cast<std::int64_t>(raw.xyz.size() / 3);
  TetGenLines lines(file);
  if (!lines.next()) {
    throwMeshIOError(file.name, "", "no header line (only comments and blank lines)");
  }
  if (lines.size() > 3) lines.fail("header: expected tets, nodes per tet, attributes");
  const std::uint64_t num_tets = static_cast<std::uint64_t>(
      lines.integer(0, 0, std::numeric_limits<std::int64_t>::max(), "number of tets"));
  const std::int64_t nodes_per_tet =
      lines.size() > 1 ? lines.integer(1, 4, 10, "nodes per tet") : 4;
  if (nodes_per_tet != 4 && nodes_per_tet != 10) lines.fail("nodes per tet must be 4 or 10");
  const std::int64_t num_attributes =
      lines.size() > 2 ? lines.integer(2, 0, kMaxAttributes, "number of attributes") : 0;
  if (num_tets > options.max_tets)
    throwTetLimit(file.name, lineRef(lines.line()), num_tets, options);
  if (num_tets > lines.bytesLeft() / kMinTetLine) {
    lines.fail("truncated: " + std::to_string(num_tets) + " tets cannot fit in the " +
               std::to_string(lines.bytesLeft()) + " bytes left in the file");
  }
  const std::size_t fields = 1 + static_cast<std::size_t>(nodes_per_tet + num_attributes);
  raw.corners.reserve(4 * num_tets);
  raw.origins.reserve(num_tets);
  std::int64_t first = 0;
  for (std::uint64_t t = 0; t < num_tets; ++t) {
    lines.requireRecord(t, num_tets, "tets");
    lines.requireFields(fields,
                        "tet number, " + std::to_string(nodes_per_tet) + " nodes, attributes");
    const std::int64_t number = lines.integer(0, INT_MIN, INT_MAX, "tet number");
    if (t == 0) {
      if (number != 0 && number != 1) lines.fail("the first tet must be number 0 or 1");
      first = number;
    } else if (number != first + static_cast<std::int64_t>(t)) {
      lines.fail("tet number " + std::to_string(number) + ", expected " +
                 std::to_string(first + static_cast<std::int64_t>(t)));
    }
    // A 10-node tet lists its corners first.
    for (std::size_t k = 1; k <= 4; ++k) {
      const std::int64_t node = lines.integer(k, INT_MIN, INT_MAX, "node");
      if (node < first_point || node - first_point >= num_points) {
        lines.fail("tet " + std::to_string(t) + ": node " + std::to_string(node) +
                   " out of range [" + std::to_string(first_point) + ", " +
                   std::to_string(first_point + num_points - 1) + "]");
      }
      raw.corners.push_back(static_cast<std::int32_t>(node - first_point));
    }
    for (std::size_t k = 5; k < fields; ++k) lines.real(k, "node or attribute");
    raw.origins.push_back(static_cast<std::int64_t>(lines.line()));
  }
  lines.expectEnd(num_tets, "tets");
  raw.origin_kind = "line";
}

}  // namespace

RawTetMesh readTetGenMesh(const std::string& path, const MeshReadOptions& options,
                          std::string& name) {
  const std::size_t max_bytes = maxMeshFileBytes(options);
  const MeshFile nodes = loadMeshFile(withExtension(path, ".node"), max_bytes);
  const MeshFile tets = loadMeshFile(withExtension(path, ".ele"), max_bytes);
  name = tets.name;
  RawTetMesh raw;
  const std::int64_t first_point = readNodes(nodes, raw);
  readTets(tets, options, first_point, raw);
  return raw;
}

void writeTetGenMesh(const std::string& node_path, const std::string& ele_path,
                     const MeshWriteData& data) {
  std::string out = "# written by tissue_cut\n";
  appendInteger(out, data.V.rows());
  out += " 3 0 0\n";
  for (Eigen::Index v = 0; v < data.V.rows(); ++v) {
    appendInteger(out, v);
    for (int k = 0; k < 3; ++k) {
      out += ' ';
      appendReal(out, data.V(v, k));
    }
    out += '\n';
  }
  writeWholeFile(node_path, out);

  out = "# written by tissue_cut\n";
  appendInteger(out, data.T.rows());
  out += " 4 0\n";
  for (Eigen::Index t = 0; t < data.T.rows(); ++t) {
    appendInteger(out, t);
    for (int k = 0; k < 4; ++k) {
      out += ' ';
      appendInteger(out, data.T(t, k));
    }
    out += '\n';
  }
  writeWholeFile(ele_path, out);
}

}  // namespace tissue_cut::mesh_io
