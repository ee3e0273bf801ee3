#include "mesh_file.hpp"

#include <cctype>
#include <cerrno>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <system_error>

#include "tissue_cut/mesh/mesh_io.hpp"

namespace tissue_cut::mesh_io {

std::string displayName(const std::string& path) {
  const std::string name = std::filesystem::path(path).filename().string();
  return name.empty() ? path : name;
}

MeshFile loadMeshFile(const std::string& path, std::size_t max_bytes) {
  MeshFile file;
  file.path = path;
  file.name = displayName(path);
  std::error_code error;
  const auto status = std::filesystem::status(path, error);
  if (!std::filesystem::exists(status)) {
    throwMeshIOError(file.name, "", "cannot open: no such file");
  }
  if (!std::filesystem::is_regular_file(status)) {
    throwMeshIOError(file.name, "", "cannot open: not a regular file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    throwMeshIOError(file.name, "", std::string("cannot open: ") + std::strerror(errno));
  }
  const std::uintmax_t size = std::filesystem::file_size(path, error);
  if (error) throwMeshIOError(file.name, "", "cannot read the file size: " + error.message());
  if (size == 0) throwMeshIOError(file.name, "", "empty file");
  if (size > max_bytes) {
    throwMeshIOError(file.name, "",
                     "file is " + std::to_string(size) + " bytes, more than the " +
                         std::to_string(max_bytes) + " bytes a mesh within the tet limit needs");
  }
  file.bytes.resize(static_cast<std::size_t>(size));
  in.read(file.bytes.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uintmax_t>(in.gcount()) != size) {
    throwMeshIOError(file.name, "", "read error (file changed while being read?)");
  }
  return file;
}

void throwMeshIOError(const std::string& name, const std::string& where, const std::string& what) {
  throw MeshIOError(where.empty() ? name + ": " + what : name + ": " + where + ": " + what);
}

std::string lineRef(std::size_t line) { return "line " + std::to_string(line); }

std::string byteRef(std::size_t offset) { return "byte offset " + std::to_string(offset); }

bool parseInteger(std::string_view token, std::int64_t& value) {
  if (!token.empty() && token.front() == '+') token.remove_prefix(1);
  if (token.empty() || token.front() == '+') return false;
  const char* end = token.data() + token.size();
  const auto result = std::from_chars(token.data(), end, value);
  return result.ec == std::errc() && result.ptr == end;
}

bool parseReal(std::string_view token, double& value) {
  // from_chars does not take the '+' that printf-style writers may emit.
  if (token.size() > 1 && token.front() == '+' &&
      (std::isdigit(static_cast<unsigned char>(token[1])) || token[1] == '.')) {
    token.remove_prefix(1);
  }
  if (token.empty()) return false;
  const char* end = token.data() + token.size();
  const auto result = std::from_chars(token.data(), end, value, std::chars_format::general);
  return result.ec == std::errc() && result.ptr == end;
}

void splitFields(std::string_view line, std::vector<std::string_view>& fields) {
  fields.clear();
  constexpr std::string_view kBlanks = " \t\r\f\v";
  std::size_t pos = line.find_first_not_of(kBlanks);
  while (pos != std::string_view::npos) {
    std::size_t end = line.find_first_of(kBlanks, pos);
    if (end == std::string_view::npos) end = line.size();
    fields.push_back(line.substr(pos, end - pos));
    pos = line.find_first_not_of(kBlanks, end);
  }
}

bool LineCursor::next(std::string_view& line) {
  if (next_ >= bytes_.size()) return false;
  start_ = next_;
  std::size_t end = bytes_.find('\n', next_);
  if (end == std::string_view::npos) end = bytes_.size();
  line = bytes_.substr(next_, end - next_);
  if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
  next_ = end + 1;
  ++line_;
  return true;
}

void ByteReader::require(std::uint64_t count, std::size_t size, const std::string& what) const {
  if (!has(count, size)) {
    throwMeshIOError(file_.name, byteRef(offset_),
                     "truncated: the file ends inside " + what + " (" + std::to_string(count) +
                         " x " + std::to_string(size) + " bytes needed, " +
                         std::to_string(remaining()) + " left)");
  }
}

bool equalsIgnoringCase(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (std::tolower(static_cast<unsigned char>(a[i])) !=
        std::tolower(static_cast<unsigned char>(b[i]))) {
      return false;
    }
  }
  return true;
}

std::string excerpt(std::string_view text) {
  constexpr std::size_t kMaxShown = 40;
  std::string shown;
  for (std::size_t i = 0; i < text.size() && i < kMaxShown; ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    shown += (c >= 0x20 && c < 0x7f) ? static_cast<char>(c) : '?';
  }
  if (text.size() > kMaxShown) shown += "...";
  return "\"" + shown + "\"";
}

void appendReal(std::string& out, double value) {
  char buffer[32];
  const auto result =
      std::to_chars(buffer, buffer + sizeof(buffer), value, std::chars_format::general, 17);
  out.append(buffer, result.ptr);
}

void appendInteger(std::string& out, std::int64_t value) {
  char buffer[24];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out.append(buffer, result.ptr);
}

void writeWholeFile(const std::string& path, std::string_view contents) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  if (!out) {
    throwMeshIOError(displayName(path), "", std::string("cannot write: ") + std::strerror(errno));
  }
  out.write(contents.data(), static_cast<std::streamsize>(contents.size()));
  out.close();
  if (!out) throwMeshIOError(displayName(path), "", "write error (disk full?)");
}

}  // namespace tissue_cut::mesh_io
