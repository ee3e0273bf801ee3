// What every mesh reader needs: the whole file in memory, error messages that start with the
// file name and say where, strict number parsing, and bounds-checked line and byte cursors.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace tissue_cut::mesh_io {

/// A mesh file read into memory in one piece, so that every later access is a bounds check
/// against bytes.size() instead of a stream state.
struct MeshFile {
  std::string path;
  std::string name;  ///< basename, what error messages start with
  std::string bytes;
};

/// The basename of `path`, as shown in error messages.
std::string displayName(const std::string& path);

/// Reads a whole file. Refuses a missing, unreadable, empty or implausibly large file (larger
/// than `max_bytes`, which keeps a wrong path from pulling gigabytes into memory).
MeshFile loadMeshFile(const std::string& path, std::size_t max_bytes);

/// Throws MeshIOError "<name>: <where>: <what>" (without the middle part when `where` is empty).
[[noreturn]] void throwMeshIOError(const std::string& name, const std::string& where,
                                   const std::string& what);

std::string lineRef(std::size_t line);    ///< "line 12"
std::string byteRef(std::size_t offset);  ///< "byte offset 1234"

/// Whole-token integer: optional '-' or '+', then decimal digits, nothing else.
bool parseInteger(std::string_view token, std::int64_t& value);
/// Whole-token decimal floating-point number in C syntax; "inf" and "nan" parse (the caller
/// reports them as non-finite), numbers beyond the range of double do not.
bool parseReal(std::string_view token, double& value);

/// Splits at spaces, tabs and carriage returns.
void splitFields(std::string_view line, std::vector<std::string_view>& fields);

/// Walks the lines of a file in memory. Lines are returned without "\n" or "\r\n".
class LineCursor {
 public:
  explicit LineCursor(std::string_view bytes, std::size_t offset = 0, std::size_t line = 0)
      : bytes_(bytes), next_(offset), line_(line) {}

  /// False at the end of the data.
  bool next(std::string_view& line);
  bool atEnd() const { return next_ >= bytes_.size(); }
  /// 1-based number of the line last returned (counting from where the cursor started).
  std::size_t lineNumber() const { return line_; }
  /// Offset of the first byte of the line last returned.
  std::size_t lineStart() const { return start_; }
  /// Offset where the next line starts.
  std::size_t offset() const { return next_; }
  /// Continues at `offset`, e.g. after a block of binary data; `line` is the line number the
  /// next line will have.
  void jump(std::size_t offset, std::size_t line) {
    next_ = offset;
    line_ = line;
  }

 private:
  std::string_view bytes_;
  std::size_t next_;
  std::size_t start_ = 0;
  std::size_t line_;
};

constexpr bool kHostIsBigEndian = __BYTE_ORDER__ == __ORDER_BIG_ENDIAN__;

/// Reads fixed-size binary values with a bounds check on every access; a read past the end
/// throws MeshIOError "<name>: byte offset N: file ends inside <what>".
class ByteReader {
 public:
  ByteReader(const MeshFile& file, std::size_t offset, bool big_endian)
      : file_(file), offset_(offset), swap_(big_endian != kHostIsBigEndian) {}

  std::size_t offset() const { return offset_; }
  std::size_t remaining() const {
    return offset_ < file_.bytes.size() ? file_.bytes.size() - offset_ : 0;
  }
  /// Whether `count` values of `size` bytes are left, without overflowing count * size.
  bool has(std::uint64_t count, std::size_t size) const { return count <= remaining() / size; }
  /// Throws unless `count` values of `size` bytes are left.
  void require(std::uint64_t count, std::size_t size, const std::string& what) const;

  template <typename T>
  T read(const char* what) {
    require(1, sizeof(T), what);
    unsigned char raw[sizeof(T)];
    std::memcpy(raw, file_.bytes.data() + offset_, sizeof(T));
    if (swap_) {
      for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(raw[i], raw[sizeof(T) - 1 - i]);
    }
    T value;
    std::memcpy(&value, raw, sizeof(T));
    offset_ += sizeof(T);
    return value;
  }

  void skip(std::uint64_t count, std::size_t size, const char* what) {
    require(count, size, what);
    offset_ += static_cast<std::size_t>(count) * size;
  }

 private:
  const MeshFile& file_;
  std::size_t offset_;
  bool swap_;
};

/// Case-insensitive ASCII comparison.
bool equalsIgnoringCase(std::string_view a, std::string_view b);

/// `text` cut to a length that is readable inside an error message.
std::string excerpt(std::string_view text);

/// Appends `value` as printf("%.17g") would, but independent of the C locale, so that every
/// double reads back bit for bit.
void appendReal(std::string& out, double value);
void appendInteger(std::string& out, std::int64_t value);

/// Writes `contents` to `path`, replacing the file; throws MeshIOError naming the file.
void writeWholeFile(const std::string& path, std::string_view contents);

}  // namespace tissue_cut::mesh_io
