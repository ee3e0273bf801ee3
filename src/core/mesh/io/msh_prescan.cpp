#include "msh_prescan.hpp"

#include <algorithm>
#include <climits>
#include <cmath>
#include <limits>
#include <set>
#include <utility>

#include "mesh_formats.hpp"

namespace tissue_cut::mesh_io {
namespace {

// Element types whose node count is fixed, with their dimension, as Gmsh 4.8 defines them
// (MElement::getInfoMSH). Types not listed (polygons, polyhedra, one-node "elements" of
// higher dimension, XFEM types) are refused: their records do not have a fixed length.
struct MshElementType {
  int type;
  int nodes;
  int dim;
};
constexpr MshElementType kMshElementTypes[] = {
    {1, 2, 1},    {2, 3, 2},     {3, 4, 2},     {4, 4, 3},     {5, 8, 3},     {6, 6, 3},
    {7, 5, 3},    {8, 3, 1},     {9, 6, 2},     {10, 9, 2},    {11, 10, 3},   {12, 27, 3},
    {13, 18, 3},  {14, 14, 3},   {15, 1, 0},    {16, 8, 2},    {17, 20, 3},   {18, 15, 3},
    {19, 13, 3},  {20, 9, 2},    {21, 10, 2},   {22, 12, 2},   {23, 15, 2},   {24, 15, 2},
    {25, 21, 2},  {26, 4, 1},    {27, 5, 1},    {28, 6, 1},    {29, 20, 3},   {30, 35, 3},
    {31, 56, 3},  {32, 22, 3},   {33, 28, 3},   {36, 16, 2},   {37, 25, 2},   {38, 36, 2},
    {39, 12, 2},  {40, 16, 2},   {41, 20, 2},   {42, 28, 2},   {43, 36, 2},   {44, 45, 2},
    {45, 55, 2},  {46, 66, 2},   {47, 49, 2},   {48, 64, 2},   {49, 81, 2},   {50, 100, 2},
    {51, 121, 2}, {52, 18, 2},   {53, 21, 2},   {54, 24, 2},   {55, 27, 2},   {56, 30, 2},
    {57, 24, 2},  {58, 28, 2},   {59, 32, 2},   {60, 36, 2},   {61, 40, 2},   {62, 7, 1},
    {63, 8, 1},   {64, 9, 1},    {65, 10, 1},   {66, 11, 1},   {71, 84, 3},   {72, 120, 3},
    {73, 165, 3}, {74, 220, 3},  {75, 286, 3},  {79, 34, 3},   {80, 40, 3},   {81, 46, 3},
    {82, 52, 3},  {83, 58, 3},   {92, 64, 3},   {93, 125, 3},  {94, 216, 3},  {95, 343, 3},
    {96, 512, 3}, {97, 729, 3},  {98, 1000, 3}, {99, 32, 3},   {100, 44, 3},  {101, 56, 3},
    {102, 68, 3}, {103, 80, 3},  {104, 92, 3},  {105, 104, 3}, {118, 30, 3},  {119, 55, 3},
    {120, 91, 3}, {121, 140, 3}, {122, 204, 3}, {123, 285, 3}, {124, 385, 3}, {125, 21, 3},
    {126, 29, 3}, {127, 37, 3},  {128, 45, 3},  {129, 53, 3},  {130, 61, 3},  {131, 69, 3},
    {137, 16, 3},
};

constexpr int kMshLinearTet = 4;
constexpr int kMshQuadraticTet = 11;

const MshElementType* findElementType(std::int64_t type) {
  for (const MshElementType& known : kMshElementTypes) {
    if (known.type == type) return &known;
  }
  return nullptr;
}

// Gmsh reads some lines into fixed buffers (entity lines in older 4.x readers, element lines of
// MSH 4: 10000 bytes); a longer line would be split and misparsed there.
constexpr std::size_t kMaxEntityLine = 4000;
constexpr std::size_t kMaxElementLine = 9000;
// Gmsh reads section markers and $PhysicalNames lines into 256-byte buffers.
constexpr std::size_t kMaxShortLine = 250;
// A section name is an identifier; anything else after '$' is corruption.
constexpr std::size_t kMaxSectionName = 64;

// Shortest possible text records, to refuse declared counts the file cannot hold before
// anything is allocated for them.
constexpr std::size_t kMinNodeLine = 8;     // "1 0 0 0\n"
constexpr std::size_t kMinElementLine = 8;  // below "1 15 0 1\n", the shortest
constexpr std::size_t kMinShortLine = 2;    // "1\n"

class MshPrescan {
 public:
  MshPrescan(const MeshFile& file, const MeshReadOptions& options)
      : file_(file), options_(options), lines_(file.bytes) {}

  MshLayout run();

 private:
  // Where things are: line numbers in ASCII files, byte offsets in binary ones (whose line
  // numbers stop meaning anything after the first block of binary data).
  std::string ref(std::size_t line_or_offset) const {
    return layout_.binary ? byteRef(line_or_offset) : lineRef(line_or_offset);
  }
  std::size_t here() const { return layout_.binary ? lines_.lineStart() : lines_.lineNumber(); }
  [[noreturn]] void fail(const std::string& what) const {
    throwMeshIOError(file_.name, ref(here()), what);
  }
  [[noreturn]] void failAtByte(std::size_t offset, const std::string& what) const {
    throwMeshIOError(file_.name, byteRef(offset), what);
  }

  std::string_view requireLine(const std::string& what);
  void splitLine(std::string_view line, std::size_t max_length, bool spaces_only);
  void requireFieldCount(std::size_t count, const std::string& what) const;
  std::int64_t intField(std::size_t i, std::int64_t min, std::int64_t max, const char* what) const;
  double realField(std::size_t i, const char* what) const;
  std::uint64_t declaredCount(std::size_t i, std::size_t min_record_bytes, const char* what) const;
  std::uint64_t binaryCount(ByteReader& reader, std::size_t min_record_bytes,
                            const char* what) const;

  void scanMeshFormat();
  void scanPhysicalNames();
  void scanEntities41();
  void scanEntitiesBinary41(ByteReader& reader);
  void scanNodes22();
  void scanElements22();
  void scanNodes41();
  void scanElements41();
  // The header of a 4.1 $Nodes or $Elements section, and the checks closing it.
  struct BlocksHeader41 {
    std::uint64_t num_blocks = 0, count = 0, min_tag = 0, max_tag = 0;
    std::size_t header_at = 0;
  };
  BlocksHeader41 readBlocksHeader41(ByteReader& reader, const std::string& kind,
                                    std::size_t binary_record_bytes, std::size_t text_record_bytes);
  void closeBlocks41(const BlocksHeader41& h, const std::string& kind, std::uint64_t seen,
                     std::uint64_t lowest, std::uint64_t highest, const ByteReader& reader,
                     const std::string& section);
  void skipSection(const std::string& name);
  void expectSectionEnd(const std::string& name);
  void afterBinaryData(std::size_t offset);

  void addNode(std::uint64_t tag, std::size_t where);
  void indexNodes();
  void checkNodeExists(std::uint64_t node, std::uint64_t element, bool is_tet,
                       std::size_t where) const;
  void addElement(std::uint64_t tag, int type, std::size_t where);
  void checkElementTagsUnique();
  // Counts tets as their number becomes known, to refuse too many before reading them.
  void declareTets(std::uint64_t count, std::size_t where);

  const MeshFile& file_;
  const MeshReadOptions& options_;
  LineCursor lines_;
  std::vector<std::string_view> fields_;
  bool big_endian_ = kHostIsBigEndian;  // of the binary data
  bool version41_ = false;
  MshLayout layout_;
  std::size_t section_body_ = 0;  // offset where the current section's first line starts
  std::vector<std::pair<std::uint64_t, std::size_t>> node_index_;     // (tag, where)
  std::vector<std::pair<std::uint64_t, std::size_t>> element_index_;  // (tag, where)
  std::set<std::pair<int, int>> entities_;                            // (dim, tag)
  bool have_entities_ = false;
  std::uint64_t declared_tets_ = 0;
  std::uint64_t num_tets_ = 0;  // tets read so far
};

std::string_view MshPrescan::requireLine(const std::string& what) {
  std::string_view line;
  if (!lines_.next(line)) {
    throwMeshIOError(file_.name, ref(layout_.binary ? file_.bytes.size() : lines_.lineNumber()),
                     "truncated: the file ends before " + what);
  }
  return line;
}

void MshPrescan::splitLine(std::string_view line, std::size_t max_length, bool spaces_only) {
  if (line.size() > max_length) {
    fail("line of " + std::to_string(line.size()) + " characters, longer than the " +
         std::to_string(max_length) + " Gmsh reads in one piece");
  }
  if (spaces_only && line.find('\t') != std::string_view::npos) {
    fail("tab between fields; Gmsh reads these lines with spaces between fields only");
  }
  splitFields(line, fields_);
}

void MshPrescan::requireFieldCount(std::size_t count, const std::string& what) const {
  if (fields_.size() != count) {
    fail("expected " + std::to_string(count) + " fields (" + what + "), found " +
         std::to_string(fields_.size()));
  }
}

std::int64_t MshPrescan::intField(std::size_t i, std::int64_t min, std::int64_t max,
                                  const char* what) const {
  std::int64_t value = 0;
  // Gmsh scans some integer lists with "%[0-9- ]", which stops at a '+'.
  if (fields_[i].front() == '+' || !parseInteger(fields_[i], value)) {
    fail(std::string(what) + ": " + excerpt(fields_[i]) + " is not an integer");
  }
  if (value < min || value > max) {
    fail(std::string(what) + " " + std::to_string(value) + " out of range [" + std::to_string(min) +
         ", " + std::to_string(max) + "]");
  }
  return value;
}

double MshPrescan::realField(std::size_t i, const char* what) const {
  double value = 0;
  if (!parseReal(fields_[i], value)) {
    fail(std::string(what) + ": " + excerpt(fields_[i]) + " is not a number (or beyond double)");
  }
  if (!std::isfinite(value)) fail(std::string("non-finite ") + what + " " + excerpt(fields_[i]));
  return value;
}

std::uint64_t MshPrescan::declaredCount(std::size_t i, std::size_t min_record_bytes,
                                        const char* what) const {
  const std::uint64_t count =
      static_cast<std::uint64_t>(intField(i, 0, std::numeric_limits<std::int64_t>::max(), what));
  const std::size_t left = file_.bytes.size() - std::min(file_.bytes.size(), lines_.offset());
  if (count > left / min_record_bytes) {
    fail("truncated: " + std::string(what) + " " + std::to_string(count) + " cannot fit in the " +
         std::to_string(left) + " bytes left in the file");
  }
  return count;
}

std::uint64_t MshPrescan::binaryCount(ByteReader& reader, std::size_t min_record_bytes,
                                      const char* what) const {
  const std::size_t at = reader.offset();
  const std::uint64_t count = reader.read<std::uint64_t>(what);
  if (count > reader.remaining() / min_record_bytes) {
    failAtByte(at, "truncated or corrupted: " + std::string(what) + " " + std::to_string(count) +
                       " cannot fit in the " + std::to_string(reader.remaining()) +
                       " bytes left in the file");
  }
  return count;
}

MshLayout MshPrescan::run() {
  std::string_view line;
  lines_.next(line);
  if (line != "$MeshFormat") {
    throwMeshIOError(file_.name, lineRef(1),
                     "not a Gmsh mesh: expected \"$MeshFormat\", found " + excerpt(line));
  }
  scanMeshFormat();

  bool have_nodes = false;
  bool have_elements = false;
  bool have_names = false;
  while (lines_.next(line)) {
    if (line.find_first_not_of(" \t\r") == std::string_view::npos) continue;
    if (line.front() != '$') {
      fail("expected a section start (\"$Name\") between sections, found " + excerpt(line));
    }
    const std::string name(line.substr(1));
    if (name.empty() || name.size() > kMaxSectionName ||
        name.find_first_not_of("ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_") !=
            std::string::npos) {
      fail("malformed section marker " + excerpt(line));
    }
    if (name.compare(0, 3, "End") == 0) fail("$" + name + " without a matching start");
    section_body_ = lines_.offset();
    if (name == "MeshFormat") fail("second $MeshFormat section");
    if (name == "PartitionedEntities" || name == "GhostElements") {
      fail("partitioned meshes are not supported (section $" + name + ")");
    }
    if (name == "PhysicalNames") {
      if (have_names) fail("second $PhysicalNames section");
      have_names = true;
      scanPhysicalNames();
    } else if (name == "Entities" && version41_) {
      if (have_entities_ || have_nodes) fail("$Entities must come once, before $Nodes");
      have_entities_ = true;
      scanEntities41();
    } else if (name == "Nodes") {
      if (have_nodes) fail("second $Nodes section");
      have_nodes = true;
      version41_ ? scanNodes41() : scanNodes22();
      indexNodes();
    } else if (name == "Elements") {
      if (have_elements) fail("second $Elements section");
      if (!have_nodes) fail("$Elements before $Nodes");
      have_elements = true;
      version41_ ? scanElements41() : scanElements22();
      checkElementTagsUnique();
    } else {
      skipSection(name);
    }
  }
  if (!have_nodes) throwMeshIOError(file_.name, "", "no $Nodes section");
  if (!have_elements) throwMeshIOError(file_.name, "", "no $Elements section");
  return std::move(layout_);
}

void MshPrescan::expectSectionEnd(const std::string& name) {
  const std::size_t body_end = lines_.offset();
  const std::string_view line = requireLine("$End" + name);
  if (line != "$End" + name) {
    fail("expected \"$End" + name + "\" (does the section hold more or less than it declares?)" +
         ", found " + excerpt(line));
  }
  layout_.gmsh_input += "$" + name + "\n";
  layout_.gmsh_input.append(file_.bytes, section_body_, body_end - section_body_);
  layout_.gmsh_input += "$End" + name + "\n";
}

void MshPrescan::afterBinaryData(std::size_t offset) {
  // Gmsh writes a newline after each block of binary data, then the end marker.
  lines_.jump(offset, 0);
  std::string_view rest;
  if (!lines_.next(rest)) failAtByte(offset, "truncated: the file ends after binary data");
  if (!rest.empty()) {
    failAtByte(offset, "unexpected bytes after the binary data (declared counts too small?)");
  }
}

void MshPrescan::skipSection(const std::string& name) {
  // Not handed to Gmsh, so only its end matters; its content may be binary.
  const std::string marker = "\n$End" + name;
  std::size_t from = lines_.offset() - 1;
  while (true) {
    const std::size_t found = file_.bytes.find(marker, from);
    if (found == std::string::npos) fail("section $" + name + " is not closed ($End" + name + ")");
    const std::size_t after = found + marker.size();
    if (after == file_.bytes.size() || file_.bytes[after] == '\n' || file_.bytes[after] == '\r') {
      const std::size_t line = lines_.lineNumber() +
                               static_cast<std::size_t>(std::count(
                                   file_.bytes.begin() + static_cast<std::ptrdiff_t>(from),
                                   file_.bytes.begin() + static_cast<std::ptrdiff_t>(found), '\n'));
      lines_.jump(found + 1, line);
      std::string_view end_line;
      lines_.next(end_line);
      return;
    }
    from = after;
  }
}

void MshPrescan::scanMeshFormat() {
  section_body_ = lines_.offset();
  splitLine(requireLine("the mesh format line"), kMaxShortLine, false);
  requireFieldCount(3, "version, file type, data size");
  const double version = realField(0, "version");
  if (version == 4.1) {
    version41_ = true;
  } else if (version != 2.2) {
    fail("MSH version " + std::string(fields_[0]) + " is not supported (only 2.2 and 4.1)");
  }
  layout_.binary = intField(1, 0, 1, "file type (0 ASCII, 1 binary)") == 1;
  const std::int64_t data_size = intField(2, 0, 64, "data size");
  if (!layout_.binary) {
    expectSectionEnd("MeshFormat");
    return;
  }
  if (data_size != 8) fail("binary data size " + std::to_string(data_size) + ", only 8 is read");
  ByteReader reader(file_, lines_.offset(), kHostIsBigEndian);
  const std::size_t at = reader.offset();
  const std::uint32_t one = reader.read<std::uint32_t>("the binary endianness check");
  if (one == 0x01000000u) {
    big_endian_ = !kHostIsBigEndian;
  } else if (one != 1) {
    failAtByte(at, "binary endianness check is " + std::to_string(one) + ", expected 1");
  }
  afterBinaryData(reader.offset());
  expectSectionEnd("MeshFormat");
}

void MshPrescan::scanPhysicalNames() {
  splitLine(requireLine("the number of physical names"), kMaxShortLine, false);
  requireFieldCount(1, "number of physical names");
  const std::uint64_t count = declaredCount(0, kMinShortLine * 4, "number of physical names");
  for (std::uint64_t i = 0; i < count; ++i) {
    const std::string_view line = requireLine("all physical names are listed");
    splitLine(line, kMaxShortLine, false);
    if (fields_.size() < 3) fail("expected: dimension, tag, \"name\"");
    intField(0, 0, 3, "dimension");
    intField(1, INT_MIN, INT_MAX, "physical tag");
    const std::size_t open = line.find('"');
    const std::size_t close = line.rfind('"');
    if (open == std::string_view::npos || close == open ||
        line.find_first_not_of(" \t\r", close + 1) != std::string_view::npos) {
      fail("physical name is not a double-quoted string");
    }
  }
  expectSectionEnd("PhysicalNames");
}

void MshPrescan::scanEntities41() {
  if (layout_.binary) {
    ByteReader reader(file_, lines_.offset(), big_endian_);
    scanEntitiesBinary41(reader);
    afterBinaryData(reader.offset());
    expectSectionEnd("Entities");
    return;
  }
  splitLine(requireLine("the entity counts"), kMaxEntityLine, true);
  requireFieldCount(4, "numbers of points, curves, surfaces, volumes");
  std::uint64_t counts[4];
  for (std::size_t dim = 0; dim < 4; ++dim) {
    counts[dim] = declaredCount(dim, kMinNodeLine, "number of entities");
  }
  for (int dim = 0; dim < 4; ++dim) {
    for (std::uint64_t i = 0; i < counts[dim]; ++i) {
      splitLine(requireLine("all entities are listed"), kMaxEntityLine, true);
      const std::size_t reals = dim == 0 ? 3 : 6;
      if (fields_.size() < reals + 2) fail("entity line too short");
      const int tag = static_cast<int>(intField(0, 0, INT_MAX, "entity tag"));
      for (std::size_t k = 1; k <= reals; ++k) realField(k, "entity bounding box coordinate");
      std::size_t next = reals + 1;
      const std::int64_t num_physicals =
          intField(next, 0, static_cast<std::int64_t>(fields_.size()), "number of physical tags");
      for (std::int64_t k = 0; k < num_physicals; ++k) {
        if (++next >= fields_.size()) fail("entity line ends inside its physical tags");
        intField(next, INT_MIN, INT_MAX, "physical tag");
      }
      if (dim > 0) {
        if (++next >= fields_.size())
          fail("entity line ends before its number of bounding entities");
        const std::int64_t num_bounding = intField(
            next, 0, static_cast<std::int64_t>(fields_.size()), "number of bounding entities");
        for (std::int64_t k = 0; k < num_bounding; ++k) {
          if (++next >= fields_.size()) fail("entity line ends inside its bounding entities");
          const std::int64_t bounding = intField(next, -INT_MAX, INT_MAX, "bounding entity tag");
          if (!entities_.count({dim - 1, static_cast<int>(std::abs(bounding))})) {
            fail("bounding entity " + std::to_string(bounding) + " of dimension " +
                 std::to_string(dim - 1) + " is not defined");
          }
        }
      }
      if (next + 1 != fields_.size()) fail("extra fields at the end of the entity line");
      if (!entities_.insert({dim, tag}).second) {
        fail("entity " + std::to_string(tag) + " of dimension " + std::to_string(dim) +
             " defined twice");
      }
    }
  }
  expectSectionEnd("Entities");
}

void MshPrescan::scanEntitiesBinary41(ByteReader& reader) {
  // Smallest entity record: a point, int tag + 3 doubles + no physical tags.
  constexpr std::size_t kMinPointRecord = 4 + 3 * 8 + 8;
  std::uint64_t counts[4];
  for (auto& count : counts) count = binaryCount(reader, kMinPointRecord, "number of entities");
  for (int dim = 0; dim < 4; ++dim) {
    for (std::uint64_t i = 0; i < counts[dim]; ++i) {
      const std::size_t at = reader.offset();
      const std::int32_t tag = reader.read<std::int32_t>("an entity");
      if (tag < 0) failAtByte(at, "entity tag " + std::to_string(tag) + " is negative");
      for (int k = 0; k < (dim == 0 ? 3 : 6); ++k) {
        const std::size_t at_real = reader.offset();
        if (!std::isfinite(reader.read<double>("an entity bounding box"))) {
          failAtByte(at_real, "non-finite entity bounding box coordinate");
        }
      }
      const std::uint64_t num_physicals = binaryCount(reader, 4, "number of physical tags");
      reader.skip(num_physicals, 4, "physical tags");
      if (dim > 0) {
        const std::uint64_t num_bounding = binaryCount(reader, 4, "number of bounding entities");
        for (std::uint64_t k = 0; k < num_bounding; ++k) {
          const std::size_t at_bounding = reader.offset();
          const std::int32_t bounding = reader.read<std::int32_t>("bounding entities");
          if (bounding == INT_MIN || !entities_.count({dim - 1, std::abs(bounding)})) {
            failAtByte(at_bounding, "bounding entity " + std::to_string(bounding) +
                                        " of dimension " + std::to_string(dim - 1) +
                                        " is not defined");
          }
        }
      }
      if (!entities_.insert({dim, tag}).second) {
        failAtByte(at, "entity " + std::to_string(tag) + " of dimension " + std::to_string(dim) +
                           " defined twice");
      }
    }
  }
}

void MshPrescan::addNode(std::uint64_t tag, std::size_t where) {
  layout_.node_tags.push_back(tag);
  node_index_.emplace_back(tag, where);
}

void MshPrescan::indexNodes() {
  if (layout_.node_tags.size() > static_cast<std::size_t>(INT_MAX)) {
    throwMeshIOError(file_.name, "", "more nodes than a mesh here can index");
  }
  std::sort(node_index_.begin(), node_index_.end());
  for (std::size_t i = 1; i < node_index_.size(); ++i) {
    if (node_index_[i].first == node_index_[i - 1].first) {
      const std::size_t later = std::max(node_index_[i].second, node_index_[i - 1].second);
      throwMeshIOError(file_.name, ref(later),
                       "node tag " + std::to_string(node_index_[i].first) + " defined twice");
    }
  }
}

void MshPrescan::checkNodeExists(std::uint64_t node, std::uint64_t element, bool is_tet,
                                 std::size_t where) const {
  const auto it = std::lower_bound(node_index_.begin(), node_index_.end(),
                                   std::make_pair(node, std::size_t{0}));
  if (it != node_index_.end() && it->first == node) return;
  const std::string what =
      is_tet ? "tet " + std::to_string(num_tets_ - 1) + " (element " + std::to_string(element) + ")"
             : "element " + std::to_string(element);
  throwMeshIOError(
      file_.name, ref(where),
      what + ": node tag " + std::to_string(node) + " out of range (no node has this tag)");
}

void MshPrescan::addElement(std::uint64_t tag, int type, std::size_t where) {
  element_index_.emplace_back(tag, where);
  if (type == kMshLinearTet || type == kMshQuadraticTet) layout_.tet_tags.push_back(tag);
}

void MshPrescan::declareTets(std::uint64_t count, std::size_t where) {
  declared_tets_ += count;
  if (declared_tets_ > options_.max_tets) {
    throwTetLimit(file_.name, ref(where), declared_tets_, options_);
  }
}

void MshPrescan::checkElementTagsUnique() {
  std::sort(element_index_.begin(), element_index_.end());
  for (std::size_t i = 1; i < element_index_.size(); ++i) {
    if (element_index_[i].first == element_index_[i - 1].first) {
      const std::size_t later = std::max(element_index_[i].second, element_index_[i - 1].second);
      throwMeshIOError(file_.name, ref(later),
                       "element tag " + std::to_string(element_index_[i].first) + " used twice");
    }
  }
  std::vector<std::pair<std::uint64_t, std::size_t>>().swap(element_index_);
}

void MshPrescan::scanNodes22() {
  splitLine(requireLine("the number of nodes"), kMaxShortLine, false);
  requireFieldCount(1, "number of nodes");
  const std::uint64_t count =
      declaredCount(0, layout_.binary ? 4 + 3 * 8 : kMinNodeLine, "number of nodes");
  layout_.node_tags.reserve(count);
  node_index_.reserve(count);
  if (layout_.binary) {
    ByteReader reader(file_, lines_.offset(), big_endian_);
    for (std::uint64_t i = 0; i < count; ++i) {
      const std::size_t at = reader.offset();
      const std::int32_t tag = reader.read<std::int32_t>("the nodes");
      if (tag < 0) failAtByte(at, "node tag " + std::to_string(tag) + " is negative");
      for (int k = 0; k < 3; ++k) {
        if (!std::isfinite(reader.read<double>("the nodes"))) {
          failAtByte(at, "node " + std::to_string(tag) + ": non-finite coordinate");
        }
      }
      addNode(static_cast<std::uint64_t>(tag), at);
    }
    afterBinaryData(reader.offset());
  } else {
    for (std::uint64_t i = 0; i < count; ++i) {
      splitLine(requireLine("all " + std::to_string(count) + " nodes are listed"), SIZE_MAX, false);
      requireFieldCount(4, "node tag, x, y, z");
      const std::int64_t tag = intField(0, 0, INT_MAX, "node tag");
      for (std::size_t k = 1; k <= 3; ++k) realField(k, "coordinate");
      addNode(static_cast<std::uint64_t>(tag), lines_.lineNumber());
    }
  }
  expectSectionEnd("Nodes");
}

void MshPrescan::scanElements22() {
  splitLine(requireLine("the number of elements"), kMaxShortLine, false);
  requireFieldCount(1, "number of elements");
  const std::uint64_t count =
      declaredCount(0, layout_.binary ? 3 * 4 : kMinElementLine, "number of elements");
  element_index_.reserve(count);
  if (layout_.binary) {
    ByteReader reader(file_, lines_.offset(), big_endian_);
    std::uint64_t seen = 0;
    while (seen < count) {
      const std::size_t at = reader.offset();
      const std::int32_t type_code = reader.read<std::int32_t>("an element block header");
      const std::int32_t block_size = reader.read<std::int32_t>("an element block header");
      const std::int32_t num_tags = reader.read<std::int32_t>("an element block header");
      const MshElementType* type = findElementType(type_code);
      if (!type) failAtByte(at, "unknown or unsupported element type " + std::to_string(type_code));
      if (block_size <= 0 || static_cast<std::uint64_t>(block_size) > count - seen) {
        failAtByte(at, "element block of " + std::to_string(block_size) + " elements, but " +
                           std::to_string(count - seen) + " of the declared elements are left");
      }
      if (num_tags < 0 || num_tags > 2) {
        failAtByte(at, std::to_string(num_tags) +
                           " tags per element; only physical and elementary tags are supported");
      }
      const std::size_t record = 1 + static_cast<std::size_t>(num_tags + type->nodes);
      reader.require(static_cast<std::uint64_t>(block_size) * record, 4, "an element block");
      const bool is_tet = type->type == kMshLinearTet || type->type == kMshQuadraticTet;
      if (is_tet) declareTets(static_cast<std::uint64_t>(block_size), at);
      for (std::int32_t e = 0; e < block_size; ++e) {
        const std::size_t at_element = reader.offset();
        const std::int32_t tag = reader.read<std::int32_t>("an element");
        if (tag < 0) failAtByte(at_element, "element tag " + std::to_string(tag) + " is negative");
        if (num_tags == 2) reader.read<std::int32_t>("an element");
        if (num_tags >= 1) {
          const std::int32_t elementary = reader.read<std::int32_t>("an element");
          if (num_tags == 2 && elementary < 0) {
            failAtByte(at_element, "negative elementary tag " + std::to_string(elementary));
          }
        }
        if (is_tet) ++num_tets_;
        for (int k = 0; k < type->nodes; ++k) {
          const std::int32_t node = reader.read<std::int32_t>("an element");
          if (node < 0)
            failAtByte(at_element, "node tag " + std::to_string(node) + " out of range");
          checkNodeExists(static_cast<std::uint64_t>(node), static_cast<std::uint64_t>(tag), is_tet,
                          at_element);
        }
        addElement(static_cast<std::uint64_t>(tag), type->type, at_element);
      }
      seen += static_cast<std::uint64_t>(block_size);
    }
    afterBinaryData(reader.offset());
  } else {
    for (std::uint64_t i = 0; i < count; ++i) {
      splitLine(requireLine("all " + std::to_string(count) + " elements are listed"), SIZE_MAX,
                false);
      if (fields_.size() < 3) fail("expected: element tag, type, number of tags, ...");
      const std::int64_t tag = intField(0, 0, INT_MAX, "element tag");
      const MshElementType* type = findElementType(intField(1, 0, INT_MAX, "element type"));
      if (!type) fail("unknown or unsupported element type " + std::string(fields_[1]));
      const std::int64_t num_tags = intField(2, 0, INT_MAX, "number of tags");
      if (num_tags > 2) {
        fail(std::to_string(num_tags) +
             " tags; only physical and elementary tags are supported (no partitions)");
      }
      requireFieldCount(3 + static_cast<std::size_t>(num_tags + type->nodes),
                        "tag, type, tags and " + std::to_string(type->nodes) + " nodes");
      if (num_tags >= 1) intField(3, INT_MIN, INT_MAX, "physical tag");
      // Gmsh silently drops elements with a negative elementary tag.
      if (num_tags == 2) intField(4, 0, INT_MAX, "elementary tag");
      const bool is_tet = type->type == kMshLinearTet || type->type == kMshQuadraticTet;
      if (is_tet) {
        declareTets(1, lines_.lineNumber());
        ++num_tets_;
      }
      for (int k = 0; k < type->nodes; ++k) {
        const std::int64_t node =
            intField(3 + static_cast<std::size_t>(num_tags + k), 0, INT_MAX, "node tag");
        checkNodeExists(static_cast<std::uint64_t>(node), static_cast<std::uint64_t>(tag), is_tet,
                        lines_.lineNumber());
      }
      addElement(static_cast<std::uint64_t>(tag), type->type, lines_.lineNumber());
    }
  }
  expectSectionEnd("Elements");
}

MshPrescan::BlocksHeader41 MshPrescan::readBlocksHeader41(ByteReader& reader,
                                                          const std::string& kind,
                                                          std::size_t binary_record_bytes,
                                                          std::size_t text_record_bytes) {
  // The header of a 4.1 $Nodes or $Elements section: blocks, count, min tag, max tag.
  constexpr std::int64_t kMaxTag = std::numeric_limits<std::int64_t>::max();
  BlocksHeader41 h;
  if (layout_.binary) {
    h.header_at = reader.offset();
    h.num_blocks = binaryCount(reader, 4 * 3 + 8, ("number of " + kind + " blocks").c_str());
    h.count = binaryCount(reader, binary_record_bytes, ("number of " + kind + "s").c_str());
    h.min_tag = reader.read<std::uint64_t>(("the " + kind + " section header").c_str());
    h.max_tag = reader.read<std::uint64_t>(("the " + kind + " section header").c_str());
  } else {
    splitLine(requireLine(("the " + kind + " section header").c_str()), kMaxShortLine, false);
    h.header_at = lines_.lineNumber();
    requireFieldCount(4, ("blocks, " + kind + "s, min tag, max tag").c_str());
    h.num_blocks = declaredCount(0, kMinNodeLine, ("number of " + kind + " blocks").c_str());
    h.count = declaredCount(1, text_record_bytes, ("number of " + kind + "s").c_str());
    h.min_tag =
        static_cast<std::uint64_t>(intField(2, 0, kMaxTag, ("min " + kind + " tag").c_str()));
    h.max_tag =
        static_cast<std::uint64_t>(intField(3, 0, kMaxTag, ("max " + kind + " tag").c_str()));
  }
  return h;
}

void MshPrescan::closeBlocks41(const BlocksHeader41& h, const std::string& kind, std::uint64_t seen,
                               std::uint64_t lowest, std::uint64_t highest,
                               const ByteReader& reader, const std::string& section) {
  // The blocks must hold what the header declared, tags included.
  if (seen != h.count) {
    throwMeshIOError(file_.name, ref(h.header_at),
                     "the section header declares " + std::to_string(h.count) + " " + kind +
                         "s, the blocks hold " + std::to_string(seen));
  }
  if (h.count > 0 && (lowest != h.min_tag || highest != h.max_tag)) {
    throwMeshIOError(file_.name, ref(h.header_at),
                     "declared " + kind + " tag range [" + std::to_string(h.min_tag) + ", " +
                         std::to_string(h.max_tag) + "] differs from the tags present [" +
                         std::to_string(lowest) + ", " + std::to_string(highest) + "]");
  }
  if (layout_.binary) afterBinaryData(reader.offset());
  expectSectionEnd(section);
}

void MshPrescan::scanNodes41() {
  constexpr std::int64_t kMaxTag = std::numeric_limits<std::int64_t>::max();
  ByteReader reader(file_, lines_.offset(), big_endian_);
  const BlocksHeader41 h = readBlocksHeader41(reader, "node", 8 + 3 * 8, kMinNodeLine);
  const std::uint64_t num_blocks = h.num_blocks, num_nodes = h.count;
  layout_.node_tags.reserve(num_nodes);
  node_index_.reserve(num_nodes);

  std::uint64_t seen = 0;
  std::uint64_t lowest = UINT64_MAX;
  std::uint64_t highest = 0;
  for (std::uint64_t b = 0; b < num_blocks; ++b) {
    int dim = 0;
    int entity = 0;
    bool parametric = false;
    std::uint64_t block_size = 0;
    std::size_t block_at = 0;
    if (layout_.binary) {
      block_at = reader.offset();
      dim = reader.read<std::int32_t>("a node block header");
      entity = reader.read<std::int32_t>("a node block header");
      const std::int32_t parametric_flag = reader.read<std::int32_t>("a node block header");
      block_size = binaryCount(reader, 8 + 3 * 8, "number of nodes in the block");
      if (dim < 0 || dim > 3 || entity < 0 || (parametric_flag != 0 && parametric_flag != 1)) {
        failAtByte(block_at, "node block header: dimension " + std::to_string(dim) + ", entity " +
                                 std::to_string(entity) + ", parametric " +
                                 std::to_string(parametric_flag) + " out of range");
      }
      parametric = parametric_flag == 1;
    } else {
      splitLine(requireLine("all node blocks are listed"), kMaxShortLine, false);
      block_at = lines_.lineNumber();
      requireFieldCount(4, "entity dimension, entity tag, parametric, number of nodes");
      dim = static_cast<int>(intField(0, 0, 3, "entity dimension"));
      entity = static_cast<int>(intField(1, 0, INT_MAX, "entity tag"));
      parametric = intField(2, 0, 1, "parametric flag") == 1;
      block_size = declaredCount(3, 2 * kMinShortLine, "number of nodes in the block");
    }
    if (block_size > num_nodes - seen) {
      throwMeshIOError(file_.name, ref(block_at),
                       "node blocks hold more than the " + std::to_string(num_nodes) +
                           " nodes the section header declares");
    }
    entities_.insert({dim, entity});
    const std::size_t num_coordinates = 3 + (parametric ? static_cast<std::size_t>(dim) : 0);
    const std::size_t first = layout_.node_tags.size();
    if (layout_.binary) {
      reader.require(block_size, 8 * (1 + num_coordinates), "a node block");
      for (std::uint64_t i = 0; i < block_size; ++i) {
        const std::size_t at = reader.offset();
        const std::uint64_t tag = reader.read<std::uint64_t>("a node block");
        if (tag == 0 || tag > static_cast<std::uint64_t>(kMaxTag)) {
          failAtByte(at, "node tag " + std::to_string(tag) + " out of range");
        }
        addNode(tag, at);
      }
      for (std::uint64_t i = 0; i < block_size; ++i) {
        const std::size_t at = reader.offset();
        for (std::size_t k = 0; k < num_coordinates; ++k) {
          if (!std::isfinite(reader.read<double>("a node block"))) {
            failAtByte(at, "node " + std::to_string(layout_.node_tags[first + i]) +
                               ": non-finite coordinate");
          }
        }
      }
    } else {
      for (std::uint64_t i = 0; i < block_size; ++i) {
        splitLine(requireLine("all node tags of the block are listed"), kMaxShortLine, false);
        requireFieldCount(1, "node tag");
        addNode(static_cast<std::uint64_t>(intField(0, 1, kMaxTag, "node tag")),
                lines_.lineNumber());
      }
      for (std::uint64_t i = 0; i < block_size; ++i) {
        splitLine(requireLine("all node coordinates of the block are listed"), SIZE_MAX, false);
        requireFieldCount(num_coordinates,
                          parametric ? "x, y, z, parametric coordinates" : "x, y, z");
        for (std::size_t k = 0; k < num_coordinates; ++k) realField(k, "coordinate");
      }
    }
    for (std::size_t i = first; i < layout_.node_tags.size(); ++i) {
      lowest = std::min(lowest, layout_.node_tags[i]);
      highest = std::max(highest, layout_.node_tags[i]);
    }
    seen += block_size;
  }
  closeBlocks41(h, "node", seen, lowest, highest, reader, "Nodes");
}

void MshPrescan::scanElements41() {
  constexpr std::int64_t kMaxTag = std::numeric_limits<std::int64_t>::max();
  ByteReader reader(file_, lines_.offset(), big_endian_);
  const BlocksHeader41 h = readBlocksHeader41(reader, "element", 2 * 8, 4);
  const std::uint64_t num_blocks = h.num_blocks, num_elements = h.count;
  element_index_.reserve(num_elements);

  std::uint64_t seen = 0;
  std::uint64_t lowest = UINT64_MAX;
  std::uint64_t highest = 0;
  for (std::uint64_t b = 0; b < num_blocks; ++b) {
    std::int64_t dim = 0;
    std::int64_t entity = 0;
    std::int64_t type_code = 0;
    std::uint64_t block_size = 0;
    std::size_t block_at = 0;
    if (layout_.binary) {
      block_at = reader.offset();
      dim = reader.read<std::int32_t>("an element block header");
      entity = reader.read<std::int32_t>("an element block header");
      type_code = reader.read<std::int32_t>("an element block header");
      block_size = binaryCount(reader, 2 * 8, "number of elements in the block");
    } else {
      splitLine(requireLine("all element blocks are listed"), kMaxShortLine, false);
      block_at = lines_.lineNumber();
      requireFieldCount(4, "entity dimension, entity tag, element type, number of elements");
      dim = intField(0, 0, 3, "entity dimension");
      entity = intField(1, 0, INT_MAX, "entity tag");
      type_code = intField(2, 0, INT_MAX, "element type");
      block_size = declaredCount(3, 4, "number of elements in the block");
    }
    const MshElementType* type = findElementType(type_code);
    if (!type) {
      throwMeshIOError(file_.name, ref(block_at),
                       "unknown or unsupported element type " + std::to_string(type_code));
    }
    if (dim != type->dim || !entities_.count({static_cast<int>(dim), static_cast<int>(entity)})) {
      throwMeshIOError(file_.name, ref(block_at),
                       "element block of dimension " + std::to_string(type->dim) +
                           " elements on entity " + std::to_string(entity) + " of dimension " +
                           std::to_string(dim) +
                           ", which is not a defined entity of that "
                           "dimension");
    }
    if (block_size > num_elements - seen) {
      throwMeshIOError(file_.name, ref(block_at),
                       "element blocks hold more than the " + std::to_string(num_elements) +
                           " elements the section header declares");
    }
    const bool is_tet = type->type == kMshLinearTet || type->type == kMshQuadraticTet;
    if (is_tet) declareTets(block_size, block_at);
    const std::size_t nodes = static_cast<std::size_t>(type->nodes);
    if (layout_.binary) {
      reader.require(block_size, 8 * (1 + nodes), "an element block");
      for (std::uint64_t e = 0; e < block_size; ++e) {
        const std::size_t at = reader.offset();
        const std::uint64_t tag = reader.read<std::uint64_t>("an element block");
        if (tag == 0 || tag > static_cast<std::uint64_t>(kMaxTag)) {
          failAtByte(at, "element tag " + std::to_string(tag) + " out of range");
        }
        if (is_tet) ++num_tets_;
        for (std::size_t k = 0; k < nodes; ++k) {
          checkNodeExists(reader.read<std::uint64_t>("an element block"), tag, is_tet, at);
        }
        addElement(tag, type->type, at);
        lowest = std::min(lowest, tag);
        highest = std::max(highest, tag);
      }
    } else {
      for (std::uint64_t e = 0; e < block_size; ++e) {
        const std::string_view line = requireLine("all elements of the block are listed");
        // Gmsh scans the node list of these lines with "%[0-9- ]".
        if (line.find_first_not_of("0123456789 ") != std::string_view::npos) {
          fail("element line holds something other than digits and spaces");
        }
        splitLine(line, kMaxElementLine, true);
        requireFieldCount(1 + nodes, "element tag and " + std::to_string(nodes) + " node tags");
        const std::uint64_t tag =
            static_cast<std::uint64_t>(intField(0, 1, kMaxTag, "element tag"));
        if (is_tet) ++num_tets_;
        for (std::size_t k = 0; k < nodes; ++k) {
          checkNodeExists(static_cast<std::uint64_t>(intField(1 + k, 0, kMaxTag, "node tag")), tag,
                          is_tet, lines_.lineNumber());
        }
        addElement(tag, type->type, lines_.lineNumber());
        lowest = std::min(lowest, tag);
        highest = std::max(highest, tag);
      }
    }
    seen += block_size;
  }
  closeBlocks41(h, "element", seen, lowest, highest, reader, "Elements");
}

}  // namespace

MshLayout prescanGmshMesh(const MeshFile& file, const MeshReadOptions& options) {
  return MshPrescan(file, options).run();
}

}  // namespace tissue_cut::mesh_io
