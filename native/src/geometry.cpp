#include "raylab/geometry.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace raylab {

namespace {

std::string vertex_text(size_t i, const glm::vec3& p) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "vertex %zu (%.9g, %.9g, %.9g)", i, double(p.x), double(p.y), double(p.z));
  return buf;
}

}  // namespace

void TriangleMesh::validate() const {
  for (size_t i = 0; i < vertices.size(); ++i) {
    const glm::vec3& p = vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw std::invalid_argument("vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
    const float m = std::max({std::abs(p.x), std::abs(p.y), std::abs(p.z)});
    if (m > kMaxCoordinate)
      throw std::invalid_argument(vertex_text(i, p) +
                                  " has a coordinate beyond the limit of 2^61 (about 2.3e18) in absolute value, "
                                  "past which the float intersection tests are no longer exact; scale the mesh down");
  }
  const size_t n = vertices.size();
  for (size_t i = 0; i < triangles.size(); ++i)
    for (int c = 0; c < 3; ++c)
      if (triangles[i][c] >= n)
        throw std::invalid_argument("triangle " + std::to_string(i) + " refers to vertex " +
                                    std::to_string(triangles[i][c]) + " but the mesh has " + std::to_string(n) +
                                    " vertices");
}

}  // namespace raylab
