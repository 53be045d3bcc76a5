#include "raylab/mesh_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#ifdef _WIN32
#include <io.h>

#include <filesystem>
#else
#include <unistd.h>
#endif

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string_view>
#include <system_error>
#include <vector>

namespace raylab {

namespace {

// The whole file is held in memory while it is read. 1 GiB is a hundred times the largest shipped mesh,
// and since a `v` line takes at least 8 bytes, no file within it has more vertices than a uint32 counts.
constexpr uint64_t kMaxFileBytes = uint64_t(1) << 30;
constexpr const char* kMaxFileText = "1 GiB";

// Messages become Python str: bytes that are not UTF-8, and control characters, are shown as \xNN.
std::string shown(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  const auto escape = [&out](unsigned char c) {
    constexpr char kHex[] = "0123456789abcdef";
    out += "\\x";
    out += kHex[c >> 4];
    out += kHex[c & 15];
  };
  size_t i = 0;
  while (i < text.size()) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c >= 0x20 && c < 0x7f) {
      out += char(c);
      ++i;
      continue;
    }
    // The length of a well-formed UTF-8 sequence starting here (RFC 3629), 0 if there is none.
    size_t length = 0;
    unsigned char low = 0x80, high = 0xbf;  // the range of the second byte
    if (c >= 0xc2 && c <= 0xdf) length = 2;
    else if (c >= 0xe0 && c <= 0xef) length = 3, low = c == 0xe0 ? 0xa0 : 0x80, high = c == 0xed ? 0x9f : 0xbf;
    else if (c >= 0xf0 && c <= 0xf4) length = 4, low = c == 0xf0 ? 0x90 : 0x80, high = c == 0xf4 ? 0x8f : 0xbf;
    bool valid = length > 0 && i + length <= text.size();
    for (size_t k = 1; valid && k < length; ++k) {
      const unsigned char b = static_cast<unsigned char>(text[i + k]);
      valid = k == 1 ? (b >= low && b <= high) : (b >= 0x80 && b <= 0xbf);
    }
    if (valid) {
      out.append(text.substr(i, length));
      i += length;
    } else {
      escape(c);
      ++i;
    }
  }
  return out;
}

std::string cannot_read(const std::string& path, const std::string& why) {
  return "cannot read mesh '" + shown(path) + "': " + why;
}

#ifdef _WIN32
// Windows: the path is UTF-8 (as Python's str arrives), so the wide API; binary mode, or the C library
// would drop every \r and stop at a ^Z; 64-bit sizes (struct stat's are 32 bits). It has no FIFOs in the
// file system, and a directory does not open: it fails with EACCES.
using FileInfo = struct _stat64;
#define S_ISSOCK(mode) false
int open_for_reading(const std::string& path) {
  const int fd = ::_wopen(std::filesystem::u8path(path).c_str(), _O_RDONLY | _O_BINARY);
  FileInfo info{};
  if (fd < 0 && errno == EACCES && ::_wstat64(std::filesystem::u8path(path).c_str(), &info) == 0 &&
      S_ISDIR(info.st_mode))
    throw std::invalid_argument(cannot_read(path, "it is a directory"));
  return fd;
}
int file_info(int fd, FileInfo& info) { return ::_fstat64(fd, &info); }
#else
using FileInfo = struct stat;
// O_NONBLOCK lets a FIFO open without waiting for a writer, so that fstat can refuse it.
int open_for_reading(const std::string& path) { return ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC); }
int file_info(int fd, FileInfo& info) { return ::fstat(fd, &info); }
#endif

const char* file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a directory";
  if (S_ISFIFO(mode)) return "a FIFO";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

// Only a regular file is read: a FIFO or a device (/dev/zero) could block or never end.
std::string read_file(const std::string& path) {
  // open() would stop at a NUL and open another file than the one named.
  if (path.find('\0') != std::string::npos)
    throw std::invalid_argument("mesh path contains a NUL character: '" + shown(path.c_str()) + "\\0...'");
  const int fd = open_for_reading(path);
  if (fd < 0) throw std::runtime_error(cannot_read(path, std::strerror(errno)));
  struct Closer {
    int fd;
    ~Closer() { ::close(fd); }
  } closer{fd};
  FileInfo info{};
  if (file_info(fd, info) != 0) throw std::runtime_error(cannot_read(path, std::strerror(errno)));
  if (!S_ISREG(info.st_mode))
    throw std::invalid_argument(cannot_read(path, std::string("it is ") + file_kind(info.st_mode)));
  const auto too_big = [&path](uint64_t bytes) {
    return std::invalid_argument(cannot_read(
        path, "it has " + std::to_string(bytes) + " bytes, more than the " + kMaxFileText + " a mesh file may have"));
  };
  if (uint64_t(info.st_size) > kMaxFileBytes) throw too_big(uint64_t(info.st_size));

  // One byte more than fstat said, to see a file that grew since.
  std::string text(size_t(info.st_size) + 1, '\0');
  size_t length = 0;
  while (true) {
    if (length == text.size()) {
      if (text.size() > kMaxFileBytes) throw too_big(text.size());
      text.resize(std::min<uint64_t>(2 * text.size(), kMaxFileBytes + 1));
    }
    const ssize_t n = ::read(fd, text.data() + length, text.size() - length);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) throw std::runtime_error(cannot_read(path, std::strerror(errno)));
    if (n == 0) break;
    length += size_t(n);
  }
  text.resize(length);
  return text;
}

// --- OBJ text ------------------------------------------------------------------------------------------

bool is_blank(char c) { return c == ' ' || c == '\t'; }

std::string quoted(std::string_view token) {
  constexpr size_t kLongest = 40;  // a token of a binary file can be the whole file
  std::string text = "'";
  text.append(shown(token.substr(0, kLongest)));
  text.append(token.size() > kLongest ? "...'" : "'");
  return text;
}

// The lines of an OBJ file, numbered from 1, split as tinyobjloader split them: \r\n, \n or a lone \r
// ends a line; each line is split into tokens at spaces and tabs.
class Lines {
 public:
  explicit Lines(std::string_view text) : text_(text) {}

  // The next line's tokens after its keyword ("v", "f", ...); false at the end of the text.
  bool next() {
    if (pos_ >= text_.size()) return false;
    ++number_;
    size_t end = pos_;
    while (end < text_.size() && text_[end] != '\n' && text_[end] != '\r') ++end;
    line_ = text_.substr(pos_, end - pos_);
    pos_ = end + (text_.compare(end, 2, "\r\n") == 0 ? 2 : 1);
    at_ = 0;
    keyword_ = token();
    return true;
  }

  size_t number() const { return number_; }
  // A statement is its keyword followed by a blank ("v" alone is not a vertex, as for tinyobjloader).
  bool is(std::string_view keyword) const { return keyword_ == keyword && keyword_.end() < line_.end(); }

  // The next token of the line, empty at its end.
  std::string_view token() {
    while (at_ < line_.size() && is_blank(line_[at_])) ++at_;
    const size_t start = at_;
    while (at_ < line_.size() && !is_blank(line_[at_])) ++at_;
    return line_.substr(start, at_ - start);
  }

 private:
  std::string_view text_, line_, keyword_;
  size_t pos_ = 0, at_ = 0, number_ = 0;
};

// A number's token without a leading '+', which from_chars does not take and OBJ writers may write
// (tinyobjloader read it); "+-1" keeps its '+' and is no number.
std::string_view without_plus(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  return token;
}

class ObjReader {
 public:
  ObjReader(const std::string& path, std::string_view text) : path_(path), text_(text) {}

  TriangleMesh read() {
    // Vertices first: a face may name a vertex that a later line defines.
    Lines lines(text_);
    while (lines.next())
      if (lines.is("v")) read_vertex(lines);
    const size_t total = mesh_.vertices.size();

    Lines faces(text_);
    size_t before = 0;  // the vertices defined before this line, which negative indices count back from
    std::vector<uint32_t> corners;
    while (faces.next()) {
      if (faces.is("v")) ++before;
      if (!faces.is("f")) continue;
      corners.clear();
      for (std::string_view token = faces.token(); !token.empty(); token = faces.token())
        corners.push_back(corner(faces.number(), token, before, total));
      if (corners.size() < 3)
        fail(faces.number(), "face has " + std::to_string(corners.size()) +
                                 (corners.size() == 1 ? " vertex" : " vertices") + ", expected at least 3");
      triangulate(corners);
    }
    return std::move(mesh_);
  }

 private:
  [[noreturn]] void fail(size_t line, const std::string& message) const {
    throw std::invalid_argument(shown(path_) + ":" + std::to_string(line) + ": " + message);
  }

  // At least three tokens, each of them entirely a number whose nearest float is finite; x y z are used,
  // the rest (w, or a colour) is not.
  void read_vertex(Lines& line) {
    float xyz[3] = {0, 0, 0};
    int count = 0;
    for (std::string_view token = line.token(); !token.empty(); token = line.token(), ++count) {
      const float value = coordinate(line.number(), token);
      if (count < 3) xyz[count] = value;
    }
    if (count < 3)
      fail(line.number(),
           "vertex has " + std::to_string(count) + " coordinate" + (count == 1 ? "" : "s") + ", expected x y z");
    mesh_.vertices.emplace_back(xyz[0], xyz[1], xyz[2]);
  }

  // The float nearest to the token's decimal value, parsed once, however many digits it has.
  float coordinate(size_t line, std::string_view token) const {
    const std::string_view digits = without_plus(token);
    float value = 0;
    const char* end = digits.data() + digits.size();
    const auto [stop, ec] = std::from_chars(digits.data(), end, value);
    if (stop == end && ec == std::errc() && std::isfinite(value)) return value;
    if (stop == end && ec == std::errc::result_out_of_range) {
      // Too large for a float, or so small that its nearest float is zero (1e-46 is 0, as before).
      double wide = 0;
      const auto [wide_stop, wide_ec] = std::from_chars(digits.data(), end, wide);
      if (wide_stop == end && wide_ec == std::errc() && std::abs(wide) < 1) return std::signbit(wide) ? -0.0f : 0.0f;
    }
    fail(line, "vertex coordinate " + quoted(token) + " is not a finite number");
  }

  // One corner of a face: v, v/vt, v//vn or v/vt/vn. Only v is used; vt and vn must be indices too.
  uint32_t corner(size_t line, std::string_view token, size_t before, size_t total) const {
    std::string_view parts[3];
    size_t count = 0;
    for (size_t start = 0;; ++count) {
      const size_t slash = token.find('/', start);
      if (count == 3) fail(line, "face vertex " + quoted(token) + " has more than v/vt/vn");
      parts[count] = token.substr(start, slash == std::string_view::npos ? slash : slash - start);
      if (slash == std::string_view::npos) break;
      start = slash + 1;
    }
    ++count;
    int64_t index = 0;  // of the vertex, parts[0]
    bool fits = true;
    for (size_t k = 0; k < count; ++k) {
      if (parts[k].empty() && k == 1 && count == 3) continue;  // v//vn
      int64_t value = 0;
      const Whole whole = integer(parts[k], value);
      if (whole == Whole::kNot)
        fail(line, "face vertex " + quoted(token) + " is not v, v/vt, v//vn or v/vt/vn with whole-number indices");
      if (whole == Whole::kFits && value == 0)
        fail(line, "face vertex " + quoted(token) + " has an index 0: OBJ indices count from 1, or back from -1");
      if (k == 0) index = value, fits = whole == Whole::kFits;
    }
    if (fits && index > 0 && uint64_t(index) <= total) return uint32_t(index - 1);
    if (fits && index < 0 && uint64_t(-(index + 1)) < before) return uint32_t(int64_t(before) + index);
    if (parts[0][0] != '-')
      fail(line, "face index " + quoted(parts[0]) + " is past the last vertex: the file has " + std::to_string(total));
    fail(line, "face index " + quoted(parts[0]) + " counts back before the first vertex: " + std::to_string(before) +
                   " vertices precede this line");
  }

  // A whole token of decimal digits with an optional sign, or too large for int64 (then beyond any
  // file's vertices, and never 0).
  enum class Whole { kNot, kFits, kTooLarge };
  static Whole integer(std::string_view token, int64_t& value) {
    const std::string_view digits = without_plus(token);
    const char* end = digits.data() + digits.size();
    const auto [stop, ec] = std::from_chars(digits.data(), end, value);
    if (stop != end || digits.empty()) return Whole::kNot;
    return ec == std::errc() ? Whole::kFits : Whole::kTooLarge;
  }

  // Triangles as written; a quad split along its shorter diagonal, as tinyobjloader split it (in float,
  // the same arithmetic); a polygon of more corners by ear clipping (below).
  void triangulate(const std::vector<uint32_t>& c) {
    if (c.size() == 4) {
      const glm::vec3* v = mesh_.vertices.data();
      const glm::vec3 e02 = v[c[2]] - v[c[0]], e13 = v[c[3]] - v[c[1]];
      const float sqr02 = e02.x * e02.x + e02.y * e02.y + e02.z * e02.z;
      const float sqr13 = e13.x * e13.x + e13.y * e13.y + e13.z * e13.z;
      if (sqr02 < sqr13) {
        mesh_.triangles.emplace_back(c[0], c[1], c[2]);
        mesh_.triangles.emplace_back(c[0], c[2], c[3]);
      } else {
        mesh_.triangles.emplace_back(c[0], c[1], c[3]);
        mesh_.triangles.emplace_back(c[1], c[2], c[3]);
      }
      return;
    }
    clip_ears(c);
  }

  // Ear clipping in the plane that the polygon's Newell normal faces most: from the first corner on, a
  // corner that is not reflex and whose triangle holds no other corner is cut off. A convex polygon
  // becomes the fan from its first corner; a concave one is covered without a triangle outside it. A
  // polygon with no such corner left (self-intersecting, or degenerate) ends as a fan of what remains.
  void clip_ears(const std::vector<uint32_t>& c) {
    const size_t n = c.size();
    glm::dvec3 normal(0.0);
    for (size_t i = 0; i < n; ++i) {
      const glm::dvec3 a = mesh_.vertices[c[i]], b = mesh_.vertices[c[(i + 1) % n]];
      normal += glm::dvec3((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    const glm::dvec3 size = glm::abs(normal);
    const int drop = size.x >= size.y && size.x >= size.z ? 0 : size.y >= size.z ? 1 : 2;
    const int u = (drop + 1) % 3, v = (drop + 2) % 3;   // (u, v, drop) is right-handed
    const double turn = normal[drop] < 0 ? -1.0 : 1.0;  // makes the polygon counter-clockwise in (u, v)
    const auto point = [&](uint32_t corner) {
      const glm::vec3& p = mesh_.vertices[corner];
      return glm::dvec2(p[u], p[v]);
    };
    const auto cross = [turn](glm::dvec2 a, glm::dvec2 b, glm::dvec2 c) {
      return turn * ((b.x - a.x) * (c.y - a.y) - (b.y - a.y) * (c.x - a.x));
    };

    std::vector<uint32_t> rest(c);
    size_t k = 0, tried = 0;
    while (rest.size() > 3 && tried < rest.size()) {
      const size_t m = rest.size();
      const uint32_t a = rest[k % m], b = rest[(k + 1) % m], e = rest[(k + 2) % m];
      const glm::dvec2 pa = point(a), pb = point(b), pe = point(e);
      bool ear = cross(pa, pb, pe) >= 0;
      for (size_t j = 3; ear && j < m; ++j) {
        const uint32_t other = rest[(k + j) % m];
        const glm::dvec2 q = point(other);
        if (q == pa || q == pb || q == pe) continue;
        ear = !(cross(pa, pb, q) > 0 && cross(pb, pe, q) > 0 && cross(pe, pa, q) > 0);
      }
      if (!ear) {
        k = (k + 1) % m;
        ++tried;
        continue;
      }
      mesh_.triangles.emplace_back(a, b, e);
      rest.erase(rest.begin() + std::ptrdiff_t((k + 1) % m));
      if ((k + 1) % m < k) --k;  // the erased corner stood before a
      tried = 0;
    }
    for (size_t i = 1; i + 1 < rest.size(); ++i) mesh_.triangles.emplace_back(rest[0], rest[i], rest[i + 1]);
  }

  const std::string& path_;
  std::string_view text_;
  TriangleMesh mesh_;
};

}  // namespace

TriangleMesh load_mesh(const std::string& path) {
  const std::string text = read_file(path);
  TriangleMesh mesh = ObjReader(path, text).read();
  try {
    mesh.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("mesh '" + shown(path) + "': " + e.what());
  }
  return mesh;
}

}  // namespace raylab
