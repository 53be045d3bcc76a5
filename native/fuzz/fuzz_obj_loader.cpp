// libFuzzer over the OBJ loader: any bytes either load as a valid mesh (finite vertices, indices in range)
// or throw the loader's error; anything else (a crash, a sanitizer report, a bad mesh) is a finding.
#include "raylab/mesh_io.h"

#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

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
  } catch (const std::exception&) {
    // A refused file: the contract.
  }
  return 0;
}
