#include "raylab/mesh_io.h"

#include <tiny_obj_loader.h>

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <system_error>

namespace raylab {

namespace {

// fopen() would stop at a NUL and open another file than the one named, and a directory opens as
// an empty stream; both are refused before anything is read.
void check_path(const std::string& path) {
  if (path.find('\0') != std::string::npos)
    throw std::invalid_argument("mesh path contains a NUL character: '" + std::string(path.c_str()) + "\\0...'");
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec))
    throw std::invalid_argument("cannot read mesh '" + path + "': it is a directory");
}

std::string read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read mesh '" + path + "': " + std::strerror(errno));
  std::ostringstream text;
  text << in.rdbuf();
  if (in.bad()) throw std::runtime_error("cannot read mesh '" + path + "': read error");
  return text.str();
}

bool is_blank(char c) { return c == ' ' || c == '\t'; }

// A whole token as a finite float. tinyobjloader reads a leading '+' too; from_chars does not.
bool finite_float(std::string_view token) {
  if (token.size() > 1 && token[0] == '+' && token[1] != '-') token.remove_prefix(1);
  double value = 0.0;
  const auto [end, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && end == token.data() + token.size() && std::isfinite(value) &&
         std::abs(value) <= double(std::numeric_limits<float>::max());
}

[[noreturn]] void line_error(const std::string& path, size_t line, const std::string& message) {
  throw std::invalid_argument(path + ":" + std::to_string(line) + ": " + message);
}

std::string quoted(std::string_view token) {
  constexpr size_t kLongest = 40;  // a token of a binary file can be the whole file
  std::string text = "'";
  text.append(token.substr(0, kLongest));
  text.append(token.size() > kLongest ? "...'" : "'");
  return text;
}

// tinyobjloader reads a missing coordinate as 0 and an unreadable one ("nan", "a", "1,5") as 0 or as
// its leading digits, so a broken file would load as a plausible mesh. Every `v` line is checked
// here first, split into lines and tokens as tinyobjloader splits them: at least three tokens, each
// of them entirely a finite float.
void check_vertex_lines(const std::string& path, std::string_view text) {
  size_t line = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    ++line;
    size_t end = text.find_first_of("\r\n", pos);
    if (end == std::string_view::npos) end = text.size();
    std::string_view s = text.substr(pos, end - pos);
    pos = end + (text.compare(end, 2, "\r\n") == 0 ? 2 : 1);  // \r\n, \n or a lone \r ends a line

    size_t i = 0;
    while (i < s.size() && is_blank(s[i])) ++i;
    if (!(i + 1 < s.size() && s[i] == 'v' && is_blank(s[i + 1]))) continue;
    i += 2;
    int coordinates = 0;
    while (true) {
      while (i < s.size() && is_blank(s[i])) ++i;
      if (i == s.size()) break;
      size_t j = i;
      while (j < s.size() && !is_blank(s[j])) ++j;
      const std::string_view token = s.substr(i, j - i);
      if (!finite_float(token))
        line_error(path, line, "vertex coordinate " + quoted(token) + " is not a finite number");
      ++coordinates;
      i = j;
    }
    if (coordinates < 3)
      line_error(path, line, "vertex has " + std::to_string(coordinates) + " coordinate" +
                                 (coordinates == 1 ? "" : "s") + ", expected x y z");
  }
}

}  // namespace

TriangleMesh load_mesh(const std::string& path) {
  check_path(path);
  const std::string text = read_file(path);
  check_vertex_lines(path, text);

  tinyobj::ObjReaderConfig config;
  config.triangulate = true;
  config.vertex_color = false;
  tinyobj::ObjReader reader;
  // From the text already checked (no second read that could see another file); materials are not
  // used, so no .mtl is read.
  if (!reader.ParseFromString(text, std::string(), config))
    throw std::runtime_error("cannot read mesh '" + path + "': " +
                             (reader.Error().empty() ? std::string("unknown error") : reader.Error()));
  const tinyobj::attrib_t& attrib = reader.GetAttrib();
  TriangleMesh mesh;
  mesh.vertices.resize(attrib.vertices.size() / 3);
  for (size_t i = 0; i < mesh.vertices.size(); ++i)
    mesh.vertices[i] = {attrib.vertices[3 * i], attrib.vertices[3 * i + 1], attrib.vertices[3 * i + 2]};
  for (const tinyobj::shape_t& shape : reader.GetShapes()) {
    const auto& idx = shape.mesh.indices;
    for (size_t f = 0; f + 2 < idx.size(); f += 3)
      mesh.triangles.push_back({uint32_t(idx[f].vertex_index), uint32_t(idx[f + 1].vertex_index),
                                uint32_t(idx[f + 2].vertex_index)});
  }
  try {
    mesh.validate();
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument("mesh '" + path + "': " + e.what());
  }
  return mesh;
}

}  // namespace raylab
