#include "raylab/geometry.h"

#include <cmath>
#include <stdexcept>

namespace raylab {

void TriangleMesh::validate() const {
  for (size_t i = 0; i < vertices.size(); ++i) {
    const glm::vec3& p = vertices[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      throw std::invalid_argument("vertex " + std::to_string(i) + " has a NaN or infinite coordinate");
  }
  const size_t n = vertices.size();
  for (size_t i = 0; i < triangles.size(); ++i)
    for (int c = 0; c < 3; ++c)
      if (triangles[i][c] >= n)
        throw std::invalid_argument("triangle " + std::to_string(i) + " refers to vertex " +
                                    std::to_string(triangles[i][c]) + " but the mesh has " +
                                    std::to_string(n) + " vertices");
}

}  // namespace raylab
