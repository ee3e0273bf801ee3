// VTK legacy unstructured grids: ASCII and BINARY (big-endian), the classic CELLS layout and
// the VTK 5.1 OFFSETS/CONNECTIVITY one.
#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>

#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {
namespace {

constexpr std::int64_t kVtkTetra = 10;
constexpr std::int64_t kVtkQuadraticTetra = 24;

// Bytes per value of the legacy data types a file may hold; 0 for those without a fixed size.
std::size_t valueBytes(std::string_view type) {
  struct Size {
    std::string_view type;
    std::size_t bytes;
  };
  static constexpr Size kSizes[] = {
      {"unsigned_char", 1}, {"char", 1},         {"short", 2},        {"unsigned_short", 2},
      {"int", 4},           {"unsigned_int", 4}, {"long", 8},         {"unsigned_long", 8},
      {"float", 4},         {"double", 8},       {"vtktypeint64", 8}, {"vtktypeuint64", 8},
      {"vtktypeint32", 4},  {"vtkidtype", 4},
  };
  for (const Size& size : kSizes) {
    if (equalsIgnoringCase(type, size.type)) return size.bytes;
  }
  return 0;
}

bool isBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\f' || c == '\v';
}

class VtkLegacyReader {
 public:
  VtkLegacyReader(const MeshFile& file, const MeshReadOptions& options)
      : file_(file), options_(options), bytes_(file.bytes) {}

  RawTetMesh read();

 private:
  std::string here() const { return binary_ ? byteRef(pos_) : lineRef(line_); }
  [[noreturn]] void fail(const std::string& what) const {
    throwMeshIOError(file_.name, here(), what);
  }
  std::size_t bytesLeft() const { return bytes_.size() - std::min(bytes_.size(), pos_); }

  bool nextLine(std::string_view& line);
  std::string_view nextToken();
  std::string_view requireToken(const std::string& what);
  bool peekKeyword(std::string_view keyword);
  std::int64_t integerToken(const std::string& what, std::int64_t min, std::int64_t max);
  void endKeywordLine();

  void readHeader();
  void readPoints();
  void readCells();
  void readCellTypes();
  void skipFieldData();
  void skipMetadata();
  void readIntegers(std::uint64_t count, std::string_view type, std::vector<std::int64_t>& out,
                    const std::string& what);
  RawTetMesh collectTets() const;

  const MeshFile& file_;
  const MeshReadOptions& options_;
  const std::string& bytes_;
  std::size_t pos_ = 0;
  std::size_t line_ = 1;  // line of pos_; meaningful in ASCII files only
  bool binary_ = false;
  bool have_points_ = false;
  bool have_cells_ = false;
  bool have_types_ = false;
  std::vector<double> points_;              // 3 per point
  std::vector<std::int64_t> offsets_;       // cells + 1 entries into connectivity_
  std::vector<std::int64_t> connectivity_;  // point ids of all cells
  std::vector<std::int64_t> types_;         // one per cell
};

bool VtkLegacyReader::nextLine(std::string_view& line) {
  if (pos_ >= bytes_.size()) return false;
  std::size_t end = bytes_.find('\n', pos_);
  if (end == std::string::npos) end = bytes_.size();
  line = std::string_view(bytes_).substr(pos_, end - pos_);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  pos_ = std::min(end + 1, bytes_.size());
  ++line_;
  return true;
}

std::string_view VtkLegacyReader::nextToken() {
  while (pos_ < bytes_.size() && isBlank(bytes_[pos_])) {
    if (bytes_[pos_] == '\n') ++line_;
    ++pos_;
  }
  const std::size_t start = pos_;
  while (pos_ < bytes_.size() && !isBlank(bytes_[pos_])) ++pos_;
  return std::string_view(bytes_).substr(start, pos_ - start);
}

std::string_view VtkLegacyReader::requireToken(const std::string& what) {
  const std::string_view token = nextToken();
  if (token.empty()) fail("truncated: the file ends before " + what);
  return token;
}

bool VtkLegacyReader::peekKeyword(std::string_view keyword) {
  const std::size_t pos = pos_;
  const std::size_t line = line_;
  if (equalsIgnoringCase(nextToken(), keyword)) return true;
  pos_ = pos;
  line_ = line;
  return false;
}

std::int64_t VtkLegacyReader::integerToken(const std::string& what, std::int64_t min,
                                           std::int64_t max) {
  const std::string_view token = requireToken(what);
  std::int64_t value = 0;
  if (!parseInteger(token, value)) fail(what + ": " + excerpt(token) + " is not an integer");
  if (value < min || value > max) {
    fail(what + " " + std::to_string(value) + " out of range [" + std::to_string(min) + ", " +
         std::to_string(max) + "]");
  }
  return value;
}

void VtkLegacyReader::endKeywordLine() {
  // In a binary file the data starts right after the newline of its keyword line.
  while (pos_ < bytes_.size() &&
         (bytes_[pos_] == ' ' || bytes_[pos_] == '\t' || bytes_[pos_] == '\r')) {
    ++pos_;
  }
  if (pos_ >= bytes_.size()) fail("truncated: the file ends after a keyword line");
  if (bytes_[pos_] != '\n') fail("unexpected text after the keyword line");
  ++pos_;
  ++line_;
}

void VtkLegacyReader::readHeader() {
  std::string_view line;
  nextLine(line);
  constexpr std::string_view kMagic = "# vtk DataFile";
  if (line.size() < kMagic.size() || !equalsIgnoringCase(line.substr(0, kMagic.size()), kMagic)) {
    throwMeshIOError(
        file_.name, lineRef(1),
        "not a VTK legacy file: expected \"# vtk DataFile Version ...\", found " + excerpt(line));
  }
  if (!nextLine(line)) fail("truncated: no title line");
  if (!nextLine(line)) fail("truncated: no ASCII/BINARY line");
  std::vector<std::string_view> fields;
  splitFields(line, fields);
  if (fields.size() == 1 && equalsIgnoringCase(fields[0], "ASCII")) {
    binary_ = false;
  } else if (fields.size() == 1 && equalsIgnoringCase(fields[0], "BINARY")) {
    binary_ = true;
  } else {
    throwMeshIOError(file_.name, lineRef(3), "expected ASCII or BINARY, found " + excerpt(line));
  }
  const std::string_view dataset = requireToken("DATASET");
  if (!equalsIgnoringCase(dataset, "DATASET")) fail("expected DATASET, found " + excerpt(dataset));
  const std::string_view kind = requireToken("the dataset type");
  if (!equalsIgnoringCase(kind, "UNSTRUCTURED_GRID")) {
    fail("dataset " + excerpt(kind) + " is not an UNSTRUCTURED_GRID");
  }
}

RawTetMesh VtkLegacyReader::read() {
  readHeader();
  while (true) {
    const std::string_view keyword = nextToken();
    if (keyword.empty()) break;
    if (equalsIgnoringCase(keyword, "POINTS")) {
      if (have_points_) fail("second POINTS section");
      readPoints();
    } else if (equalsIgnoringCase(keyword, "CELLS")) {
      if (have_cells_) fail("second CELLS section");
      readCells();
    } else if (equalsIgnoringCase(keyword, "CELL_TYPES")) {
      if (have_types_) fail("second CELL_TYPES section");
      readCellTypes();
    } else if (equalsIgnoringCase(keyword, "FIELD")) {
      skipFieldData();
    } else if (equalsIgnoringCase(keyword, "METADATA")) {
      skipMetadata();
    } else if (equalsIgnoringCase(keyword, "POINT_DATA") ||
               equalsIgnoringCase(keyword, "CELL_DATA")) {
      break;  // attribute data follows, none of it is needed
    } else {
      fail("unexpected keyword " + excerpt(keyword));
    }
  }
  if (!have_points_) throwMeshIOError(file_.name, "", "no POINTS section");
  if (!have_cells_) throwMeshIOError(file_.name, "", "no CELLS section");
  if (!have_types_) throwMeshIOError(file_.name, "", "no CELL_TYPES section");
  return collectTets();
}

void VtkLegacyReader::readPoints() {
  const std::uint64_t count =
      static_cast<std::uint64_t>(integerToken("number of points", 0, INT_MAX));
  const std::string_view type = requireToken("the POINTS data type");
  const bool is_double = equalsIgnoringCase(type, "double");
  if (!is_double && !equalsIgnoringCase(type, "float")) {
    fail("POINTS of type " + excerpt(type) + "; only float and double are read");
  }
  const std::uint64_t values = 3 * count;
  if (binary_) {
    endKeywordLine();
    ByteReader reader(file_, pos_, true);
    reader.require(values, is_double ? 8 : 4, "the POINTS data");
    points_.resize(values);
    for (std::uint64_t i = 0; i < values; ++i) {
      const std::size_t at = reader.offset();
      const double x = is_double ? reader.read<double>("the POINTS data")
                                 : static_cast<double>(reader.read<float>("the POINTS data"));
      if (!std::isfinite(x)) {
        throwMeshIOError(file_.name, byteRef(at),
                         "point " + std::to_string(i / 3) + ": non-finite coordinate");
      }
      points_[i] = x;
    }
    pos_ = reader.offset();
  } else {
    if (values > bytesLeft() / 2) {
      fail("truncated: " + std::to_string(count) + " points cannot fit in the " +
           std::to_string(bytesLeft()) + " bytes left in the file");
    }
    points_.resize(values);
    for (std::uint64_t i = 0; i < values; ++i) {
      const std::string_view token = requireToken("all " + std::to_string(count) + " points");
      double x = 0;
      if (!parseReal(token, x)) fail(excerpt(token) + " is not a number (or beyond double)");
      if (!std::isfinite(x)) {
        fail("point " + std::to_string(i / 3) + ": non-finite coordinate " + excerpt(token));
      }
      points_[i] = x;
    }
  }
  have_points_ = true;
}

void VtkLegacyReader::readIntegers(std::uint64_t count, std::string_view type,
                                   std::vector<std::int64_t>& out, const std::string& what) {
  if (binary_) {
    const std::size_t bytes = valueBytes(type);
    if (bytes != 4 && bytes != 8) fail(what + " of type " + excerpt(type) + " cannot be read");
    ByteReader reader(file_, pos_, true);
    reader.require(count, bytes, what);
    out.resize(count);
    for (std::uint64_t i = 0; i < count; ++i) {
      out[i] = bytes == 4 ? reader.read<std::int32_t>(what.c_str())
                          : reader.read<std::int64_t>(what.c_str());
    }
    pos_ = reader.offset();
    return;
  }
  if (count > bytesLeft() / 2) {
    fail("truncated: " + std::to_string(count) + " values of " + what + " cannot fit in the " +
         std::to_string(bytesLeft()) + " bytes left in the file");
  }
  out.resize(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    const std::string_view token = requireToken("all of " + what);
    if (!parseInteger(token, out[i])) {
      fail(what + ": " + excerpt(token) + " is not an integer");
    }
  }
}

void VtkLegacyReader::readCells() {
  constexpr std::int64_t kMaxCount = std::numeric_limits<std::int32_t>::max();
  const std::int64_t first = integerToken("the first CELLS count", 0, kMaxCount);
  const std::int64_t second = integerToken("the second CELLS count", 0, kMaxCount);
  if (binary_) endKeywordLine();
  if (peekKeyword("OFFSETS")) {
    // VTK 5.1: CELLS <offsets> <connectivity size>, then both arrays with their types.
    const std::string_view offsets_type = requireToken("the OFFSETS data type");
    if (binary_) endKeywordLine();
    readIntegers(static_cast<std::uint64_t>(first), offsets_type, offsets_, "OFFSETS");
    if (!peekKeyword("CONNECTIVITY")) fail("expected CONNECTIVITY after OFFSETS");
    const std::string_view connectivity_type = requireToken("the CONNECTIVITY data type");
    if (binary_) endKeywordLine();
    readIntegers(static_cast<std::uint64_t>(second), connectivity_type, connectivity_,
                 "CONNECTIVITY");
    if (offsets_.empty()) offsets_.push_back(0);
    if (offsets_.front() != 0 || offsets_.back() != second) {
      fail("OFFSETS must run from 0 to the CONNECTIVITY size " + std::to_string(second));
    }
    for (std::size_t c = 1; c < offsets_.size(); ++c) {
      if (offsets_[c] < offsets_[c - 1]) {
        fail("OFFSETS decrease at cell " + std::to_string(c - 1));
      }
    }
  } else {
    // Classic: CELLS <cells> <size>, then per cell its point count and point ids.
    const std::size_t num_cells = static_cast<std::size_t>(first);
    const std::size_t size = static_cast<std::size_t>(second);
    // Every cell takes at least its point count: more cells than values is corruption, and
    // must not size an allocation.
    if (num_cells > size) {
      fail("CELLS declares " + std::to_string(num_cells) + " cells in only " +
           std::to_string(size) + " values");
    }
    readIntegers(size, "int", connectivity_, "CELLS");
    offsets_.resize(num_cells + 1);
    std::size_t read = 0;
    std::size_t written = 0;
    for (std::size_t c = 0; c < num_cells; ++c) {
      if (read >= size) fail("the CELLS data ends before cell " + std::to_string(c));
      const std::int64_t points = connectivity_[read];
      if (points < 0 || static_cast<std::uint64_t>(points) > size - read - 1) {
        fail("cell " + std::to_string(c) + " declares " + std::to_string(points) +
             " points, beyond the CELLS size " + std::to_string(size));
      }
      offsets_[c] = static_cast<std::int64_t>(written);
      for (std::int64_t k = 0; k < points; ++k) {
        connectivity_[written++] = connectivity_[read + 1 + static_cast<std::size_t>(k)];
      }
      read += 1 + static_cast<std::size_t>(points);
    }
    if (read != size) {
      fail("CELLS size is " + std::to_string(size) + " but its " + std::to_string(num_cells) +
           " cells use " + std::to_string(read));
    }
    offsets_[num_cells] = static_cast<std::int64_t>(written);
    connectivity_.resize(written);
  }
  have_cells_ = true;
}

void VtkLegacyReader::readCellTypes() {
  if (!have_cells_) fail("CELL_TYPES before CELLS");
  const std::int64_t count = integerToken("number of cell types", 0, INT_MAX);
  const std::size_t num_cells = offsets_.size() - 1;
  if (static_cast<std::size_t>(count) != num_cells) {
    fail("CELL_TYPES lists " + std::to_string(count) + " cells, CELLS has " +
         std::to_string(num_cells));
  }
  if (binary_) endKeywordLine();
  readIntegers(static_cast<std::uint64_t>(count), "int", types_, "CELL_TYPES");
  have_types_ = true;
}

void VtkLegacyReader::skipFieldData() {
  requireToken("the FIELD name");
  const std::int64_t arrays = integerToken("number of FIELD arrays", 0, INT_MAX);
  for (std::int64_t a = 0; a < arrays; ++a) {
    const std::string_view name = requireToken("a FIELD array name");
    if (equalsIgnoringCase(name, "NULL_ARRAY")) continue;
    const std::int64_t components = integerToken("number of components", 0, INT_MAX);
    const std::int64_t tuples = integerToken("number of tuples", 0, INT_MAX);
    const std::string_view type = requireToken("the FIELD array data type");
    const std::uint64_t count =
        static_cast<std::uint64_t>(components) * static_cast<std::uint64_t>(tuples);
    const std::size_t bytes = valueBytes(type);
    if (bytes == 0) fail("FIELD array of type " + excerpt(type) + " cannot be skipped");
    if (binary_) {
      endKeywordLine();
      ByteReader reader(file_, pos_, true);
      reader.skip(count, bytes, "a FIELD array");
      pos_ = reader.offset();
    } else {
      if (count > bytesLeft() / 2) fail("truncated: FIELD array larger than the rest of the file");
      for (std::uint64_t i = 0; i < count; ++i) requireToken("all FIELD array values");
    }
    if (peekKeyword("METADATA")) skipMetadata();
  }
}

void VtkLegacyReader::skipMetadata() {
  // METADATA blocks end with an empty line.
  std::string_view line;
  nextLine(line);  // the rest of the METADATA line
  while (true) {
    if (!nextLine(line)) fail("truncated: METADATA block without its closing blank line");
    if (line.find_first_not_of(" \t\r") == std::string_view::npos) return;
  }
}

RawTetMesh VtkLegacyReader::collectTets() const {
  const std::size_t num_cells = types_.size();
  const std::int64_t num_points = static_cast<std::int64_t>(points_.size() / 3);
  std::size_t num_tets = 0;
  for (const std::int64_t type : types_) {
    if (type == kVtkTetra || type == kVtkQuadraticTetra) ++num_tets;
  }
  if (num_tets > options_.max_tets) throwTetLimit(file_.name, "", num_tets, options_);
  RawTetMesh raw;
  raw.corners.reserve(4 * num_tets);
  raw.origins.reserve(num_tets);
  raw.origin_kind = "cell";
  for (std::size_t c = 0; c < num_cells; ++c) {
    const std::int64_t type = types_[c];
    if (type != kVtkTetra && type != kVtkQuadraticTetra) continue;
    const std::string tet =
        "tet " + std::to_string(raw.origins.size()) + " (cell " + std::to_string(c) + ")";
    const std::int64_t expected = type == kVtkTetra ? 4 : 10;
    const std::int64_t points = offsets_[c + 1] - offsets_[c];
    if (points != expected) {
      throwMeshIOError(file_.name, tet,
                       "cell type " + std::to_string(type) + " with " + std::to_string(points) +
                           " points, expected " + std::to_string(expected));
    }
    // A quadratic tet lists its corners first.
    for (std::size_t k = 0; k < 4; ++k) {
      const std::int64_t id = connectivity_[static_cast<std::size_t>(offsets_[c]) + k];
      if (id < 0 || id >= num_points) {
        throwMeshIOError(file_.name, tet,
                         "point index " + std::to_string(id) + " out of range [0, " +
                             std::to_string(num_points - 1) + "]");
      }
      raw.corners.push_back(static_cast<std::int32_t>(id));
    }
    raw.origins.push_back(static_cast<std::int64_t>(c));
  }
  raw.xyz = points_;
  return raw;
}

}  // namespace

RawTetMesh readVtkLegacyMesh(const MeshFile& file, const MeshReadOptions& options) {
  return VtkLegacyReader(file, options).read();
}

void writeVtkLegacyMesh(const std::string& path, const MeshWriteData& data) {
  const Eigen::Index num_points = data.V.rows();
  const Eigen::Index num_tets = data.T.rows();
  std::string out =
      "# vtk DataFile Version 2.0\ntissue_cut mesh\nASCII\nDATASET UNSTRUCTURED_GRID\nPOINTS ";
  appendInteger(out, num_points);
  out += " double\n";
  const auto append_rows = [&out](const Eigen::MatrixXd& rows) {
    for (Eigen::Index i = 0; i < rows.rows(); ++i) {
      for (Eigen::Index k = 0; k < rows.cols(); ++k) {
        if (k > 0) out += ' ';
        appendReal(out, rows(i, k));
      }
      out += '\n';
    }
  };
  append_rows(data.V);
  out += "CELLS ";
  appendInteger(out, num_tets);
  out += ' ';
  appendInteger(out, 5 * num_tets);
  out += '\n';
  for (Eigen::Index t = 0; t < num_tets; ++t) {
    out += '4';
    for (int k = 0; k < 4; ++k) {
      out += ' ';
      appendInteger(out, data.T(t, k));
    }
    out += '\n';
  }
  out += "CELL_TYPES ";
  appendInteger(out, num_tets);
  out += '\n';
  for (Eigen::Index t = 0; t < num_tets; ++t) out += "10\n";
  if (data.rest.size() > 0) {
    out += "POINT_DATA ";
    appendInteger(out, num_points);
    out += "\nVECTORS rest double\n";
    append_rows(data.rest);
  }
  // Cell arrays as a FIELD: VTK and ParaView read it like SCALARS, and meshio (which the
  // independent checker uses) gives one value per cell instead of a column.
  const int arrays = (data.quality.size() > 0) + (data.cut_region.size() > 0);
  if (arrays > 0) {
    out += "CELL_DATA ";
    appendInteger(out, num_tets);
    out += "\nFIELD FieldData ";
    appendInteger(out, arrays);
    out += '\n';
  }
  if (data.quality.size() > 0) {
    out += "quality 1 ";
    appendInteger(out, num_tets);
    out += " double\n";
    for (Eigen::Index t = 0; t < num_tets; ++t) {
      appendReal(out, data.quality[t]);
      out += '\n';
    }
  }
  if (data.cut_region.size() > 0) {
    out += "cut_region 1 ";
    appendInteger(out, num_tets);
    out += " int\n";
    for (Eigen::Index t = 0; t < num_tets; ++t) {
      appendInteger(out, data.cut_region[t]);
      out += '\n';
    }
  }
  writeWholeFile(path, out);
}

}  // namespace tissue_cut::mesh_io
