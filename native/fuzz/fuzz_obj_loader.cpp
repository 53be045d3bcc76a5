// libFuzzer over the OBJ loader: any bytes either load as a valid mesh (finite vertices, indices in range)
// or throw the loader's error, whose message names the file and is UTF-8 (Python makes a str of it);
// anything else (a crash, a sanitizer report, a bad mesh, a bad message) is a finding.
#include "raylab/mesh_io.h"

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

namespace {

// Well-formed UTF-8 by RFC 3629's table (no overlong forms, no surrogates, nothing past U+10FFFF).
bool is_utf8(const std::string& s) {
  for (size_t i = 0; i < s.size();) {
    const unsigned char c = static_cast<unsigned char>(s[i]);
    size_t length = c < 0x80                 ? 1
                    : c >= 0xc2 && c <= 0xdf ? 2
                    : c >= 0xe0 && c <= 0xef ? 3
                    : c >= 0xf0 && c <= 0xf4 ? 4
                                             : 0;
    if (length == 0 || i + length > s.size()) return false;
    for (size_t k = 1; k < length; ++k) {
      const unsigned char b = static_cast<unsigned char>(s[i + k]);
      unsigned char low = 0x80, high = 0xbf;
      if (k == 1 && c == 0xe0) low = 0xa0;
      if (k == 1 && c == 0xed) high = 0x9f;
      if (k == 1 && c == 0xf0) low = 0x90;
      if (k == 1 && c == 0xf4) high = 0x8f;
      if (b < low || b > high) return false;
    }
    i += length;
  }
  return true;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string path = "/tmp/raylab_fuzz_" + std::to_string(getpid()) + ".obj";
  if (FILE* file = std::fopen(path.c_str(), "wb")) {
    std::fwrite(data, 1, size, file);
    std::fclose(file);
  } else {
    return 0;
  }
  try {
    const raylab::TriangleMesh mesh = raylab::load_mesh(path);
    for (const auto& v : mesh.vertices)
      if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) std::abort();
    for (const auto& t : mesh.triangles)
      for (int c = 0; c < 3; ++c)
        if (t[c] >= mesh.vertices.size()) std::abort();
  } catch (const std::exception& e) {
    // A refused file: the contract, if the message says which file in text Python can hold.
    const std::string message = e.what();
    if (message.find(path) == std::string::npos || !is_utf8(message)) std::abort();
  }
  return 0;
}
